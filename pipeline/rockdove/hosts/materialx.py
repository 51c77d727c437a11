"""The ``materialx`` and ``materialx_physical`` hosts: the asset's ``baked`` and ``physical`` MaterialX networks,
read from the written USD as Hydra's HdMtlx does, as GLSL by MaterialX's ``GlslShaderGenerator``, drawn offscreen
in the project's EGL (:mod:`rockdove.hosts.materialx_gl`). OpenPBR's GLSL thin film is an approximation, so
``materialx_physical`` is judged on green, purple and hue-class agreement (docs/design.md, "Hosts")."""

from __future__ import annotations

from typing import Any, NamedTuple

from ..usd.layout import resolve_root_layer
from . import glsl
from .base import Host, HostError, save_pngs

#: ``shading`` variant -> the input its feather network's base colour comes from (set black: the film lobe alone).
BASE_COLOUR = {"baked": "StructuralMix.bg", "physical": "MtlxPhysicalSurface.base_color"}


class VariantHost(Host):
    """A host drawing the asset's ``shading`` variant ``variant`` (``preview``: the UsdPreviewSurface, always)."""

    def cannot_draw(self, asset_path: str) -> str | None:
        return None if self.variant == "preview" else missing_variant(asset_path, self.variant)


class MaterialXHost(VariantHost):
    """The asset's MaterialX network for ``variant`` as MaterialX's generated GLSL (module docstring)."""

    def unavailable(self) -> str | None:
        """None when MaterialX's GLSL generator and an offscreen GL context (the glsl host's) can be used."""
        try:
            import MaterialX.PyMaterialXGenGlsl  # noqa: F401
        except ImportError as exc:
            return f"MaterialX is not installed ({exc})"
        return glsl.HOST.unavailable()

    def render(self, asset_path: str, views, out_dir: str | None) -> dict:
        """:meth:`Host.render` of the asset's ``variant`` network; HostError when reading, compiling or GL fails."""
        from ..render.scene import load_scene
        from .materialx_gl import draw

        name, variant, views = self.name, self.variant, list(views)
        try:
            layer = resolve_root_layer(asset_path)
            scene = load_scene(layer, variants={"shading": variant})
            networks = feather_networks(layer, variant)
            import MaterialX.PyMaterialXGenGlsl as mx_glsl
            import MaterialX.PyMaterialXGenShader as mx_gen

            sources = {}
            for path, net in networks.items():  # MaterialX's GLSL of each mesh's surfacematerial, two-sided
                shader = generate(net.doc, net.material, mx_glsl.GlslShaderGenerator.create(), hwTransparency=True)
                vert, frag = (shader.getSourceCode(stage) for stage in (mx_gen.VERTEX_STAGE, mx_gen.PIXEL_STAGE))
                sources[path] = (vert, two_sided(frag))
        except (ValueError, RuntimeError) as exc:
            raise HostError(name, f"cannot turn the asset's MaterialX network into GLSL: {exc}") from None
        except Exception as exc:  # MaterialX raises its own exception types (ExceptionShaderGenError...)
            raise HostError(name, f"MaterialX shader generation failed: {type(exc).__name__}: {exc}") from None
        try:
            images = draw(scene, networks, sources, views, name=name)
        except HostError:
            raise
        except Exception as exc:
            raise HostError(name, f"GL drawing failed: {type(exc).__name__}: {exc}") from None
        if out_dir:
            save_pngs(images, out_dir, name)
        return images


#: The asset's default network for MaterialX hosts (``baked``) and OpenPBR's thin film (``physical``).
BAKED = MaterialXHost("materialx", "baked", "view_angle")
PHYSICAL = MaterialXHost("materialx_physical", "physical", "view_angle")


def missing_variant(asset_path: str, variant: str) -> str | None:
    """Why a host cannot draw this asset (it carries no ``shading`` variant ``variant``), else None."""
    from pxr import Usd

    stage = Usd.Stage.Open(resolve_root_layer(asset_path), Usd.Stage.LoadNone)
    root = stage.GetDefaultPrim()
    vsets = root.GetVariantSets() if root else None
    have = list(vsets.GetVariantSet("shading").GetVariantNames()) if vsets and vsets.HasVariantSet("shading") else []
    return None if variant in have else f"the asset carries no {variant!r} shading variant (it has {have})"


# -- the asset's MaterialX network -> GLSL ----------------------------------------------------------------------
def generate(doc, material_name: str, generator, **options):
    """MaterialX's ``generator`` run on ``material_name`` with colour management and images flipped (first row)."""
    import MaterialX as mx
    import MaterialX.PyMaterialXGenShader as mx_gen

    if (node := doc.getNode(material_name)) is None:
        raise ValueError(f"material_name={material_name!r} is not a node of the MaterialX document")
    ctx = mx_gen.GenContext(generator)
    ctx.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
    cms = mx_gen.DefaultColorManagementSystem.create(generator.getTarget())
    cms.loadLibrary(doc.getDataLibrary() or doc)
    generator.setColorManagementSystem(cms)
    opts = ctx.getOptions()
    opts.targetColorSpaceOverride = "lin_rec709"
    opts.fileTextureVerticalFlip = True
    for name, value in options.items():
        setattr(opts, name, value)
    return generator.generate(material_name, node, ctx)


#: Declared at the top of the generated main(): the interpolated normal flipped towards the viewer.
_TWO_SIDED = ("vec3 rdNormalWorld = dot(vd.normalWorld, u_viewPosition - vd.positionWorld) < 0.0 ? "
              "-vd.normalWorld : vd.normalWorld;")


def two_sided(pixel_source: str) -> str:
    """The generated pixel shader with its normal made two-sided (the host's double-sided rule)."""
    head, sep, body = pixel_source.partition("void main()\n{\n")
    if not sep or "vd.normalWorld" not in body:
        raise ValueError("the generated pixel shader has no main() reading vd.normalWorld")
    return head + sep + "    " + _TWO_SIDED + "\n" + body.replace("vd.normalWorld", "rdNormalWorld")


class Network(NamedTuple):
    """A mesh's MaterialX network: the document, its ``surfacematerial``'s name, each image node's file."""

    doc: Any  # MaterialX.Document
    material: str
    files: dict[str, str]


def feather_networks(layer: str, variant: str) -> dict[str, Network]:
    """Mesh path -> :class:`Network` of each mesh with a MaterialX material."""
    from pxr import Usd, UsdGeom, UsdShade

    from ..usd.material import load_mtlx_libraries, usd_to_mtlx_document

    if reason := missing_variant(layer, variant):
        raise ValueError(f"asset {layer!r}: {reason}")
    stage = Usd.Stage.Open(layer, Usd.Stage.LoadAll)
    root = stage.GetDefaultPrim()
    stage.SetEditTarget(stage.GetSessionLayer())
    root.GetVariantSets().GetVariantSet("shading").SetVariantSelection(variant)
    library = load_mtlx_libraries()
    out = {}
    for prim in Usd.PrimRange(root):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        if not (material := UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]):
            continue
        output = material.GetSurfaceOutput("mtlx")  # not ComputeSurfaceSource: it falls back to the universal one
        sources = output.GetConnectedSources()[0] if output else []
        if not sources:
            continue
        surface = UsdShade.Shader(sources[0].source.GetPrim())
        primvars = {pv.GetPrimvarName() for pv in UsdGeom.PrimvarsAPI(prim).GetPrimvars()}
        doc = usd_to_mtlx_document(surface, library, primvars)  # its values checked: none can be code
        files = {}
        for child in material.GetPrim().GetChildren():
            file_input = UsdShade.Shader(child).GetInput("file") if child.IsA(UsdShade.Shader) else None
            value = file_input.Get() if file_input else None
            if value is not None and doc.getNode(child.GetName()) is not None:
                files[child.GetName()] = value.resolvedPath or value.path
        out[str(prim.GetPath())] = Network(doc, f"{material.GetPrim().GetName()}_mtlx", files)
    if not out:
        raise ValueError(f"asset {layer!r}: no mesh is bound to a material with outputs:mtlx:surface")
    return out



"""Material networks: the UsdPreviewSurface networks and the MaterialX thin-film network (docs/design.md, "USD asset").

The feather's ``outputs:mtlx:surface`` is ``materials/thinfilm.mtlx`` copied node for node into ``ND_*`` shaders:
the document is data, never spelt here; the build sets only its parameters. The ``shading`` variant connects
``MtlxBakedSurface`` (the LUT) or ``MtlxPhysicalSurface`` (OpenPBR: ``thin_film_thickness`` in micrometres,
``thin_film_ior`` one real index at :data:`rockdove.usd.stage.FILM_IOR_WAVELENGTH_NM`, on ``specular_ior``)."""

from __future__ import annotations

import functools
import os

from .. import resources
from ..errors import UsageError
from .shader_values import problem

#: The colour space of thinfilm.mtlx (its ``colorspace`` attribute): linear Rec.709, the project's working space.
MTLX_WORKING_SPACE = "lin_rec709"
#: MaterialX surfacematerial names in thinfilm.mtlx, by shading variant.
MTLX_MATERIALS = {"baked": "ThinFilmBaked", "physical": "ThinFilmPhysical"}
#: Texture roles -> file names under textures/ (docs/design.md, "Textures").
TEXTURE_FILES = {
    "lut": "thinfilm_lut.exr",
    "feather_base": "feather_base.png",
    "feather_mask": "feather_mask.png",
    "feather_preview": "feather_preview.png",
    "body_base": "body_base.png",
    "plumage_base": "plumage_base.png",
    "plumage_normal": "plumage_normal.png",
}
#: The feather mesh's texcoord primvar into the preview atlas (textures_io), authored by rockdove.usd.stage and read
#: by the preview material.
PREVIEW_PRIMVAR = "previewST"
#: shading variant -> the MaterialX surface shader node of thinfilm.mtlx it connects
MTLX_SURFACES = {"baked": "MtlxBakedSurface", "physical": "MtlxPhysicalSurface"}
#: image nodes of thinfilm.mtlx -> texture role
_MTLX_IMAGES = {"LutTexture": "lut", "BaseColorTexture": "feather_base", "MaskTexture": "feather_mask"}
#: Roughness of the universal previews: 1 with metallic 0 is as close to Lambert as UsdPreviewSurface gets.
PREVIEW_ROUGHNESS = 1.0
#: Opacity cut of the feather cards (docs/design.md, "Shading model").
OPACITY_THRESHOLD = 0.5

# MaterialX type -> Sdf value type name
_SDF_TYPES = {
    "float": "Float", "integer": "Int", "boolean": "Bool", "string": "String", "filename": "Asset",
    "color3": "Color3f", "color4": "Color4f", "vector2": "Float2", "vector3": "Float3", "vector4": "Float4",
    "matrix33": "Matrix3d", "surfaceshader": "Token", "material": "Token", "BSDF": "Token", "EDF": "Token",
}


def texture_asset_paths() -> dict[str, str]:
    """Texture role -> asset path as authored in the layers (``./textures/<file>``)."""
    return {role: f"./textures/{name}" for role, name in TEXTURE_FILES.items()}


@functools.lru_cache(maxsize=1)
def load_mtlx_libraries():
    """The MaterialX standard data libraries as one document, read once per process (~65 ms). Shared: callers use
    it as a data library (``setDataLibrary``, ``getNodeDef``) and must not change it."""
    import MaterialX as mx

    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    return lib


def load_thinfilm_document():
    """``materials/thinfilm.mtlx`` as a MaterialX document, the standard libraries its data library."""
    import MaterialX as mx

    doc = mx.createDocument()
    mx.readFromXmlFile(doc, os.fspath(resources.path("materials/thinfilm.mtlx")))
    doc.setDataLibrary(load_mtlx_libraries())
    return doc


def _usd_value(mx_input, type_name: str):
    from pxr import Gf, Sdf

    value = mx_input.getValue()
    if type_name == "filename":
        path = str(value)
        return Sdf.AssetPath(path if path.startswith(("./", "../", "/")) else f"./{path}")
    vec = {"vector2": Gf.Vec2f, "color3": Gf.Vec3f, "vector3": Gf.Vec3f, "color4": Gf.Vec4f, "vector4": Gf.Vec4f}
    if type_name in vec:
        return vec[type_name](*value.asTuple())
    if type_name == "matrix33":
        return Gf.Matrix3d(*(value[i, j] for i in range(3) for j in range(3)))
    return value


def mtlx_nodes(doc) -> list:
    """Top-level shading nodes of a document, in document order, without the surfacematerial nodes."""
    return [n for n in doc.getNodes() if n.getType() != "material"]


def upstream_nodes(doc, roots) -> set:
    """Names of the nodes ``roots`` (node names) depend on, themselves included (MaterialX's graph traversal)."""
    return set(roots) | {e.getUpstreamElement().getName() for r in roots for e in doc.getNode(r).traverseGraph()}


def copy_mtlx_network(doc, material, roots=None) -> dict:
    """Copy the nodes of ``doc`` (all, or ``roots`` and their upstream) into ``material``: node name -> shader."""
    from pxr import Sdf, UsdShade

    stage = material.GetPrim().GetStage()
    base = material.GetPath()
    keep = upstream_nodes(doc, roots) if roots is not None else None
    copied = [n for n in mtlx_nodes(doc) if keep is None or n.getName() in keep]
    shaders = {}
    for node in copied:
        if (nodedef := node.getNodeDef()) is None:
            raise UsageError(f"MaterialX node {node.getName()!r} ({node.getCategory()}) has no nodedef")
        shader = UsdShade.Shader.Define(stage, base.AppendChild(node.getName()))
        shader.SetShaderId(nodedef.getName())
        for out in nodedef.getActiveOutputs():  # "out", or a multi-output node's own (UsdUVTexture: rgb, a...)
            shader.CreateOutput(out.getName(), getattr(Sdf.ValueTypeNames, _SDF_TYPES[out.getType()]))
        shaders[node.getName()] = shader
    for node in copied:
        shader = shaders[node.getName()]
        for inp in node.getInputs():
            t = inp.getType()
            usd_in = shader.CreateInput(inp.getName(), getattr(Sdf.ValueTypeNames, _SDF_TYPES[t]))
            if upstream := inp.getNodeName():
                usd_in.ConnectToSource(shaders[upstream].ConnectableAPI(), inp.getOutputString() or "out")
            else:
                usd_in.Set(_usd_value(inp, t))
            if inp.hasColorSpace():
                usd_in.GetAttr().SetColorSpace(inp.getColorSpace())
    return shaders


def lut_info(lut) -> dict:
    """The values of a ThinFilmLUT the material and the schema need, as plain (cacheable) data."""
    md = dict(lut.metadata)
    return {"n_angle": int(lut.n_angle), "n_thickness": int(lut.n_thickness),
            "angle_warp_gamma": float(lut.angle_warp_gamma),
            "thickness_range_nm": (float(lut.thickness_range_nm[0]), float(lut.thickness_range_nm[1])),
            "colour_space": str(lut.colour_space), "illuminant": str(md.get("illuminant", "D65")),
            "observer": str(md.get("observer", "CIE 1931 2 Degree Standard Observer"))}


def lut_transform(lut: dict) -> tuple:
    """``LutTransform`` of thinfilm.mtlx, row-major: (x, thickness_nm, 1) @ it = (u, v, 1), the LUT texel centres of
    pipeline/rockdove/lut/table.py: u = (x (N - 1) + 0.5) / N, v = (y (M - 1) + 0.5) / M, y = (d - lo) / (hi - lo)
    ((hi - lo) floored at 1e-6 nm: a one-row LUT reads v = 0.5)."""
    n, m = lut["n_angle"], lut["n_thickness"]
    lo, hi = lut["thickness_range_nm"]
    v_per_nm = (m - 1) / (m * max(hi - lo, 1e-6))
    return ((n - 1) / n, 0.0, 0.0, 0.0, v_per_nm, 0.0, 0.5 / n, 0.5 / m - lo * v_per_nm, 1.0)


def _preview_texture(material, name: str, file: str, st_output, *, colour_space: str, wrap: str = "clamp"):
    from pxr import Sdf, UsdShade

    tex = UsdShade.Shader.Define(material.GetPrim().GetStage(), material.GetPath().AppendChild(name))
    tex.SetShaderId("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(file))
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(st_output)
    for name, value in (("wrapS", wrap), ("wrapT", wrap), ("sourceColorSpace", colour_space)):
        tex.CreateInput(name, Sdf.ValueTypeNames.Token).Set(value)
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    tex.CreateOutput("a", Sdf.ValueTypeNames.Float)
    return tex


def _preview_surface(material):
    """The material's ``PreviewSurface`` (UsdPreviewSurface), connected to its universal surface output."""
    from pxr import Sdf, UsdShade

    surf = UsdShade.Shader.Define(material.GetPrim().GetStage(), material.GetPath().AppendChild("PreviewSurface"))
    surf.SetShaderId("UsdPreviewSurface")
    surf.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(PREVIEW_ROUGHNESS)
    surf.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    material.CreateSurfaceOutput().ConnectToSource(surf.CreateOutput("surface", Sdf.ValueTypeNames.Token))
    return surf


def _st_reader(material, varname: str = "st"):
    """The material's ``StReader``: its ``result`` output, the primvar ``varname``."""
    from pxr import Sdf, UsdShade

    reader = UsdShade.Shader.Define(material.GetPrim().GetStage(), material.GetPath().AppendChild("StReader"))
    reader.SetShaderId("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set(varname)  # a string, not a token (USD >= 20.11)
    return reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)


def author_feather_material(stage, path, *, lut: dict | None, film_ior: float, textures: dict | None = None,
                            variants=("baked", "physical"), substrate_ior: float = 1.0):
    """Define the feather material: the preview network and the MaterialX nodes of the ``variants``. ``film_ior``
    and ``substrate_ior`` (relative to the incident medium) are OpenPBR's ``thin_film_ior`` and ``specular_ior``."""
    from pxr import Gf, Sdf, UsdShade

    textures = {**texture_asset_paths(), **(textures or {})}
    variants = tuple(variants)
    if not variants or any(v not in MTLX_SURFACES for v in variants) or len(set(variants)) != len(variants):
        raise UsageError(f"variants={variants!r}; allowed: distinct names from {sorted(MTLX_SURFACES)}")
    if lut is None and "baked" in variants:
        raise UsageError(f"lut=None with variants={variants!r}: the baked variant needs a LUT (use ('physical',))")
    material = UsdShade.Material.Define(stage, path)
    # universal network: the preview atlas through the mesh's previewST (one tile per card thickness)
    st = _st_reader(material, PREVIEW_PRIMVAR)
    preview_tex = _preview_texture(material, "PreviewTexture", textures["feather_preview"], st, colour_space="sRGB")
    surf = _preview_surface(material)
    surf.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(preview_tex.GetOutput("rgb"))
    surf.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(preview_tex.GetOutput("a"))
    surf.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(OPACITY_THRESHOLD)

    # MaterialX network, copied from materials/thinfilm.mtlx, then the build's values
    shaders = copy_mtlx_network(load_thinfilm_document(), material, roots=[MTLX_SURFACES[v] for v in variants])
    values = {"FilmIor": float(film_ior), "SubstrateIor": float(substrate_ior)}
    if lut is not None:
        values.update({"LutTransform": Gf.Matrix3d(*lut_transform(lut)),
                       "LutAngleWarpExponent": 1.0 / float(lut["angle_warp_gamma"]) - 1.0})
    for name, value in values.items():
        if name in shaders:  # e.g. FilmIor only feeds the physical surface
            shaders[name].GetInput("value").Set(value)
    for name, role in _MTLX_IMAGES.items():
        if name in shaders:
            shaders[name].GetInput("file").Set(Sdf.AssetPath(textures[role]))
    if "LutTexture" in shaders:
        # the space the LUT was baked in (a MaterialX name: lin_rec709, acescg), never "raw", which MaterialX and
        # Storm do not know ("Unsupported color space transform from raw to lin_rec709")
        shaders["LutTexture"].GetInput("file").GetAttr().SetColorSpace(str(lut["colour_space"]))
    default = "baked" if "baked" in variants else variants[0]
    material.CreateSurfaceOutput("mtlx").ConnectToSource(shaders[MTLX_SURFACES[default]].GetOutput("out"))
    return material


def _mx_value_string(value, mx_type: str) -> str:
    if mx_type == "filename":
        return value.path
    if mx_type == "boolean":
        return "true" if value else "false"
    if mx_type == "integer":
        return str(int(value))
    if mx_type == "float":
        return repr(float(value))
    if mx_type == "matrix33":
        return ", ".join(repr(float(value[i][j])) for i in range(3) for j in range(3))
    if mx_type.startswith(("color", "vector")):
        return ", ".join(repr(float(x)) for x in value)
    return str(value)


def usd_to_mtlx_document(surface_shader, library=None, primvars=None):
    """The MaterialX document of the shaders upstream of ``surface_shader``, as Hydra's HdMtlx rebuilds it, so the
    *authored* network is checked. UsageError for an unknown id or input, or a value that could be code."""
    import MaterialX as mx
    from pxr import UsdShade

    library = library or load_mtlx_libraries()
    doc = mx.createDocument()
    doc.setDataLibrary(library)
    doc.setColorSpace(MTLX_WORKING_SPACE)
    done = {}

    def add(shader):
        name = shader.GetPath().name
        if name in done:
            return done[name]
        sid = shader.GetShaderId() or ""
        if (nodedef := library.getNodeDef(sid)) is None:
            raise UsageError(f"{shader.GetPath()}: info:id {sid!r} is not a MaterialX nodedef")
        node = doc.addNode(nodedef.getNodeString(), name, nodedef.getType())
        node.setNodeDefString(sid)
        done[name] = node
        for inp in shader.GetInputs():
            if (mx_in := nodedef.getActiveInput(inp.GetBaseName())) is None:
                raise UsageError(f"{inp.GetAttr().GetPath()}: {sid} declares no input {inp.GetBaseName()!r}")
            target = node.addInput(mx_in.getName(), mx_in.getType())
            sources = inp.GetConnectedSources()[0]
            why = problem(mx_in.getName(), mx_in.getType(), mx_in.getAttribute("enum"), None if sources else inp.Get(),
                          inp.GetAttr().GetColorSpace(), library, primvars)
            if why:  # only values that cannot be code reach a generator (rockdove.usd.shader_values)
                raise UsageError(f"{inp.GetAttr().GetPath()}: {why}")
            if sources:
                up = add(UsdShade.Shader(sources[0].source.GetPrim()))
                target.setNodeName(up.getName())
                if up.getNodeDef().getActiveOutput(sources[0].sourceName) is None:
                    raise UsageError(f"{inp.GetAttr().GetPath()}: {up.getNodeDef().getName()} has no output "
                                     f"{sources[0].sourceName!r}")
                if sources[0].sourceName != "out":
                    target.setOutputString(sources[0].sourceName)
            elif inp.Get() is not None:
                target.setValueString(_mx_value_string(inp.Get(), mx_in.getType()))
            if inp.GetAttr().HasColorSpace():
                target.setColorSpace(inp.GetAttr().GetColorSpace())
        return node

    surface = add(surface_shader)
    material = doc.addNode("surfacematerial", f"{surface_shader.GetPrim().GetParent().GetName()}_mtlx", "material")
    material.addInput("surfaceshader", "surfaceshader").setNodeName(surface.getName())
    return doc


def mtlx_surface_path(material_path, variant: str):
    """Path of the ``out`` output of the MaterialX surface shader a shading variant connects."""
    from pxr import Sdf

    return Sdf.Path(str(material_path)).AppendChild(MTLX_SURFACES[variant]).AppendProperty("outputs:out")


def author_body_material(stage, path, *, texture: str | None = None):
    """Define the body material: UsdPreviewSurface with ``BaseColorTexture`` (body_base.png, sRGB)."""
    from pxr import Sdf, UsdShade

    texture = texture or texture_asset_paths()["body_base"]
    material = UsdShade.Material.Define(stage, path)
    tex = _preview_texture(material, "BaseColorTexture", texture, _st_reader(material), colour_space="sRGB")
    _preview_surface(material).CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        tex.GetOutput("rgb"))
    return material


def author_plumage_material(stage, path, *, textures: dict | None = None):
    """The plumage material: base colour, its alpha cut out, and a normal map (scale 2, bias -1), roughness in alpha."""
    from pxr import Gf, Sdf, UsdShade

    textures = {**texture_asset_paths(), **(textures or {})}
    material = UsdShade.Material.Define(stage, path)
    st = _st_reader(material)
    colour = _preview_texture(material, "BaseColorTexture", textures["plumage_base"], st, colour_space="sRGB")
    normal = _preview_texture(material, "NormalTexture", textures["plumage_normal"], st, colour_space="raw")
    normal.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(2.0, 2.0, 2.0, 1.0))
    normal.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(-1.0, -1.0, -1.0, 0.0))
    surf = _preview_surface(material)
    for name, type_name, source in (("diffuseColor", "Color3f", colour.GetOutput("rgb")),
                                    ("opacity", "Float", colour.GetOutput("a")),
                                    ("normal", "Normal3f", normal.GetOutput("rgb")),
                                    ("roughness", "Float", normal.GetOutput("a"))):
        surf.CreateInput(name, getattr(Sdf.ValueTypeNames, type_name)).ConnectToSource(source)
    surf.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(OPACITY_THRESHOLD)
    return material


def author_constant_material(stage, path, colour_linear):
    """Define a UsdPreviewSurface material with a constant linear diffuse colour (beak, eyes, legs...)."""
    from pxr import Gf, Sdf, UsdShade

    c = tuple(float(v) for v in colour_linear)
    material = UsdShade.Material.Define(stage, path)
    _preview_surface(material).CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*c))
    return material

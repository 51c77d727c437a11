"""rockdove for Blender: USD import builds the physical thin-film material of rockdove assets.

Install: Edit > Preferences > Add-ons > Install from Disk (``rockdove_blender.zip``, written by
``rockdove blender-addon --out DIR``), or ``bpy.ops.preferences.addon_install(filepath=ZIP)`` and
``bpy.ops.preferences.addon_enable(module="rockdove_blender")``. Then a plain File > Import > USD
(``bpy.ops.wm.usd_import``) of a rockdove asset (``pigeon.usda`` or ``pigeon.usdz``) gives the neck feathers
a Principled BSDF whose thin film is the asset's film, so Cycles shows the green/purple shimmer changing with
view and light. Blender 4.2 or later (the Principled BSDF's thin film and ``bpy.types.USDHook``).

What the hook reads (the rockdove asset's own records, docs/design.md "USD asset"):

- a mesh is a rockdove film when it carries ``rockdove:film:cauchyA`` (``RockDoveThinFilmAPI``; Blender's
  importer drops the applied schema but the stage keeps its attributes);
- thickness: the point attribute the importer makes of the primvar ``rockdove:film:thicknessPrimvar``
  (``thickness``, nm) -> Principled "Thin Film Thickness" (nm, Blender's unit);
- film index: ``n = cauchyA + cauchyB_nm2 / lambda^2`` at :data:`FILM_IOR_WAVELENGTH_NM` (Blender's film
  has one real index: dispersion is dropped, as in the asset's MaterialX physical variant);
- substrate: ``rockdove:film:substrateIndex`` -> Principled "IOR" (1.0: a film in air; with Blender's
  default 1.5 the paper film's lower interface vanishes and the film shows no colour);
- the feather base colour (``BaseColorTexture``, sRGB, alpha = silhouette) and tip mask (``MaskTexture``, raw)
  of the bound material: ``mix(base BSDF, film BSDF, mask)``, cut out where alpha < 0.5 (binary, no blend).

Assets without ``rockdove:film:*`` attributes are left exactly as Blender's importer made them. The add-on
opens no network connection and writes no file: textures inside a usdz are read through USD's resolver and
packed into the blend file.
"""

bl_info = {
    "name": "rockdove thin film (USD import)",
    "author": "rockdove",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "File > Import > Universal Scene Description",
    "description": "Builds the physical thin-film material of rockdove USD assets on import",
    "category": "Import-Export",
}

import bpy

FILM_PREFIX = "rockdove:film:"
#: Wavelength at which Blender's single film index samples the Cauchy index, nm (the asset's MaterialX physical
#: variant uses the same: rockdove.usd.stage.FILM_IOR_WAVELENGTH_NM).
FILM_IOR_WAVELENGTH_NM = 550.0
#: Opacity cut of the feather cards (the asset's ``opacityThreshold``).
OPACITY_THRESHOLD = 0.5
#: Shader names of the rockdove feather material whose textures the hook reads.
BASE_TEXTURE_SHADER = "BaseColorTexture"
MASK_TEXTURE_SHADER = "MaskTexture"
#: Roughness of the film lobe. Measured in Cycles (sun along the light-sweep views + dim grey world, 200 px):
#: at 0 (a mirror) a sun shows only pin-point glints and the neck takes the world's colour; at 0.4 the lit neck
#: is green with 60 degrees between light and view and purple at 120, the paper's light-driven flip. A
#: verification render sets 0 (the smooth film's mirror lobe, compared with the exact reference).
FILM_ROUGHNESS = 0.4
#: Roughness of the base (as the asset's preview: Lambert-like).
BASE_ROUGHNESS = 1.0
#: Names of the nodes the hook builds (a verification render finds the base BSDF by name to turn it black).
NODE_FILM = "rockdove film"
NODE_BASE = "rockdove base"
NODE_BASE_TEXTURE = "rockdove base colour"
NODE_MASK_TEXTURE = "rockdove tip mask"
#: Custom property set on the materials the hook builds (value: the USD path of the film mesh).
MATERIAL_TAG = "rockdove:thinFilm"


def film_record(prim) -> dict:
    """The ``rockdove:film:*`` attributes of a prim, {} when it is not a rockdove film."""
    out = {}
    for attr in prim.GetAttributes():
        name = attr.GetName()
        if name.startswith(FILM_PREFIX) and attr.HasAuthoredValue():
            out[name[len(FILM_PREFIX):]] = attr.Get()
    return out if "cauchyA" in out else {}


def film_ior(record: dict) -> float:
    """Film index at :data:`FILM_IOR_WAVELENGTH_NM`: ``cauchyA + cauchyB_nm2 / lambda_nm**2``."""
    return float(record["cauchyA"]) + float(record.get("cauchyB_nm2", 0.0)) / FILM_IOR_WAVELENGTH_NM ** 2


def _texture_bytes(asset_path):
    """(file path or None, bytes or None) of a resolved Sdf.AssetPath (a file, or a file inside a usdz)."""
    import os

    from pxr import Ar

    resolved = asset_path.resolvedPath if asset_path is not None else ""
    if not resolved:
        return None, None
    if os.path.isfile(resolved):
        return resolved, None
    asset = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved))
    return None, (bytes(asset.GetBuffer()) if asset is not None else None)


def _load_image(name: str, asset_path, colour_space: str):
    """A Blender image of a texture of the asset: loaded from its file, or packed from the usdz's bytes."""
    path, data = _texture_bytes(asset_path)
    if path is None and data is None:
        return None
    if path is not None:
        image = bpy.data.images.load(path, check_existing=True)
    else:
        image = bpy.data.images.new(name, 8, 8)
        image.pack(data=data, data_len=len(data))
        image.source = "FILE"
    image.colorspace_settings.name = colour_space
    return image


def _shader_file(material_prim, shader_name: str):
    if not material_prim:
        return None
    shader = material_prim.GetChild(shader_name)
    attr = shader.GetAttribute("inputs:file") if shader else None
    return attr.Get() if attr else None


def build_material(name: str, record: dict, base_image, mask_image, uv_name: str, thickness_attribute: str):
    """The physical thin-film material: ``cutout(mix(base, film, mask))``.

    Parameters
    ----------
    record : dict
        :func:`film_record` of the mesh.
    base_image, mask_image : bpy.types.Image or None
        Feather base colour (sRGB, alpha = silhouette) and tip mask; None: base black and opaque, mask 1.
    uv_name : str
        UV map of the feather's ``st``.
    thickness_attribute : str
        Point attribute holding the film thickness, nm.
    """
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    mat[MATERIAL_TAG] = True
    for key, value in record.items():
        if isinstance(value, (int, float, str)):
            mat[FILM_PREFIX + key] = value
    nt = mat.node_tree
    nodes, links = nt.nodes, nt.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")

    film = nodes.new("ShaderNodeBsdfPrincipled")
    film.name = film.label = NODE_FILM
    film.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    film.inputs["Roughness"].default_value = FILM_ROUGHNESS
    film.inputs["IOR"].default_value = float(record.get("substrateIndex", 1.0))
    film.inputs["Thin Film IOR"].default_value = film_ior(record)
    thickness = nodes.new("ShaderNodeAttribute")
    thickness.attribute_type = "GEOMETRY"
    thickness.attribute_name = thickness_attribute
    links.new(thickness.outputs["Fac"], film.inputs["Thin Film Thickness"])

    base = nodes.new("ShaderNodeBsdfPrincipled")
    base.name = base.label = NODE_BASE
    base.inputs["Roughness"].default_value = BASE_ROUGHNESS

    uv = nodes.new("ShaderNodeUVMap")
    uv.uv_map = uv_name
    mix = nodes.new("ShaderNodeMixShader")
    links.new(base.outputs["BSDF"], mix.inputs[1])
    links.new(film.outputs["BSDF"], mix.inputs[2])
    def image_node(node_name, image):  # an image read at the feather's UVs, clamped like the GL sampler
        tex = nodes.new("ShaderNodeTexImage")
        tex.name = tex.label = node_name
        tex.image, tex.extension = image, "EXTEND"
        links.new(uv.outputs["UV"], tex.inputs["Vector"])
        return tex

    if mask_image is not None:
        tex = image_node(NODE_MASK_TEXTURE, mask_image)
        links.new(tex.outputs["Color"], mix.inputs["Fac"])
    else:
        mix.inputs["Fac"].default_value = 1.0

    surface = mix.outputs["Shader"]
    if base_image is not None:
        tex = image_node(NODE_BASE_TEXTURE, base_image)
        links.new(tex.outputs["Color"], base.inputs["Base Color"])
        cut = nodes.new("ShaderNodeMath")
        cut.operation = "GREATER_THAN"  # binary cut-out, like opacityThreshold: 1 where alpha > 0.5
        cut.inputs[1].default_value = OPACITY_THRESHOLD
        links.new(tex.outputs["Alpha"], cut.inputs[0])
        hole = nodes.new("ShaderNodeBsdfTransparent")
        keep = nodes.new("ShaderNodeMixShader")
        links.new(cut.outputs["Value"], keep.inputs["Fac"])
        links.new(hole.outputs["BSDF"], keep.inputs[1])
        links.new(surface, keep.inputs[2])
        surface = keep.outputs["Shader"]
    else:
        base.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    links.new(surface, out.inputs["Surface"])
    for i, node in enumerate(nodes):  # a readable layout for the node editor
        node.location = (-300.0 * (i % 4), -250.0 * (i // 4))
    return mat


def apply_to_import(import_context) -> list:
    """Build the thin-film material of every rockdove film mesh of one USD import.

    Returns
    -------
    list of str
        USD paths of the meshes given a thin-film material (empty for a non-rockdove asset).
    """
    from pxr import UsdShade

    stage = import_context.get_stage()
    done = []
    for path, ids in import_context.get_prim_map().items():
        prim = stage.GetPrimAtPath(path)
        record = film_record(prim) if prim else {}
        if not record:
            continue
        # the prim map gives the object for a mesh prim merged with its parent Xform, else the mesh datablock
        meshes = {i.data for i in ids if isinstance(i, bpy.types.Object) and i.type == "MESH"}
        meshes |= {i for i in ids if isinstance(i, bpy.types.Mesh)}
        objects = [ob for ob in bpy.data.objects if ob.type == "MESH" and ob.data in meshes]
        if not objects:
            continue
        material_prim = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0].GetPrim()
        base = _load_image(f"{prim.GetName()}_base", _shader_file(material_prim, BASE_TEXTURE_SHADER), "sRGB")
        mask = _load_image(f"{prim.GetName()}_mask", _shader_file(material_prim, MASK_TEXTURE_SHADER), "Non-Color")
        thickness_attribute = str(record.get("thicknessPrimvar") or "thickness")
        for ob in objects:
            mesh = ob.data
            if thickness_attribute not in mesh.attributes:
                print(f"rockdove: {path}: no '{thickness_attribute}' attribute on the imported mesh; left as imported")
                continue
            uv_name = "st" if "st" in mesh.uv_layers else (mesh.uv_layers[0].name if mesh.uv_layers else "st")
            mat = build_material(f"{prim.GetName()}ThinFilm", record, base, mask, uv_name, thickness_attribute)
            mat[MATERIAL_TAG] = str(path)
            if len(ob.material_slots) == 0:
                mesh.materials.append(mat)
            for slot in ob.material_slots:
                slot.material = mat
            done.append(str(path))
    return done


class RockdoveUSDHook(bpy.types.USDHook):
    """Builds the physical thin-film material of rockdove assets when a USD file is imported."""

    bl_idname = "rockdove_usd_hook"
    bl_label = "rockdove thin film"
    bl_description = "Build the Principled thin-film material of rockdove assets on USD import"

    @staticmethod
    def on_import(import_context):
        try:
            done = apply_to_import(import_context)
        except Exception as exc:  # never break Blender's own import; say what happened
            print(f"rockdove: thin-film material not built ({type(exc).__name__}: {exc}); "
                  "the asset keeps Blender's UsdPreviewSurface material")
            return False
        if done:
            print(f"rockdove: thin-film material on {', '.join(done)}")
        return True


def register():
    bpy.utils.register_class(RockdoveUSDHook)


def unregister():
    bpy.utils.unregister_class(RockdoveUSDHook)

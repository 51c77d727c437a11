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

An animated stage (``pigeon_walk.usda``, which selects the ``motion`` variant) imports as an armature playing the
motion as an action, over the frame range the importer sets; the hook sets the frame rate (:func:`match_frame_rate`).

Blender versions: 4.4 and later hand the hook the import's prim map; 4.2 and 4.3 do not, and the hook finds the
objects with :func:`find_imported`. As a Python module (``pip install bpy``) the hook needs bpy's bundled ``pxr``,
which :func:`bundled_pxr` puts on ``sys.path``; the 4.2 and 4.3 wheels ship none, so there (and in a Blender
without USD hooks) :func:`register` says so in one line and imports stay Blender's own. A film record that fails
:func:`check_record` is named in one line and left as imported; so are assets without ``rockdove:film:*``
attributes, exactly as Blender's importer made them. The add-on opens no network connection and writes no file:
textures inside a usdz are read through USD's resolver and packed into the blend file.
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

import importlib.util
import math
import os
import sys

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


def _resolved(asset_path) -> str:
    """The resolved path of an Sdf.AssetPath ("" for none)."""
    return asset_path.resolvedPath if asset_path is not None else ""


def _texture_bytes(asset_path):
    """(file path or None, bytes or None) of a resolved Sdf.AssetPath (a file, or a file inside a usdz)."""
    from pxr import Ar

    resolved = _resolved(asset_path)
    if not resolved:
        return None, None
    if os.path.isfile(resolved):
        return resolved, None
    asset = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved))
    return None, (bytes(asset.GetBuffer()) if asset is not None else None)


def _outside(asset_path, stage) -> str | None:
    """The resolved path of a texture that lies outside the asset (the root layer's folder, or its usdz), else
    None: a texture of the asset, or none."""
    from pxr import Ar

    resolved = _resolved(asset_path)
    if not resolved:
        return None
    outer = Ar.SplitPackageRelativePathOuter(resolved)[0] if Ar.IsPackageRelativePath(resolved) else resolved
    folder = os.path.dirname(os.path.realpath(stage.GetRootLayer().realPath))
    return None if os.path.commonpath([os.path.realpath(outer), folder]) == folder else resolved


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
    """The physical thin-film material ``cutout(mix(base, film, mask))`` of a :func:`film_record`: ``base_image``
    and ``mask_image`` are the feather base colour (sRGB, alpha = silhouette) and tip mask (None: base black and
    opaque, mask 1), read at the UV map ``uv_name``; ``thickness_attribute`` holds the film thickness, nm."""
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


def bundled_pxr() -> str | None:
    """Make Blender's own ``pxr`` Python package importable, before any USD import needs it.

    The USD hooks hand the import's stage to Python as an object of Blender's USD, which only Blender's own
    ``pxr`` can take: without it a bpy-module process aborts on the first USD import (pip's bpy keeps its
    bundled ``pxr`` under ``bpy/<version>/python/.../site-packages``, off ``sys.path``). This puts that
    folder first on ``sys.path`` when ``pxr`` is not imported yet.

    Returns
    -------
    str or None
        None when the ``pxr`` this process will use is Blender's; else why the hook cannot run (one line).
    """
    lib = os.path.join(bpy.utils.resource_path("LOCAL"), "python", "lib")
    sites = [os.path.join(lib, f"python{sys.version_info.major}.{sys.version_info.minor}", "site-packages"),
             os.path.join(lib, "site-packages")]  # Linux and macOS; Windows
    site = next((s for s in sites if os.path.isdir(os.path.join(s, "pxr"))), sites[0])
    bundled = os.path.isdir(os.path.join(site, "pxr"))
    loaded = sys.modules.get("pxr")
    if loaded is not None:
        where, site_real = os.path.realpath(os.path.dirname(loaded.__file__ or "")), os.path.realpath(site)
        if bundled and os.path.commonpath([where, site_real]) != site_real:
            return f"this process imported another USD's pxr ({where}) before Blender's ({site})"
        return None
    if bundled:
        if site not in sys.path:
            sys.path.insert(0, site)
        return None
    if not bpy.app.binary_path:  # Blender as a Python module: only its bundled pxr matches its USD
        return (f"the bpy {bpy.app.version_string} module ships no pxr Python package (the 4.2 and 4.3 wheels have none), "
                "so USD import hooks cannot run in it; Blender 4.2+ itself or bpy 4.4+ can")
    if importlib.util.find_spec("pxr") is None:  # else a Blender built on the system's USD, with its pxr
        return f"Blender {bpy.app.version_string} has no pxr Python package"
    return None


def _base_name(name: str) -> str:
    """A Blender ID name without the ``.001`` suffix Blender adds where the name is taken."""
    stem, dot, num = name.rpartition(".")
    return stem if dot and len(num) == 3 and num.isdigit() else name


def find_imported(meshes, candidates) -> dict:
    """The objects that the USD importer made of mesh prims, without a prim map (Blender 4.2 and 4.3).

    ``meshes`` are ``(USD path, point count)`` pairs; ``candidates`` are this import's objects: the ones Blender's
    importer leaves selected (4.2 to 5.0 deselect everything, select what they created, then call the hooks).
    An object is a prim's when its mesh is named after the prim (Blender's ``.001`` suffixes aside), the object
    after the prim or after its parent Xform (where the importer merged the two), its parent object after one of
    the prim's ancestors, and its mesh has the prim's point count.

    Returns
    -------
    dict
        USD path -> list of bpy objects, for the prims that matched.
    """
    out = {}
    for path, n_points in meshes:
        *ancestors, name = str(path).strip("/").split("/")
        found = [ob for ob in candidates if ob.type == "MESH" and _base_name(ob.data.name) == name
                 and _base_name(ob.name) in (name, *ancestors[-1:])
                 and (ob.parent is None or _base_name(ob.parent.name) in ancestors)
                 and len(ob.data.vertices) == n_points]
        if found:
            out[str(path)] = found
    return out


def imported_meshes(import_context, prims) -> dict:
    """USD path -> the mesh objects this import made of it, for ``prims``: by the import's prim map where
    Blender has one (4.4 and later), else by :func:`find_imported` over the objects the importer selected."""
    get_prim_map = getattr(import_context, "get_prim_map", None)
    if get_prim_map is None:
        layer = bpy.context.view_layer or bpy.context.scene.view_layers[0]  # a job's end may have no window
        points = [(p.GetPath(), len(p.GetAttribute("points").Get() or ())) for p in prims]
        return find_imported(points, [ob for ob in layer.objects if ob.select_get(view_layer=layer)])
    prim_map = {str(path): ids for path, ids in get_prim_map().items()}
    out = {}
    for prim in prims:
        ids = prim_map.get(str(prim.GetPath()), [])
        # the object for a mesh prim merged with its parent Xform, else the mesh datablock
        meshes = {i.data for i in ids if isinstance(i, bpy.types.Object) and i.type == "MESH"}
        meshes |= {i for i in ids if isinstance(i, bpy.types.Mesh)}
        objects = [ob for ob in bpy.data.objects if ob.type == "MESH" and ob.data in meshes]
        if objects:
            out[str(prim.GetPath())] = objects
    return out


def check_record(record: dict) -> str | None:
    """None when a film record can be built in Blender, else what is wrong with it (one line)."""
    def number(key, low):
        value = record.get(key, low)
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value >= low
        return None if ok else f"{FILM_PREFIX}{key} = {value!r} is not a finite number >= {low}"

    units = record.get("thicknessUnits", "nm")
    name = record.get("thicknessPrimvar", "thickness")
    return (number("cauchyA", 1.0) or number("substrateIndex", 1.0) or number("cauchyB_nm2", 0.0)
            or (None if film_ior(record) >= 1.0 else f"the film index at {FILM_IOR_WAVELENGTH_NM:g} nm, {film_ior(record)}, is below 1")
            or (None if units == "nm" else f"{FILM_PREFIX}thicknessUnits = {units!r}, not 'nm'")
            or (None if isinstance(name, str) and name.strip() else f"{FILM_PREFIX}thicknessPrimvar = {name!r}"))


def apply_to_import(import_context) -> list:
    """Build the thin-film material of every rockdove film mesh of one USD import.

    Every film is checked before any material is built; a film that fails a check is named in one line and its
    meshes are left as imported.

    Returns
    -------
    list of str
        USD paths of the meshes given a thin-film material (empty for a non-rockdove asset).
    """
    from pxr import UsdGeom, UsdShade

    stage = import_context.get_stage()
    films = {str(p.GetPath()): (p, r) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh) and (r := film_record(p))}
    found = imported_meshes(import_context, [p for p, _ in films.values()]) if films else {}
    plan = []
    for path, objects in found.items():
        prim, record = films[path]
        thickness_attribute = str(record.get("thicknessPrimvar") or "thickness")
        why = check_record(record) or next(
            (f"no '{thickness_attribute}' attribute on the imported mesh {ob.data.name!r}" for ob in objects
             if thickness_attribute not in ob.data.attributes), None)
        material_prim = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0].GetPrim()
        files = [_shader_file(material_prim, name) for name in (BASE_TEXTURE_SHADER, MASK_TEXTURE_SHADER)]
        outside = [o for o in (_outside(f, stage) for f in files) if o]
        why = why or (f"its texture {outside[0]} lies outside the asset, not read" if outside else None)
        if why:
            print(f"rockdove: {path}: {why}; left as imported")
            continue
        plan.append((path, prim, record, objects, thickness_attribute, files))
    done = []
    for path, prim, record, objects, thickness_attribute, (base_file, mask_file) in plan:
        base = _load_image(f"{prim.GetName()}_base", base_file, "sRGB")
        mask = _load_image(f"{prim.GetName()}_mask", mask_file, "Non-Color")
        for ob in objects:
            mesh = ob.data
            uv_name = "st" if "st" in mesh.uv_layers else (mesh.uv_layers[0].name if mesh.uv_layers else "st")
            mat = build_material(f"{prim.GetName()}ThinFilm", record, base, mask, uv_name, thickness_attribute)
            mat[MATERIAL_TAG] = path
            if len(ob.material_slots) == 0:
                mesh.materials.append(mat)
            for slot in ob.material_slots:
                slot.material = mat
        done.append(path)
    return done


def match_frame_rate(stage, render) -> str | None:
    """Blender's importer sets the frame range of an animated stage but not its rate: a stage whose skeleton plays
    an animation (``pigeon_walk.usda``) sets the scene's frame rate to its ``timeCodesPerSecond``; says so."""
    from pxr import UsdSkel

    fps = stage.GetTimeCodesPerSecond()
    if fps <= 0 or abs(render.fps / render.fps_base - fps) < 1e-6 or not any(
            p.IsA(UsdSkel.Skeleton) and UsdSkel.BindingAPI(p).GetAnimationSourceRel().GetTargets()
            for p in stage.Traverse()):
        return None
    render.fps, render.fps_base = max(1, round(fps)), max(1, round(fps)) / fps
    return f"rockdove: frame rate {fps:g} fps, the asset's timeCodesPerSecond"


def on_import(import_context):
    """The ``USDHook.on_import`` of the add-on: never breaks Blender's own import; says what happened."""
    try:
        done = apply_to_import(import_context)
    except Exception as exc:
        print(f"rockdove: thin-film material not built ({type(exc).__name__}: {exc}); "
              "the asset keeps Blender's UsdPreviewSurface material")
        return False
    if done:
        print(f"rockdove: thin-film material on {', '.join(done)}")
    try:
        rate = match_frame_rate(import_context.get_stage(), bpy.context.scene.render)
    except Exception as exc:
        rate = f"rockdove: frame rate left as it was ({type(exc).__name__}: {exc})"
    if rate:
        print(rate)
    return True


#: The registered USDHook class (None: not registered, see :func:`register`).
_hook = None


def register():
    """Register the USD import hook where it can run, else say in one line why not (imports stay Blender's)."""
    global _hook
    usd_hook = getattr(bpy.types, "USDHook", None)
    why = (f"Blender {bpy.app.version_string} has no USD import hooks (bpy.types.USDHook)" if usd_hook is None
           else bundled_pxr())
    if why:
        print(f"rockdove: thin-film material off: {why}; USD imports keep Blender's UsdPreviewSurface material")
        return
    _hook = type("RockdoveUSDHook", (usd_hook,), {
        "__doc__": "Builds the physical thin-film material of rockdove assets when a USD file is imported.",
        "bl_idname": "rockdove_usd_hook", "bl_label": "rockdove thin film",
        "bl_description": "Build the Principled thin-film material of rockdove assets on USD import",
        "on_import": staticmethod(on_import)})
    bpy.utils.register_class(_hook)


def unregister():
    global _hook
    if _hook is not None:
        bpy.utils.unregister_class(_hook)
        _hook = None

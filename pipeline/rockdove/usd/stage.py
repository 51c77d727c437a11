"""The asset's USD layers: interface layer, payload contents, meshes, primvars, extents, shading variants.

Structure (docs/design.md, "USD asset"; the interface-layer + payload pattern of NVIDIA's
usd-exchange-samples):

- ``DIR/pigeon.usda`` (interface): defaultPrim ``/Pigeon``, an Xform of kind ``component`` with assetInfo
  (name, identifier, version) and an extentsHint, ``upAxis = Y``, ``metersPerUnit = 1``, a payload to
  ``./pigeon_payload.usda`` and the variant set ``shading`` = {``baked`` (default), ``physical``}, which
  reconnects ``FeatherMaterial.outputs:mtlx:surface`` (variants are stronger than payloads). The
  configuration's ``shading.variant`` chooses what the set holds (:data:`SHADING_CHOICES`): ``"both"`` (the
  above), ``"baked"`` (only baked) or ``"physical"`` (only physical, the default; an asset without a LUT: no
  LUT texture, no baked MaterialX network, no ``rockdove:lut:*`` attributes).
- ``DIR/pigeon_payload.usda`` (contents, a few lines): sublayers the two layers below, split by what changes
  them, so a film change rewrites the small looks layer and leaves the big geometry layer's bytes as they were:

  - ``DIR/pigeon_looks.usda`` (:data:`LOOKS_LAYER`, stronger): ``/Pigeon/Looks/<Kind>Material`` materials and,
    as an ``over`` on the feather mesh, ``RockDoveThinFilmAPI`` (the film and the LUT). Depends on the film,
    the LUT, the shading choice and the parts' material kinds; text, because people read it.
  - ``DIR/pigeon_geom.usdc`` (:data:`GEOMETRY_LAYER`): ``/Pigeon/Geom/<part>`` meshes, their primvars and
    their material bindings (relationships to the looks' paths). Depends on the bird only; crate, because
    its arrays are big (NVIDIA's UsdAsciiPerformanceChecker: large arrays belong in usdc).

Authoring functions take a stage and return; they never save. :func:`write_layers` and its two halves
:func:`write_geometry` and :func:`write_looks` are the only functions here that write files (into the folder
they are handed). Text layers are written with ``Sdf.Layer.ExportToString`` and the crate layer with
``Sdf.Layer.Export``: no timestamps, attributes in authoring order, so the same inputs give byte-identical
files (tested for both formats).
"""

from __future__ import annotations

import os

import numpy as np

from ..geometry.plumage import CARD_PARTS
from ..geometry.types import drop_unreferenced_points, point_bounds
from .material import (
    PREVIEW_PRIMVAR,
    author_body_material,
    author_constant_material,
    author_feather_material,
    mtlx_surface_path,
    texture_asset_paths,
)

ROOT = "/Pigeon"
INTERFACE_LAYER = "pigeon.usda"
PAYLOAD_LAYER = "pigeon_payload.usda"
#: The payload's sublayers (strongest first): film-dependent looks (text) and bird-only geometry (crate).
LOOKS_LAYER = "pigeon_looks.usda"
GEOMETRY_LAYER = "pigeon_geom.usdc"
SHADING_VARIANT_SET = "shading"
SHADING_VARIANTS = ("baked", "physical")
DEFAULT_SHADING = "baked"
#: configuration ``shading.variant`` -> the variants of the ``shading`` set (the first is the default)
SHADING_CHOICES = {"both": ("baked", "physical"), "baked": ("baked",), "physical": ("physical",)}


def shading_variants(shading: str) -> tuple:
    """The variants an asset carries for a ``shading.variant`` choice (``"both"``, ``"baked"``, ``"physical"``)."""
    if shading not in SHADING_CHOICES:
        raise ValueError(f"shading={shading!r}; allowed: {sorted(SHADING_CHOICES)}")
    return SHADING_CHOICES[shading]
FEATHER_MATERIAL = "feather"
#: Wavelength at which the physical variant's thin_film_ior samples the film's Cauchy index: OpenPBR's film has
#: one real index; 550 nm is next to the peak of the CIE photopic luminosity curve V(lambda) (555 nm), where the
#: colour-matching functions weigh the spectrum most (keratin: n = 1.5515 there, 1.569 at 400 nm, 1.544 at 700 nm).
FILM_IOR_WAVELENGTH_NM = 550.0

PREVIEW_ST_DOC = ("Texture coordinates of this vertex in feather_preview.png, the UsdPreviewSurface atlas: the "
                  "feather's st inside the tile of the card's film thickness (rockdove.usd.textures_io.preview_st).")
THICKNESS_DOC = ("Film (keratin cortex) thickness of the feather barbules at this vertex, in nanometres; the "
                 "thin-film LUT is indexed by it (RockDoveThinFilmAPI rockdove:film:thicknessPrimvar).")


def new_stage(up_axis: str = "Y", meters_per_unit: float = 1.0, *, load_payloads: bool = True):
    """An in-memory stage with the asset's stage metadata set at creation (upAxis, metersPerUnit, defaultPrim).

    ``load_payloads=False`` for the interface layer, whose payload is not written yet while it is authored.

    Returns
    -------
    Usd.Stage
    """
    from .schema import register

    register()  # before the first stage: USD builds its schema registry once
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateInMemory(load=Usd.Stage.LoadAll if load_payloads else Usd.Stage.LoadNone)
    if up_axis not in ("Y", "Z"):
        raise ValueError(f"up_axis must be 'Y' or 'Z', got {up_axis!r}")
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y if up_axis == "Y" else UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, float(meters_per_unit))
    stage.GetRootLayer().defaultPrim = ROOT.lstrip("/")
    return stage


def material_name(kind: str) -> str:
    """Material prim name for a MeshPart.material kind: ``"feather"`` -> ``"FeatherMaterial"``."""
    return f"{kind[:1].upper()}{kind[1:]}Material"


def _extent(points: np.ndarray) -> np.ndarray:
    return point_bounds(points).astype(np.float32)


def _check_part(part) -> None:
    v = part.n_points
    counts = np.asarray(part.face_vertex_counts)
    idx = np.asarray(part.face_vertex_indices)
    checks = [
        (np.asarray(part.points_m).shape == (v, 3), f"points_m shape {np.shape(part.points_m)}"),
        (v > 0, "no points"),
        (int(counts.sum()) == idx.size, f"sum(face_vertex_counts)={int(counts.sum())} != "
                                        f"len(face_vertex_indices)={idx.size}"),
        (idx.size == 0 or (idx.min() >= 0 and idx.max() < v), f"face_vertex_indices outside [0, {v})"),
        (np.asarray(part.normals).shape == (v, 3), f"normals shape {np.shape(part.normals)}, expected ({v}, 3)"),
        (np.asarray(part.st).shape == (v, 2), f"st shape {np.shape(part.st)}, expected ({v}, 2)"),
    ]
    for ok, what in checks:
        if not ok:
            raise ValueError(f"part {part.name!r}: {what}")


def author_mesh(stage, path, part, preview_range_nm=None):
    """Define one ``UsdGeom.Mesh`` from a :class:`rockdove.geometry.MeshPart`.

    Authors points (m), topology, vertex normals, ``primvars:st`` (texCoord2f, vertex),
    ``primvars:displayColor`` (constant, linear), every extra primvar (float/floatN, documented), extent,
    ``subdivisionScheme = none`` (the meshes are final polygons) and ``doubleSided`` for feather cards (the neck's
    and :data:`rockdove.geometry.plumage.CARD_PARTS`). With
    ``preview_range_nm`` (the film's thickness range, nm) also ``primvars:previewST`` (texCoord2f, vertex), the
    coordinates into the preview atlas (:func:`rockdove.usd.textures_io.preview_st`; needs a ``thickness``
    primvar).

    Returns
    -------
    UsdGeom.Mesh
    """
    from pxr import Sdf, UsdGeom, Vt

    _check_part(part)
    part = drop_unreferenced_points(part)  # every point a face uses: validators reject unused topology
    mesh = UsdGeom.Mesh.Define(stage, path)
    points = np.ascontiguousarray(part.points_m, dtype=np.float32)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(part.face_vertex_counts, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(
        Vt.IntArray.FromNumpy(np.ascontiguousarray(part.face_vertex_indices, np.int32)))
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(part.normals, np.float32)))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(_extent(points)))
    mesh.CreateDoubleSidedAttr(part.material == FEATHER_MATERIAL or part.name in CARD_PARTS)
    api = UsdGeom.PrimvarsAPI(mesh)
    st = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    st.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(part.st, np.float32)))
    dc = mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant)
    dc.Set(Vt.Vec3fArray.FromNumpy(np.asarray([part.display_color], np.float32)))
    for name in sorted(part.primvars):
        pv = part.primvars[name]
        values = np.ascontiguousarray(pv.values, dtype=np.float32)
        width = 1 if values.ndim == 1 else values.shape[1]
        if values.ndim > 2 or width not in (1, 2, 3):
            raise ValueError(f"part {part.name!r}: primvar {name!r} has shape {values.shape}; allowed (N,), (N, 2|3)")
        type_name, vt = {1: ("FloatArray", Vt.FloatArray), 2: ("Float2Array", Vt.Vec2fArray),
                         3: ("Float3Array", Vt.Vec3fArray)}[width]
        primvar = api.CreatePrimvar(name, getattr(Sdf.ValueTypeNames, type_name), pv.interpolation)
        primvar.Set(vt.FromNumpy(values))
        doc = THICKNESS_DOC if name == "thickness" else pv.doc
        if doc:
            primvar.GetAttr().SetDocumentation(doc)
    if preview_range_nm is not None:
        from .textures_io import preview_st

        coords = preview_st(part.st, part.primvars["thickness"].values, preview_range_nm)
        pst = api.CreatePrimvar(PREVIEW_PRIMVAR, Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
        pst.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(coords)))
        pst.GetAttr().SetDocumentation(PREVIEW_ST_DOC)
    return mesh


def _feather_part(bird):
    names = [p.name for p in bird.parts]
    if len(set(names)) != len(names):
        raise ValueError(f"bird: part names must be unique, got {names}")
    feathers = [p for p in bird.parts if p.material == FEATHER_MATERIAL]
    if len(feathers) != 1:
        raise ValueError(f"bird: exactly one part with material 'feather' expected (all cards in one mesh), "
                         f"got {[p.name for p in feathers]}")
    if "thickness" not in feathers[0].primvars:
        raise ValueError(f"part {feathers[0].name!r}: feather part needs a 'thickness' primvar (nm, vertex)")
    return feathers[0]


def author_geometry(stage, bird):
    """Author the geometry half of the payload: ``/Pigeon/Geom`` meshes, each bound to its kind's material
    ``/Pigeon/Looks/<Kind>Material`` (a relationship only: the materials are :func:`author_looks`'s).

    Parameters
    ----------
    stage : Usd.Stage
        From :func:`new_stage`; its edit target receives the meshes.
    bird : rockdove.geometry.Bird

    Returns
    -------
    Usd.Prim
        ``/Pigeon``.
    """
    from pxr import UsdGeom, UsdShade

    _feather_part(bird)
    root = UsdGeom.Xform.Define(stage, ROOT)
    UsdGeom.Scope.Define(stage, f"{ROOT}/Geom")
    for part in bird.parts:
        preview_range = None
        if part.material == FEATHER_MATERIAL:  # the preview atlas spans the mesh's thickness range, rounded
            d = np.asarray(part.primvars["thickness"].values, np.float64)  # outward as the LUT axis is
            preview_range = (float(d.min()), float(d.max()))
        mesh = author_mesh(stage, f"{ROOT}/Geom/{part.name}", part, preview_range)
        binding = UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim())
        binding.GetDirectBindingRel().SetTargets([f"{ROOT}/Looks/{material_name(part.material)}"])
    return root.GetPrim()


def author_looks(stage, bird, film, lut: dict | None, textures: dict | None = None, variants=SHADING_VARIANTS):
    """Author the looks half of the payload: ``/Pigeon/Looks`` materials, and ``RockDoveThinFilmAPI`` (film and
    LUT) on the feather mesh authored by :func:`author_geometry` (an ``over`` in the edit target).

    Parameters
    ----------
    stage : Usd.Stage
        A stage that composes the geometry (e.g. its layer as a weaker sublayer) so the feather prim is a Mesh;
        the edit target receives the looks.
    bird : rockdove.geometry.Bird
        Only its parts' names, material kinds and display colours are read.
    film : rockdove.films.FilmModel
        The film the LUT was baked from (recorded with RockDoveThinFilmAPI on the feather mesh).
    lut : dict or None
        :func:`rockdove.usd.material.lut_info` of the LUT; None for a physical-only asset.
    textures : dict, optional
        Texture role -> asset path (default ``./textures/<file>``, :func:`material.texture_asset_paths`).
    variants : sequence of str
        The shading variants the asset carries (:func:`shading_variants`); without ``lut`` only
        ``("physical",)``.

    Returns
    -------
    Usd.Prim
        ``/Pigeon``.
    """
    from pxr import UsdGeom

    from .schema import apply_thin_film

    textures = {**texture_asset_paths(), **(textures or {})}
    feather = _feather_part(bird)
    root = UsdGeom.Xform.Define(stage, ROOT)
    UsdGeom.Scope.Define(stage, f"{ROOT}/Looks")
    n_incident = float(np.real(film.n_incident))  # OpenPBR's indices are relative to the medium above
    film_ior = float(np.real(film.n_film(FILM_IOR_WAVELENGTH_NM))) / n_incident
    substrate_ior = float(np.real(film.n_substrate)) / n_incident
    done = set()
    for part in bird.parts:  # one material per kind, in part order
        kind = part.material
        if kind in done:
            continue
        done.add(kind)
        path = f"{ROOT}/Looks/{material_name(kind)}"
        if kind == FEATHER_MATERIAL:
            author_feather_material(stage, path, lut=lut, film_ior=film_ior, textures=textures, variants=variants,
                                    substrate_ior=substrate_ior)
        elif kind == "body":
            author_body_material(stage, path, texture=textures["body_base"])
        else:
            author_constant_material(stage, path, part.display_color)
    mesh = stage.GetPrimAtPath(f"{ROOT}/Geom/{feather.name}")
    if not mesh:
        raise ValueError(f"stage has no {ROOT}/Geom/{feather.name}: compose the geometry layer before the looks")
    lut_kw = {} if lut is None else dict(
        lut_file=textures["lut"], lut_colour_space=lut["colour_space"],
        angle_warp_gamma=lut["angle_warp_gamma"], thickness_range_nm=lut["thickness_range_nm"],
        illuminant=lut["illuminant"], observer=lut["observer"])
    apply_thin_film(
        mesh, model=film.name, cauchy_a=film.cauchy_a, cauchy_b_nm2=film.cauchy_b_nm2, k=film.k,
        incident_index=float(np.real(film.n_incident)), substrate_index=float(np.real(film.n_substrate)),
        **({"lut_file": None} | lut_kw))
    return root.GetPrim()


def bird_extent(bird) -> np.ndarray:
    """(2, 3) float32 bounding box (min, max) of every part's points, metres."""
    pts = np.concatenate([np.asarray(p.points_m, np.float32) for p in bird.parts])
    return _extent(pts)


def author_interface(stage, *, extent, version: str, payload: str = f"./{PAYLOAD_LAYER}",
                     feather_material: str = f"{ROOT}/Looks/FeatherMaterial", name: str = "pigeon",
                     variants=SHADING_VARIANTS):
    """Author the interface layer: ``/Pigeon`` (component, assetInfo, extentsHint), payload, shading variants.

    Parameters
    ----------
    stage : Usd.Stage
        From :func:`new_stage`.
    extent : array_like, (2, 3)
        Bounding box of the contents (min, max), metres; becomes the default-purpose extentsHint.
    version : str
        assetInfo version.
    payload : str
        Asset path of the contents layer.
    variants : sequence of str
        The variants of the ``shading`` set (:func:`shading_variants`); ``baked`` is the default selection
        when present, else the first.

    Returns
    -------
    Usd.Prim
        ``/Pigeon``.
    """
    from pxr import Kind, Sdf, Usd, UsdGeom, Vt

    prim = UsdGeom.Xform.Define(stage, ROOT).GetPrim()
    model = Usd.ModelAPI(prim)
    model.SetKind(Kind.Tokens.component)
    model.SetAssetName(name)
    model.SetAssetIdentifier(Sdf.AssetPath(f"./{INTERFACE_LAYER}"))
    model.SetAssetVersion(str(version))
    UsdGeom.ModelAPI.Apply(prim).SetExtentsHint(Vt.Vec3fArray.FromNumpy(np.asarray(extent, np.float32)))
    prim.GetPayloads().AddPayload(payload)
    variants = tuple(variants)
    if not variants or any(v not in SHADING_VARIANTS for v in variants):
        raise ValueError(f"variants={variants!r}; allowed: names from {SHADING_VARIANTS}")
    vset = prim.GetVariantSets().AddVariantSet(SHADING_VARIANT_SET)
    for variant in variants:
        vset.AddVariant(variant)
        vset.SetVariantSelection(variant)
        with vset.GetVariantEditContext():
            over = stage.OverridePrim(feather_material)
            out = over.CreateAttribute("outputs:mtlx:surface", Sdf.ValueTypeNames.Token, custom=False)
            out.SetConnections([mtlx_surface_path(feather_material, variant)])
    vset.SetVariantSelection(DEFAULT_SHADING if DEFAULT_SHADING in variants else variants[0])
    return prim


def _export(stage_or_layer, path: str) -> None:
    """Write a layer: text via ExportToString (``.usda``), crate via Export (``.usdc``); byte-identical for the
    same content either way."""
    layer = stage_or_layer.GetRootLayer() if hasattr(stage_or_layer, "GetRootLayer") else stage_or_layer
    if path.endswith(".usdc"):
        if not layer.Export(path):
            raise RuntimeError(f"USD could not write {path!r}")
        return
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(layer.ExportToString())


def write_geometry(out_dir: str, bird) -> str:
    """Author :func:`author_geometry` and write it as ``out_dir/pigeon_geom.usdc`` (crate); returns its path."""
    stage = new_stage()
    author_geometry(stage, bird)
    out_dir = os.path.abspath(out_dir)
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, GEOMETRY_LAYER)
    _export(stage, path)
    return path


def write_looks(out_dir: str, bird, film, lut: dict | None, *, version: str, geometry: str,
                textures: dict | None = None, shading: str | None = None) -> dict:
    """Write every layer but the geometry: the interface (``pigeon.usda``), the payload (``pigeon_payload.usda``,
    sublayering looks over geometry) and the looks (``pigeon_looks.usda``, :func:`author_looks`).

    Parameters
    ----------
    out_dir : str
    bird : rockdove.geometry.Bird
    film : rockdove.films.FilmModel
    lut : dict or None
        :func:`rockdove.usd.material.lut_info`; None for an asset without a LUT (physical-only shading).
    version : str
        assetInfo version.
    geometry : str
        The geometry layer (:func:`write_geometry`) the looks are authored over; read, not copied or changed.
    textures : dict, optional
        Texture role -> asset path.
    shading : {"both", "baked", "physical"}, optional
        The variants the asset carries (:func:`shading_variants`); default ``"both"`` with a LUT, ``"physical"``
        without. ``"both"`` and ``"baked"`` need a LUT.

    Returns
    -------
    dict[str, str]
        ``interface``, ``payload``, ``looks``: absolute paths.
    """
    from pxr import Sdf, Usd

    shading = shading or ("both" if lut is not None else "physical")
    variants = shading_variants(shading)
    if lut is None and "baked" in variants:
        raise ValueError(f"shading={shading!r} needs a LUT (lut=None); without one only 'physical' is possible")
    geometry_layer = Sdf.Layer.OpenAsAnonymous(os.path.abspath(geometry))
    if geometry_layer is None:
        raise ValueError(f"geometry={geometry!r} is not a readable USD layer")
    looks = new_stage()
    composed = Usd.Stage.CreateInMemory()
    composed.GetRootLayer().subLayerPaths = [looks.GetRootLayer().identifier, geometry_layer.identifier]
    composed.SetEditTarget(Usd.EditTarget(looks.GetRootLayer()))
    author_looks(composed, bird, film, lut, textures, variants=variants)
    payload = Sdf.Layer.CreateAnonymous(".usda")  # a bare layer: no stage to recompose its relative sublayers
    payload.defaultPrim = ROOT.lstrip("/")
    for key, value in (("upAxis", "Y"), ("metersPerUnit", 1.0)):  # as new_stage, for tools opening it alone
        payload.pseudoRoot.SetInfo(key, value)
    payload.subLayerPaths = [f"./{LOOKS_LAYER}", f"./{GEOMETRY_LAYER}"]
    interface = new_stage(load_payloads=False)
    author_interface(interface, extent=bird_extent(bird), version=version, variants=variants)
    out_dir = os.path.abspath(out_dir)
    os.makedirs(out_dir, exist_ok=True)
    paths = {"interface": os.path.join(out_dir, INTERFACE_LAYER), "payload": os.path.join(out_dir, PAYLOAD_LAYER),
             "looks": os.path.join(out_dir, LOOKS_LAYER)}
    for key, stage in (("looks", looks), ("payload", payload), ("interface", interface)):
        _export(stage, paths[key])
    return paths


def write_layers(out_dir: str, bird, film, lut: dict | None, *, version: str, textures: dict | None = None,
                 shading: str | None = None) -> dict:
    """Write every layer of the asset into ``out_dir``: :func:`write_geometry` then :func:`write_looks`.

    Returns
    -------
    dict[str, str]
        ``interface`` (pigeon.usda), ``payload`` (pigeon_payload.usda), ``looks`` (pigeon_looks.usda),
        ``geometry`` (pigeon_geom.usdc): absolute paths.
    """
    geometry = write_geometry(out_dir, bird)
    paths = write_looks(out_dir, bird, film, lut, version=version, geometry=geometry, textures=textures,
                        shading=shading)
    return {**paths, "geometry": geometry}


def variant_combinations(stage) -> list[dict]:
    """Every combination of the default prim's variant selections, as ``{set name: variant}`` dicts (sets in
    name order); ``[{}]`` without a default prim or variant sets."""
    import itertools

    prim = stage.GetDefaultPrim()
    if not prim:
        return [{}]
    sets = prim.GetVariantSets()
    names = sorted(sets.GetNames())
    choices = [sets.GetVariantSet(n).GetVariantNames() for n in names]
    return [dict(zip(names, combo)) for combo in itertools.product(*choices)] or [{}]


def open_asset(path: str, shading: str | None = None):
    """Open an asset's root layer (payloads loaded), optionally selecting a ``shading`` variant.

    The variant selection is made in the session layer, so the files are not modified.
    """
    from pxr import Usd

    from .schema import register

    register()
    stage = Usd.Stage.Open(path, Usd.Stage.LoadAll)
    if stage is None:
        raise ValueError(f"path={path!r} is not a USD stage")
    if shading is not None:
        if shading not in SHADING_VARIANTS:
            raise ValueError(f"shading={shading!r}; use one of {SHADING_VARIANTS}")
        with Usd.EditContext(stage, stage.GetSessionLayer()):
            stage.GetPrimAtPath(ROOT).GetVariantSet(SHADING_VARIANT_SET).SetVariantSelection(shading)
    return stage

"""The asset's USD layers (docs/design.md, "USD asset"): the interface layer + payload pattern of NVIDIA's
usd-exchange-samples, the payload's layers split by what changes them (a film change rewrites only the small text
looks layer; the geometry is crate, its arrays being big); the ``shading`` variant set on the interface (variants are
stronger than payloads). Text layers go through ``ExportToString``, the crate through ``Export``: no timestamps, so
the same inputs give byte-identical files (tested)."""

from __future__ import annotations

import itertools
import json
import os

import numpy as np
from pxr import Kind, Sdf, Usd, UsdGeom, UsdShade, UsdSkel, Vt

from ..errors import UsageError
from ..geometry.plumage import CARD_PARTS
from ..geometry.types import drop_unreferenced_points, point_bounds
from ..rig.motions import FPS
from .material import (
    PREVIEW_PRIMVAR,
    author_body_material,
    author_constant_material,
    author_feather_material,
    author_plumage_material,
    mtlx_surface_path,
    texture_asset_paths,
)
from .schema import apply_thin_film, register
from .skel import MOTIONS, REST, RIG_LAYER, author_motion_variants, author_rig, motion_layer
from .textures_io import preview_st

ROOT = "/Pigeon"
INTERFACE_LAYER = "pigeon.usda"
PAYLOAD_LAYER = "pigeon_payload.usda"
LOOKS_LAYER = "pigeon_looks.usda"
GEOMETRY_LAYER = "pigeon_geom.usdc"
#: The looks layer's customLayerData key of the build configuration (JSON; :func:`write_looks`).
BUILD_CONFIG_KEY = "rockdove:buildConfig"
SHADING_VARIANT_SET = "shading"
SHADING_VARIANTS = ("baked", "physical")
DEFAULT_SHADING = "baked"
#: configuration ``shading.variant`` -> the variants of the ``shading`` set
SHADING_CHOICES = {"both": ("baked", "physical"), "baked": ("baked",), "physical": ("physical",)}
FEATHER_MATERIAL = "feather"
#: Wavelength at which the physical variant's thin_film_ior samples the film's Cauchy index: OpenPBR's film has
#: one real index; 550 nm is next to the peak of the CIE photopic luminosity curve V(lambda) (555 nm), where the
#: colour-matching functions weigh the spectrum most (keratin: n = 1.5515 there, 1.569 at 400 nm, 1.544 at 700 nm).
FILM_IOR_WAVELENGTH_NM = 550.0

PREVIEW_ST_DOC = ("Texture coordinates of this vertex in feather_preview.png, the UsdPreviewSurface atlas: the "
                  "feather's st inside the tile of the card's film thickness (rockdove.usd.textures_io.preview_st).")
THICKNESS_DOC = ("Film (keratin cortex) thickness of the feather barbules at this vertex, in nanometres; the "
                 "thin-film LUT is indexed by it (RockDoveThinFilmAPI rockdove:film:thicknessPrimvar).")


def new_stage(*, load_payloads: bool = True):
    """An in-memory stage with the asset's metadata; ``load_payloads=False``: the interface's, not written yet."""
    register()  # before the first stage: USD builds its schema registry once
    stage = Usd.Stage.CreateInMemory(load=Usd.Stage.LoadAll if load_payloads else Usd.Stage.LoadNone)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.GetRootLayer().defaultPrim = ROOT.lstrip("/")
    return stage


def material_name(kind: str) -> str:
    """Material prim name for a MeshPart.material kind: ``"feather"`` -> ``"FeatherMaterial"``."""
    return f"{kind[:1].upper()}{kind[1:]}Material"


def author_mesh(stage, path, part, preview_range_nm=None):
    """Define one ``UsdGeom.Mesh`` (m, final polygons) from a MeshPart; with ``preview_range_nm`` its previewST."""
    part = drop_unreferenced_points(part)  # every point a face uses: validators reject unused topology
    mesh = UsdGeom.Mesh.Define(stage, path)
    points = np.ascontiguousarray(part.points_m, dtype=np.float32)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(part.face_vertex_counts, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(part.face_vertex_indices, np.int32)))
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(part.normals, np.float32)))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(point_bounds(points).astype(np.float32)))
    mesh.CreateDoubleSidedAttr(part.material == FEATHER_MATERIAL or part.name in CARD_PARTS)
    api = UsdGeom.PrimvarsAPI(mesh)
    st = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    st.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(part.st, np.float32)))
    dc = mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant)
    dc.Set(Vt.Vec3fArray.FromNumpy(np.asarray([part.display_color], np.float32)))
    for name in sorted(part.primvars):
        pv = part.primvars[name]
        values = np.ascontiguousarray(pv.values, dtype=np.float32)
        type_name, vt = {1: ("FloatArray", Vt.FloatArray), 2: ("Float2Array", Vt.Vec2fArray),
                         3: ("Float3Array", Vt.Vec3fArray)}[1 if values.ndim == 1 else values.shape[1]]
        primvar = api.CreatePrimvar(name, getattr(Sdf.ValueTypeNames, type_name), pv.interpolation)
        primvar.Set(vt.FromNumpy(values))
        doc = THICKNESS_DOC if name == "thickness" else pv.doc
        if doc:
            primvar.GetAttr().SetDocumentation(doc)
    if preview_range_nm is not None:
        coords = preview_st(part.st, part.primvars["thickness"].values, preview_range_nm)
        pst = api.CreatePrimvar(PREVIEW_PRIMVAR, Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
        pst.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(coords)))
        pst.GetAttr().SetDocumentation(PREVIEW_ST_DOC)
    return mesh


def _feather_part(bird):
    """The one part with the feather material (all neck cards in one mesh), which carries ``thickness``."""
    feathers = [p for p in bird.parts if p.material == FEATHER_MATERIAL]
    if len(feathers) != 1 or "thickness" not in feathers[0].primvars:
        raise UsageError(f"bird: exactly one part with material 'feather' and a 'thickness' primvar expected, "
                         f"got {[p.name for p in feathers]}")
    return feathers[0]


def author_geometry(stage, bird):
    """The ``/Pigeon/Geom`` meshes in ``stage``'s edit target, bound to materials :func:`author_looks` defines."""
    _feather_part(bird)
    root = UsdGeom.Xform.Define(stage, ROOT)
    # the rig layer's skeleton binds its meshes (rockdove.usd.skel); no authored extent: UsdSkel computes the
    # SkelRoot's from the posed joints (padded), right in every pose, as NVIDIA's ExtentsChecker expects
    UsdSkel.Root.Define(stage, f"{ROOT}/Geom")
    for part in bird.parts:
        preview_range = None
        if part.material == FEATHER_MATERIAL:  # the preview atlas spans the mesh's thickness range
            d = np.asarray(part.primvars["thickness"].values, np.float64)
            preview_range = (float(d.min()), float(d.max()))
        mesh = author_mesh(stage, f"{ROOT}/Geom/{part.name}", part, preview_range)
        binding = UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim())
        binding.GetDirectBindingRel().SetTargets([f"{ROOT}/Looks/{material_name(part.material)}"])
    return root.GetPrim()


def author_looks(stage, bird, film, lut: dict | None, variants=SHADING_VARIANTS):
    """The materials, and ``RockDoveThinFilmAPI`` over the feather mesh ``stage`` composes, in its edit target."""
    textures = texture_asset_paths()
    feather = _feather_part(bird)
    root = UsdGeom.Xform.Define(stage, ROOT)
    UsdGeom.Scope.Define(stage, f"{ROOT}/Looks")
    n_incident = float(np.real(film.n_incident))  # OpenPBR's indices are relative to the medium above
    film_ior = float(np.real(film.n_film(FILM_IOR_WAVELENGTH_NM))) / n_incident
    substrate_ior = float(np.real(film.n_substrate)) / n_incident
    for kind in dict.fromkeys(p.material for p in bird.parts):  # one material per kind, in part order
        path = f"{ROOT}/Looks/{material_name(kind)}"
        if kind == FEATHER_MATERIAL:
            author_feather_material(stage, path, lut=lut, film_ior=film_ior, textures=textures, variants=variants,
                                    substrate_ior=substrate_ior)
        elif kind == "body":
            author_body_material(stage, path, texture=textures["body_base"])
        elif kind == "plumage":
            author_plumage_material(stage, path, textures=textures)
        else:
            author_constant_material(stage, path, next(p for p in bird.parts if p.material == kind).display_color)
    mesh = stage.GetPrimAtPath(f"{ROOT}/Geom/{feather.name}")
    lut_kw = {} if lut is None else dict(
        lut_file=textures["lut"], lut_colour_space=lut["colour_space"],
        angle_warp_gamma=lut["angle_warp_gamma"], thickness_range_nm=lut["thickness_range_nm"],
        illuminant=lut["illuminant"], observer=lut["observer"])
    apply_thin_film(
        mesh, model=film.name, cauchy_a=film.cauchy_a, cauchy_b_nm2=film.cauchy_b_nm2, k=film.k,
        incident_index=float(np.real(film.n_incident)), substrate_index=float(np.real(film.n_substrate)),
        **({"lut_file": None} | lut_kw))
    return root.GetPrim()


def author_interface(stage, *, extent, version: str, variants=SHADING_VARIANTS):
    """The interface layer: ``/Pigeon`` (``extent`` (2, 3) m), the payload and the ``shading`` variant set."""
    prim = UsdGeom.Xform.Define(stage, ROOT).GetPrim()
    model = Usd.ModelAPI(prim)
    model.SetKind(Kind.Tokens.component)
    model.SetAssetName("pigeon")
    model.SetAssetIdentifier(Sdf.AssetPath(f"./{INTERFACE_LAYER}"))
    model.SetAssetVersion(str(version))
    UsdGeom.ModelAPI.Apply(prim).SetExtentsHint(Vt.Vec3fArray.FromNumpy(np.asarray(extent, np.float32)))
    prim.GetPayloads().AddPayload(f"./{PAYLOAD_LAYER}")
    feather_material = f"{ROOT}/Looks/FeatherMaterial"
    vset = prim.GetVariantSets().AddVariantSet(SHADING_VARIANT_SET)
    for variant in variants:
        vset.AddVariant(variant)
        vset.SetVariantSelection(variant)
        with vset.GetVariantEditContext():
            over = stage.OverridePrim(feather_material)
            out = over.CreateAttribute("outputs:mtlx:surface", Sdf.ValueTypeNames.Token, custom=False)
            out.SetConnections([mtlx_surface_path(feather_material, variant)])
    vset.SetVariantSelection(DEFAULT_SHADING if DEFAULT_SHADING in variants else variants[0])
    author_motion_variants(stage, prim)
    return prim


def _export(stage_or_layer, path: str) -> str:
    """A layer to ``path`` (its folder made): crate via Export (``.usdc``), text via ExportToString."""
    layer = stage_or_layer.GetRootLayer() if hasattr(stage_or_layer, "GetRootLayer") else stage_or_layer
    os.makedirs(os.path.dirname(path), exist_ok=True)
    if path.endswith(".usdc"):
        if not layer.Export(path):
            raise RuntimeError(f"USD could not write {path!r}")
        return path
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(layer.ExportToString())
    return path


def write_geometry(out_dir: str, bird) -> str:
    """:func:`author_geometry` as ``out_dir/pigeon_geom.usdc``; returns its path."""
    stage = new_stage()
    author_geometry(stage, bird)
    return _export(stage, os.path.join(os.path.abspath(out_dir), GEOMETRY_LAYER))


def write_rig(out_dir: str, bird) -> str:
    """:func:`rockdove.usd.skel.author_rig` as ``out_dir/pigeon_rig.usdc``; returns its path."""
    stage = new_stage()
    stage.SetTimeCodesPerSecond(FPS)  # as the root layer's: USD scales a sublayer's samples by the ratio
    stage.SetFramesPerSecond(FPS)
    author_rig(stage, bird)
    return _export(stage, os.path.join(os.path.abspath(out_dir), RIG_LAYER))


def write_looks(out_dir: str, bird, film, lut: dict | None, *, version: str, geometry: str,
                shading: str | None = None, config: dict | None = None) -> dict:
    """Every layer but the geometry and rig into ``out_dir``: their paths. ``config``: recorded for the viewer."""
    shading = shading or ("both" if lut is not None else "physical")
    if shading not in SHADING_CHOICES:
        raise UsageError(f"shading={shading!r}; allowed: {sorted(SHADING_CHOICES)}")
    variants = SHADING_CHOICES[shading]
    if lut is None and "baked" in variants:
        raise UsageError(f"shading={shading!r} needs a LUT (lut=None); without one only 'physical' is possible")
    geometry_layer = Sdf.Layer.OpenAsAnonymous(os.path.abspath(geometry))
    looks = new_stage()
    composed = Usd.Stage.CreateInMemory()
    composed.GetRootLayer().subLayerPaths = [looks.GetRootLayer().identifier, geometry_layer.identifier]
    composed.SetEditTarget(Usd.EditTarget(looks.GetRootLayer()))
    author_looks(composed, bird, film, lut, variants=variants)
    if config is not None:
        looks.GetRootLayer().customLayerData = {BUILD_CONFIG_KEY: json.dumps(config, sort_keys=True)}
    payload = Sdf.Layer.CreateAnonymous(".usda")  # a bare layer: no stage to recompose its relative sublayers
    payload.defaultPrim = ROOT.lstrip("/")
    for key, value in (("upAxis", "Y"), ("metersPerUnit", 1.0)):  # as new_stage, for tools opening it alone
        payload.pseudoRoot.SetInfo(key, value)
    payload.subLayerPaths = [f"./{LOOKS_LAYER}", f"./{RIG_LAYER}", f"./{GEOMETRY_LAYER}"]
    interface = new_stage(load_payloads=False)
    extent = point_bounds(np.concatenate([np.asarray(p.points_m, np.float32) for p in bird.parts]))
    author_interface(interface, extent=extent.astype(np.float32), version=version, variants=variants)
    out_dir = os.path.abspath(out_dir)
    paths = {key: _export(layer, os.path.join(out_dir, name)) for key, layer, name in (
        ("looks", looks, LOOKS_LAYER), ("payload", payload, PAYLOAD_LAYER), ("interface", interface, INTERFACE_LAYER))}
    for motion in MOTIONS:  # pigeon_idle.usda, pigeon_walk.usda: each plays one motion (rockdove.usd.skel)
        if motion != REST:
            path = os.path.join(out_dir, f"pigeon_{motion}.usda")
            paths[motion] = _export(motion_layer(INTERFACE_LAYER, motion), path)
    return paths


def write_layers(out_dir: str, bird, film, lut: dict | None, *, version: str, shading: str | None = None) -> dict:
    """:func:`write_geometry`, :func:`write_looks` and :func:`write_rig`: every layer's path."""
    geometry = write_geometry(out_dir, bird)
    paths = write_looks(out_dir, bird, film, lut, version=version, geometry=geometry, shading=shading)
    return {**paths, "geometry": geometry, "rig": write_rig(out_dir, bird)}


def variant_combinations(stage) -> list[dict]:
    """Every combination of the default prim's variant selections as ``{set: variant}``; ``[{}]`` without any."""
    if not (prim := stage.GetDefaultPrim()):
        return [{}]
    sets = prim.GetVariantSets()
    names = sorted(sets.GetNames())
    choices = [sets.GetVariantSet(n).GetVariantNames() for n in names]
    return [dict(zip(names, combo)) for combo in itertools.product(*choices)] or [{}]


def open_asset(path: str, shading: str | None = None):
    """An asset opened with payloads loaded, the ``shading`` variant (if given) selected in the session layer."""
    register()
    if (stage := Usd.Stage.Open(path, Usd.Stage.LoadAll)) is None:
        raise UsageError(f"path={path!r} is not a USD stage")
    if shading is not None:
        if shading not in SHADING_VARIANTS:
            raise UsageError(f"shading={shading!r}; use one of {SHADING_VARIANTS}")
        with Usd.EditContext(stage, stage.GetSessionLayer()):
            stage.GetPrimAtPath(ROOT).GetVariantSet(SHADING_VARIANT_SET).SetVariantSelection(shading)
    return stage

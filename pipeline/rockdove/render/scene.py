"""Read a written rockdove USD asset back into plain numpy arrays for the GL renderer and the CPU reference.

The verifier checks what was *written*: the root layer opened from disk with pxr (payloads loaded, a chosen
``shading`` variant) becomes a :class:`RenderScene` of numpy arrays, so the pyrender path (:mod:`rockdove.render.gl`)
and the CPU reference see the same data (names: docs/design.md, "USD asset"): every visible mesh, fan-triangulated
in world metres, its primvars (face-varying ones split vertices per corner; constant and uniform ones expanded),
material (``"feather"`` for a mesh with ``RockDoveThinFilmAPI``, else the bound material's name without
``Material``, lower case; its textures with absolute paths and its constant colour) and film."""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass, field

import numpy as np

from ..errors import UsageError
from ..usd.material import OPACITY_THRESHOLD
from .film import ThinFilmParams, lut_to_draw, read_film, thickness_range_nm
from .skinning import animated, pose
from .triangulate import fan_triangulate, fan_triangulate_corners, vertex_normals


@dataclass(frozen=True, eq=False)
class ScenePart:
    """One triangulated mesh in world space; per-vertex arrays are float32 (V, ...)."""

    name: str  # USD prim name ("Body", "NeckFeathers", ...)
    path: str  # USD prim path
    material_kind: str  # "feather", "body", "beak", ... (module docstring)
    positions_m: np.ndarray  # (V, 3) world positions, metres
    normals: np.ndarray  # (V, 3) world unit normals
    triangles: np.ndarray  # (T, 3) int32, counter-clockwise seen from the normal side
    st: np.ndarray  # (V, 2) texture coordinates (t = 0 at the image's bottom); zeros when not authored
    thickness_nm: np.ndarray | None = None  # (V,) film thickness, nm (feathers only)
    neck_s: np.ndarray | None = None  # (V,) primvars:neckS in [0, 1]
    thickness_field: np.ndarray | None = None  # (V, 3) primvars:thicknessField (rockdove.geometry.cards)
    preview_st: np.ndarray | None = None  # (V, 2) primvars:previewST (into the UsdPreviewSurface atlas)
    base_colour_texture: str | None = None  # absolute path, RGB or RGBA (A: the feather silhouette)
    base_colour_srgb: bool = True  # sourceColorSpace not raw
    mask_texture: str | None = None  # absolute path of the structural-colour mask (raw grey)
    base_colour: np.ndarray = field(default_factory=lambda: np.full(3, 0.5, np.float32))  # linear, untextured parts
    opacity_threshold: float = OPACITY_THRESHOLD  # fragments with texture alpha below it are discarded
    double_sided: bool = False  # UsdGeom doubleSided: the shading normal is turned toward the viewer
    normal_texture: str | None = None  # absolute path of the tangent-space normal map (UsdPreviewSurface normal)

    @property
    def is_feather(self) -> bool:
        return self.material_kind == "feather"


@dataclass(frozen=True, eq=False)
class RenderScene:
    """A USD asset read back for rendering; the renderers' part ids are ``index + 1`` in ``parts`` (0 = background)."""

    root_layer: str  # absolute path of the opened root layer
    parts: tuple  # of ScenePart: the visible meshes
    film: ThinFilmParams | None  # the feathers' thin film (None when no mesh carries the API)
    variants: dict  # the active variant selections, e.g. {"shading": "baked", "motion": "rest"}
    time: float | None = None  # the time code the meshes were posed at (None: as authored, no animation)

    @property
    def bounds_m(self) -> np.ndarray:
        """Axis-aligned world bounds of all parts, (2, 3) float64 ``[min, max]``, metres."""
        pts = np.concatenate([p.positions_m for p in self.parts]).astype(np.float64)
        return np.stack([pts.min(axis=0), pts.max(axis=0)])

    @property
    def neck_centre_m(self) -> np.ndarray:
        """Centre of the feathers' bounds (the bounds' centre if there are no feathers), (3,) metres."""
        feathers = [p.positions_m for p in self.parts if p.is_feather]
        if not feathers:
            return self.bounds_m.mean(axis=0)
        pts = np.concatenate(feathers).astype(np.float64)
        return 0.5 * (pts.min(axis=0) + pts.max(axis=0))

    def part(self, name: str) -> ScenePart:
        for p in self.parts:
            if p.name == name:
                return p
        raise UsageError(f"part={name!r} is not in the scene; parts are {[p.name for p in self.parts]}")

    def part_id(self, name: str) -> int:
        """Id of a part in the renderers' part-id images."""
        return self.parts.index(self.part(name)) + 1

    @property
    def thickness_range_nm(self) -> tuple:
        """The film's thickness range, nm (:func:`rockdove.render.film.thickness_range_nm`)."""
        if self.film is None:
            raise UsageError(f"the scene {self.root_layer!r} has no thin-film feathers")
        feathers = [p.thickness_nm for p in self.parts if p.is_feather and p.thickness_nm is not None]
        return thickness_range_nm(self.film, np.concatenate(feathers) if feathers else [])

    def load_lut(self):
        """The :class:`rockdove.lut.ThinFilmLUT` to draw the film with (:func:`rockdove.render.film.lut_to_draw`)."""
        if self.film is None:
            raise UsageError(f"the scene {self.root_layer!r} has no thin-film feathers, so no LUT")
        return lut_to_draw(self.film, self.thickness_range_nm)


#: Shader prim names of the materials (docs/design.md, "USD asset").
BASE_COLOR_SHADER = "BaseColorTexture"
MASK_SHADER = "MaskTexture"
NORMAL_SHADER = "NormalTexture"
#: Shader inputs that may hold a constant base colour for untextured parts (UsdPreviewSurface, MaterialX).
CONSTANT_COLOUR_INPUTS = ("diffuseColor", "base_color", "baseColor")


def asset_abs_path(attr, value) -> str | None:
    """Absolute path of an asset-valued attribute (resolved by Ar, else anchored to the authoring layer)."""
    if value is None:
        return None
    resolved = getattr(value, "resolvedPath", "") or ""
    raw = getattr(value, "path", str(value))
    if not raw:
        return None
    if resolved:
        return os.path.abspath(resolved)
    for spec in attr.GetPropertyStack():
        if spec.HasDefaultValue() or spec.default is not None:
            return os.path.abspath(spec.layer.ComputeAbsolutePath(raw))
    return os.path.abspath(raw)


def primvar_array(values, interp: str, n_points: int, face_vertex_counts, name: str, prim_path: str):
    """Flattened primvar ``values`` and their interpolation: 'vertex' or 'faceVarying' (constant, uniform expanded)."""
    a = np.asarray(values)
    n_faces = len(face_vertex_counts)
    if interp == "constant":
        return np.repeat(a.reshape(1, *a.shape[1:]) if a.ndim else a[None], n_points, axis=0), "vertex"
    if interp == "uniform":
        if len(a) != n_faces:
            raise UsageError(f"{prim_path}: primvar {name} is uniform with {len(a)} values for {n_faces} faces")
        return np.repeat(a, face_vertex_counts, axis=0), "faceVarying"
    if interp in ("vertex", "varying"):
        if len(a) != n_points:
            raise UsageError(f"{prim_path}: primvar {name} has {len(a)} values for {n_points} points")
        return a, "vertex"
    if interp == "faceVarying":
        if len(a) != int(np.sum(face_vertex_counts)):
            raise UsageError(f"{prim_path}: faceVarying primvar {name} has {len(a)} values")
        return a, "faceVarying"
    raise UsageError(f"{prim_path}: primvar {name} has unsupported interpolation {interp!r}")


def material_info(prim, stage):
    """(material kind, base texture, srgb?, mask texture, constant colour, opacity threshold, normal map)."""
    from pxr import Usd, UsdShade

    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    if not mat:
        return None, None, True, None, None, OPACITY_THRESHOLD, None
    name = mat.GetPrim().GetName()
    kind = name[: -len("Material")].lower() if name.endswith("Material") and len(name) > 8 else name.lower()
    base = mask = colour_const = normal = None
    srgb, threshold = True, OPACITY_THRESHOLD
    for p in Usd.PrimRange(mat.GetPrim()):
        if not p.IsA(UsdShade.Shader):
            continue
        sh = UsdShade.Shader(p)
        if p.GetName() in (BASE_COLOR_SHADER, MASK_SHADER, NORMAL_SHADER):
            inp = sh.GetInput("file")
            if not inp:
                raise UsageError(f"{p.GetPath()}: texture shader has no inputs:file")
            path = asset_abs_path(inp.GetAttr(), inp.Get())
            if path is None:
                raise UsageError(f"{p.GetPath()}: inputs:file is empty")
            if not os.path.isfile(path):
                raise UsageError(f"{p.GetPath()}: texture {path!r} does not exist")
            if p.GetName() == BASE_COLOR_SHADER:
                base = path
                cs = sh.GetInput("sourceColorSpace")
                cs_val = cs.Get() if cs else None
                if cs_val is None:  # MaterialX: colorspace metadata on the file input
                    cs_val = inp.GetAttr().GetColorSpace() or "sRGB"
                srgb = str(cs_val).lower() not in ("raw", "lin_rec709", "linear")
            elif p.GetName() == MASK_SHADER:
                mask = path
            else:
                normal = path
        for key in CONSTANT_COLOUR_INPUTS:
            inp = sh.GetInput(key)
            if inp and colour_const is None and not inp.HasConnectedSource():
                v = inp.Get()
                if v is not None:
                    colour_const = np.asarray(v, dtype=np.float32).reshape(3)
        thr = sh.GetInput("opacityThreshold")
        if thr and thr.Get() is not None and float(thr.Get()) > 0:
            threshold = float(thr.Get())
    return kind, base, srgb, mask, colour_const, threshold, normal


def _read_mesh(prim, xcache, meters_per_unit, stage, posed=None):
    from pxr import UsdGeom

    mesh = UsdGeom.Mesh(prim)
    path = str(prim.GetPath())
    pts = mesh.GetPointsAttr().Get() if posed is None else posed[0]
    counts = mesh.GetFaceVertexCountsAttr().Get()
    fvi = mesh.GetFaceVertexIndicesAttr().Get()
    if pts is None or counts is None or fvi is None or len(pts) == 0 or len(counts) == 0:
        return None
    pts, counts, fvi = np.asarray(pts, np.float64), np.asarray(counts, np.int64), np.asarray(fvi, np.int64)
    if fvi.size and (fvi.min() < 0 or fvi.max() >= len(pts)):
        raise UsageError(f"{path}: faceVertexIndices out of range for {len(pts)} points")
    left = mesh.GetOrientationAttr().Get() == "leftHanded"

    film = read_film(prim)
    pvapi = UsdGeom.PrimvarsAPI(prim)
    attrs = {}  # name -> (values, interpolation)
    want = {"st": "st", "neck_s": "neckS", "preview_st": "previewST", "normals": "normals",
            "thickness_field": "thicknessField"}
    if film is not None:
        want["thickness"] = film.thickness_primvar
    for key, pv_name in want.items():
        pv = pvapi.GetPrimvar(pv_name)
        if pv and pv.HasValue():
            attrs[key] = primvar_array(pv.ComputeFlattened(), pv.GetInterpolation(), len(pts), counts, pv_name, path)
    if film is not None and "thickness" not in attrs:
        raise UsageError(f"{path}: thickness primvar primvars:{film.thickness_primvar} is missing")
    normals = mesh.GetNormalsAttr().Get()
    if "normals" not in attrs and normals is not None and len(normals):
        attrs["normals"] = primvar_array(normals, mesh.GetNormalsInterpolation(), len(pts), counts, "normals", path)
    if posed is not None:  # the skinned normals, else none: area-weighted ones of the posed mesh
        attrs.pop("normals", None)
        if posed[1] is not None:
            attrs["normals"] = (posed[1], "vertex")

    if any(interp == "faceVarying" for _, interp in attrs.values()):  # split vertices per face corner
        tris = fan_triangulate_corners(counts)
        if left:
            tris = tris[:, [0, 2, 1]]
        positions = pts[fvi]
        out = {k: (v if interp == "faceVarying" else v[fvi]) for k, (v, interp) in attrs.items()}
    else:
        positions = pts
        tris = fan_triangulate(counts, fvi, left)
        out = {k: v for k, (v, _) in attrs.items()}

    # row-vector convention; a skinned mesh's points are in its skeleton's space (UsdSkel)
    m = np.asarray(xcache.GetLocalToWorldTransform(prim) if posed is None else posed[2], dtype=np.float64)
    # a contiguous copy of the 3x3 block: numpy multiplies by a strided view element by element (60x slower)
    world = (positions @ np.ascontiguousarray(m[:3, :3]) + m[3, :3]) * meters_per_unit
    if np.linalg.det(m[:3, :3]) < 0:
        tris = tris[:, [0, 2, 1]]
    if "normals" in out:
        nrm = np.asarray(out["normals"], dtype=np.float64).reshape(-1, 3) @ np.linalg.inv(m[:3, :3]).T
        nrm = (nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-30)).astype(np.float32)
    else:
        nrm = vertex_normals(world, tris)
    n_v = len(world)
    arr = {k: np.asarray(out[k], np.float32).reshape(n_v, *shape) if k in out else None
           for k, shape in (("st", (2,)), ("thickness", ()), ("neck_s", ()), ("preview_st", (2,)),
                            ("thickness_field", (3,)))}

    kind, base_tex, srgb, mask_tex, colour_const, threshold, normal_tex = material_info(prim, stage)
    kind = "feather" if film is not None else kind or prim.GetName().lower()
    if colour_const is None:
        dc = pvapi.GetPrimvar("displayColor")
        v = dc.ComputeFlattened() if dc and dc.HasValue() else None
        colour_const = np.asarray(v[0], np.float32) if v is not None and len(v) else np.full(3, 0.5, np.float32)
    part = ScenePart(
        name=prim.GetName(), path=path, material_kind=kind, positions_m=np.ascontiguousarray(world, dtype=np.float32),
        normals=np.ascontiguousarray(nrm), triangles=np.ascontiguousarray(tris, dtype=np.int32),
        st=np.ascontiguousarray(arr["st"]) if arr["st"] is not None else np.zeros((n_v, 2), np.float32),
        thickness_nm=arr["thickness"], neck_s=arr["neck_s"], preview_st=arr["preview_st"],
        thickness_field=arr["thickness_field"],
        base_colour_texture=base_tex, base_colour_srgb=srgb, mask_texture=mask_tex,
        base_colour=np.asarray(colour_const, np.float32), opacity_threshold=threshold,
        double_sided=bool(mesh.GetDoubleSidedAttr().Get()), normal_texture=normal_tex)
    return part, film


def load_scene(path, variants: dict | None = None, time: float | None = None) -> RenderScene:
    """Open a written asset (its folder or root layer) with pxr as a :class:`RenderScene`, with ``variants``
    selected on the default prim (e.g. ``{"shading": "baked", "motion": "walk"}``; default as authored) and, when a
    motion is selected, the meshes skinned by UsdSkel at time code ``time`` (default the first;
    :mod:`rockdove.render.skinning`). UsageError naming what is wrong with the asset, a variant or the time."""
    from pxr import Sdf, Usd, UsdGeom

    from ..usd.layout import resolve_root_layer
    from ..usd.schema import register

    layer_path = resolve_root_layer(path)
    # USD builds its schema registry at the first stage opened: register before, for the rest of the process (a
    # RuntimeError: the registry was already built without it; this reader reads the attributes by name)
    with contextlib.suppress(RuntimeError):
        register()
    try:
        stage = Usd.Stage.Open(layer_path, Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise UsageError(f"path={os.fspath(path)!r} could not be opened as USD: {exc}") from None
    if stage is None:
        raise UsageError(f"path={os.fspath(path)!r} could not be opened as USD")
    up = UsdGeom.GetStageUpAxis(stage)
    if up != UsdGeom.Tokens.y:
        raise UsageError(f"{layer_path}: upAxis={up!r}; rockdove assets are Y-up (docs/design.md)")
    mpu = float(UsdGeom.GetStageMetersPerUnit(stage))
    root = stage.GetDefaultPrim() or stage.GetPseudoRoot()
    active = {}
    if variants:
        stage.SetEditTarget(stage.GetSessionLayer())
        vsets = root.GetVariantSets()
        for set_name, sel in variants.items():
            if not vsets.HasVariantSet(set_name):
                raise UsageError(f"variants={variants!r}: {root.GetPath()} has no variant set {set_name!r}; "
                                 f"it has {list(vsets.GetNames())}")
            vs = vsets.GetVariantSet(set_name)
            if sel not in vs.GetVariantNames():
                raise UsageError(f"variants={variants!r}: {set_name!r} must be one of {list(vs.GetVariantNames())}")
            vs.SetVariantSelection(sel)
        stage.Load(Sdf.Path.absoluteRootPath)
    if root and root.IsValid() and root != stage.GetPseudoRoot():
        vsets = root.GetVariantSets()
        active = {n: vsets.GetVariantSet(n).GetVariantSelection() for n in vsets.GetNames()}

    posed, at = {}, None
    if time is not None or animated(stage):
        start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
        at = start if time is None else float(time)
        if not start <= at <= end:
            raise UsageError(f"time={time!r} lies outside the animation: time codes {start:g} to {end:g} "
                             f"({stage.GetTimeCodesPerSecond():g} per second)")
        posed = pose(stage, [at])[0] if animated(stage) else {}
    xcache = UsdGeom.XformCache(Usd.TimeCode.Default())
    parts, film = [], None
    for prim in Usd.PrimRange(root, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)):
        img = UsdGeom.Imageable(prim)
        if (not prim.IsA(UsdGeom.Mesh) or img.ComputeVisibility() == UsdGeom.Tokens.invisible
                or img.ComputePurpose() not in (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)):
            continue
        res = _read_mesh(prim, xcache, mpu, stage, posed.get(str(prim.GetPath())))
        if res is not None:
            parts.append(res[0])
            film = res[1] if film is None else film  # the first feather mesh's
    if not parts:
        raise UsageError(f"path={os.fspath(path)!r}: no visible mesh under {root.GetPath()}")
    return RenderScene(root_layer=layer_path, parts=tuple(parts), film=film, variants=active, time=at)

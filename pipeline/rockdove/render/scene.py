"""Read a written rockdove USD asset back into plain numpy arrays for the GL renderer and the CPU reference.

The verifier checks what was *written*: this module opens the root layer from disk with pxr (payloads loaded,
a chosen ``shading`` variant), and returns a :class:`RenderScene` of numpy arrays only (no pxr objects), so
that the pyrender path (:mod:`rockdove.render.gl`) and the CPU reference see exactly the same data.

What is read (names from docs/design.md, "USD asset" and "Textures"):

- every visible ``UsdGeom.Mesh`` (purpose default or render) under the default prim, triangulated (fan
  triangulation of each polygon, vectorised), with its local-to-world transform and the stage's
  ``metersPerUnit`` applied, so positions are world metres and normals world unit vectors;
- ``st`` (``primvars:st``), vertex normals (authored, else area-weighted from the triangles), the film
  thickness primvar named by ``rockdove:film:thicknessPrimvar`` (nm) and ``primvars:neckS`` when present;
  face-varying primvars are honoured by splitting vertices per face corner;
- per part the material kind (``"feather"`` for a mesh carrying the ``RockDoveThinFilmAPI`` attributes,
  else the bound material's name without the ``Material`` suffix, lower case, e.g. ``BodyMaterial`` ->
  ``"body"``), the ``BaseColorTexture`` / ``MaskTexture`` shaders' ``inputs:file`` resolved to absolute
  paths, and a constant base colour (``inputs:diffuseColor`` / ``inputs:base_color`` of the bound
  material's shaders, else ``primvars:displayColor``) for parts without a texture;
- the thin-film physics authored with ``RockDoveThinFilmAPI``, read by :func:`rockdove.render.film.read_film`
  through the schema's one reader (:class:`rockdove.render.film.ThinFilmParams`; an asset without a LUT reads
  too, ``lut_file = None``).

Helpers by concern: :mod:`.usd_read` (primvars, materials), :mod:`.triangulate` (faces to triangles, vertex
normals), :mod:`.texture` (decoding and sampling the texture images the parts name).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from .film import ThinFilmParams, lut_to_draw, read_film, thickness_range_nm
from .triangulate import fan_triangulate, fan_triangulate_corners, vertex_normals
from .usd_read import DEFAULT_OPACITY_THRESHOLD, material_info, primvar_array

@dataclass(frozen=True, eq=False)
class ScenePart:
    """One triangulated mesh in world space.

    Attributes
    ----------
    name : str
        USD prim name (``"Body"``, ``"NeckFeathers"``, ...).
    path : str
        USD prim path.
    material_kind : str
        ``"feather"``, ``"body"``, ``"beak"``, ... (see module docstring).
    positions_m : ndarray, (V, 3) float32
        World positions, metres.
    normals : ndarray, (V, 3) float32
        World unit normals.
    triangles : ndarray, (T, 3) int32
        Counter-clockwise (seen from the normal side) vertex indices.
    st : ndarray, (V, 2) float32
        Texture coordinates (t = 0 at the bottom of the image); zeros when not authored.
    thickness_nm : ndarray, (V,) float32 or None
        Film thickness per vertex, nm (feathers only).
    neck_s : ndarray, (V,) float32 or None
        ``primvars:neckS`` in [0, 1] when authored.
    preview_st : ndarray, (V, 2) float32 or None
        ``primvars:previewST`` (texcoords into the UsdPreviewSurface atlas) when authored.
    base_colour_texture : str or None
        Absolute path of the base colour image (RGB or RGBA; A is the feather silhouette).
    base_colour_srgb : bool
        Whether the base texture is sRGB-encoded (``sourceColorSpace`` not ``raw``).
    mask_texture : str or None
        Absolute path of the structural-colour mask (raw grey).
    base_colour : ndarray, (3,) float32
        Constant linear base colour, used when there is no base texture.
    opacity_threshold : float
        Fragments with texture alpha below this are discarded.
    """

    name: str
    path: str
    material_kind: str
    positions_m: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    st: np.ndarray
    thickness_nm: np.ndarray | None = None
    neck_s: np.ndarray | None = None
    preview_st: np.ndarray | None = None
    base_colour_texture: str | None = None
    base_colour_srgb: bool = True
    mask_texture: str | None = None
    base_colour: np.ndarray = field(default_factory=lambda: np.full(3, 0.5, np.float32))
    opacity_threshold: float = DEFAULT_OPACITY_THRESHOLD

    @property
    def is_feather(self) -> bool:
        return self.material_kind == "feather"

    @property
    def triangle_normals(self) -> np.ndarray:
        """Geometric unit normals of the triangles, (T, 3) float64."""
        p = self.positions_m.astype(np.float64)
        t = self.triangles
        n = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)


@dataclass(frozen=True, eq=False)
class RenderScene:
    """A USD asset read back for rendering: parts, thin-film physics and bounds (numpy only).

    Attributes
    ----------
    root_layer : str
        Absolute path of the opened root layer.
    parts : tuple of ScenePart
        The visible meshes; part ids used by the renderers are ``index + 1`` (0 = background).
    film : ThinFilmParams or None
        Thin-film physics of the feathers (None when no mesh carries the API).
    variants : dict
        Variant selections that were active, e.g. ``{"shading": "baked"}``.
    """

    root_layer: str
    parts: tuple
    film: ThinFilmParams | None
    variants: dict

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
        raise ValueError(f"part={name!r} is not in the scene; parts are {[p.name for p in self.parts]}")

    def part_id(self, name: str) -> int:
        """Id of a part in the renderers' part-id images (index + 1; 0 is background)."""
        return [p.name for p in self.parts].index(self.part(name).name) + 1

    @property
    def thickness_range_nm(self) -> tuple:
        """The film's thickness range, nm: its LUT's, or for a LUT-less film the feathers' thicknesses rounded
        outward to whole nm (:func:`rockdove.render.film.thickness_range_nm`)."""
        if self.film is None:
            raise ValueError(f"the scene {self.root_layer!r} has no thin-film feathers")
        feathers = [p.thickness_nm for p in self.parts if p.is_feather and p.thickness_nm is not None]
        return thickness_range_nm(self.film, np.concatenate(feathers) if feathers else [])

    def load_lut(self):
        """The :class:`rockdove.lut.ThinFilmLUT` to draw the film with: the EXR named by ``rockdove:lut:file``,
        or for a LUT-less asset one baked in memory (:func:`rockdove.render.film.lut_to_draw`)."""
        if self.film is None:
            raise ValueError(f"the scene {self.root_layer!r} has no thin-film feathers, so no LUT")
        return lut_to_draw(self.film, self.thickness_range_nm)


# -- USD reading ------------------------------------------------------------------------------------------
def register_schema() -> None:
    """Register the RockDoveThinFilmAPI codeless schema with USD before any stage is opened in this process.

    USD builds its schema registry once, at the first stage opened; a later registration is not seen, which
    would break other code in the same process (the USD stage's authoring and validation). The reader itself
    reads the attributes by name and does not need the schema. A no-op when the registry was already built
    without it (:func:`rockdove.usd.schema.register`).
    """
    from rockdove.usd.schema import register

    try:
        register()
    except RuntimeError:
        pass


def _read_mesh(prim, xcache, meters_per_unit, stage):
    from pxr import UsdGeom

    mesh = UsdGeom.Mesh(prim)
    path = str(prim.GetPath())
    pts = mesh.GetPointsAttr().Get()
    counts = mesh.GetFaceVertexCountsAttr().Get()
    fvi = mesh.GetFaceVertexIndicesAttr().Get()
    if pts is None or counts is None or fvi is None or len(pts) == 0 or len(counts) == 0:
        return None
    pts = np.asarray(pts, dtype=np.float64)
    counts = np.asarray(counts, dtype=np.int64)
    fvi = np.asarray(fvi, dtype=np.int64)
    if fvi.size and (fvi.min() < 0 or fvi.max() >= len(pts)):
        raise ValueError(f"{path}: faceVertexIndices out of range for {len(pts)} points")
    left = mesh.GetOrientationAttr().Get() == "leftHanded"

    film = read_film(prim)
    pvapi = UsdGeom.PrimvarsAPI(prim)
    attrs = {}  # name -> (values, interpolation)
    want = {"st": "st", "neck_s": "neckS", "preview_st": "previewST"}
    if film is not None:
        want["thickness"] = film.thickness_primvar
    for key, pv_name in want.items():
        pv = pvapi.GetPrimvar(pv_name)
        if pv and pv.HasValue():
            attrs[key] = primvar_array(pv, len(pts), counts, pv_name, path)
    if film is not None and "thickness" not in attrs:
        raise ValueError(f"{path}: thickness primvar primvars:{film.thickness_primvar} is missing")
    normals = mesh.GetNormalsAttr().Get()
    n_interp = mesh.GetNormalsInterpolation()
    pv_n = pvapi.GetPrimvar("normals")
    if pv_n and pv_n.HasValue():
        attrs["normals"] = primvar_array(pv_n, len(pts), counts, "normals", path)
    elif normals is not None and len(normals):
        class _N:  # adapter so authored normals go through the same interpolation handling
            def ComputeFlattened(self):
                return normals

            def GetInterpolation(self):
                return n_interp

        attrs["normals"] = primvar_array(_N(), len(pts), counts, "normals", path)

    face_varying = any(interp == "faceVarying" for _, interp in attrs.values())
    if face_varying:  # split vertices per face corner
        corner_tris = fan_triangulate_corners(counts)
        if left:
            corner_tris = corner_tris[:, [0, 2, 1]]
        positions = pts[fvi]
        tris = corner_tris
        out = {k: (v if interp == "faceVarying" else v[fvi]) for k, (v, interp) in attrs.items()}
    else:
        positions = pts
        tris = fan_triangulate(counts, fvi, left)
        out = {k: v for k, (v, _) in attrs.items()}

    m = np.asarray(xcache.GetLocalToWorldTransform(prim), dtype=np.float64)  # row-vector convention
    # a contiguous copy of the 3x3 block: numpy multiplies by a strided view element by element (60x slower)
    world = (positions @ np.ascontiguousarray(m[:3, :3]) + m[3, :3]) * meters_per_unit
    if "normals" in out:
        nrm = np.asarray(out["normals"], dtype=np.float64).reshape(-1, 3) @ np.linalg.inv(m[:3, :3]).T
        nlen = np.linalg.norm(nrm, axis=1, keepdims=True)
        nrm = nrm / np.maximum(nlen, 1e-30)
        if np.linalg.det(m[:3, :3]) < 0:
            tris = tris[:, [0, 2, 1]]
        nrm = nrm.astype(np.float32)
    else:
        if np.linalg.det(m[:3, :3]) < 0:
            tris = tris[:, [0, 2, 1]]
        nrm = vertex_normals(world, tris)
    n_v = len(world)
    st = np.asarray(out["st"], dtype=np.float32).reshape(n_v, 2) if "st" in out else np.zeros((n_v, 2), np.float32)
    thickness = np.asarray(out["thickness"], dtype=np.float32).reshape(n_v) if "thickness" in out else None
    neck_s = np.asarray(out["neck_s"], dtype=np.float32).reshape(n_v) if "neck_s" in out else None
    preview_st = np.asarray(out["preview_st"], np.float32).reshape(n_v, 2) if "preview_st" in out else None
    if thickness is not None and film is not None and film.thickness_units != "nm":
        raise ValueError(f"{path}: rockdove:film:thicknessUnits={film.thickness_units!r}; only 'nm' is allowed")

    kind, base_tex, srgb, mask_tex, colour_const, threshold = material_info(prim, stage)
    if film is not None:
        kind = "feather"
    if kind is None:
        kind = prim.GetName().lower()
    if colour_const is None:
        dc = pvapi.GetPrimvar("displayColor")
        v = dc.ComputeFlattened() if dc and dc.HasValue() else None
        colour_const = np.asarray(v[0], np.float32) if v is not None and len(v) else np.full(3, 0.5, np.float32)
    part = ScenePart(
        name=prim.GetName(),
        path=path,
        material_kind=kind,
        positions_m=np.ascontiguousarray(world, dtype=np.float32),
        normals=np.ascontiguousarray(nrm),
        triangles=np.ascontiguousarray(tris, dtype=np.int32),
        st=np.ascontiguousarray(st),
        thickness_nm=thickness,
        neck_s=neck_s,
        preview_st=preview_st,
        base_colour_texture=base_tex,
        base_colour_srgb=srgb,
        mask_texture=mask_tex,
        base_colour=np.asarray(colour_const, np.float32),
        opacity_threshold=threshold,
    )
    return part, film


def load_scene(path, variants: dict | None = None) -> RenderScene:
    """Open a written asset with pxr and read it back as a :class:`RenderScene`.

    Parameters
    ----------
    path : str or os.PathLike
        The asset folder (containing ``pigeon.usda``) or its root layer.
    variants : dict, optional
        Variant selections on the default prim, e.g. ``{"shading": "baked"}``; default: as authored.

    Returns
    -------
    RenderScene

    Raises
    ------
    ValueError
        The path is not a USD asset, a variant does not exist, no mesh is found, or the thin-film data
        or textures named in the asset are missing.
    """
    from pxr import Sdf, Usd, UsdGeom

    from ..usd.layout import resolve_root_layer

    layer_path = resolve_root_layer(path)
    register_schema()
    try:
        stage = Usd.Stage.Open(layer_path, Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise ValueError(f"path={os.fspath(path)!r} could not be opened as USD: {exc}") from None
    if stage is None:
        raise ValueError(f"path={os.fspath(path)!r} could not be opened as USD")
    up = UsdGeom.GetStageUpAxis(stage)
    if up != UsdGeom.Tokens.y:
        raise ValueError(f"{layer_path}: upAxis={up!r}; rockdove assets are Y-up (docs/design.md)")
    mpu = float(UsdGeom.GetStageMetersPerUnit(stage))
    root = stage.GetDefaultPrim() or stage.GetPseudoRoot()
    active = {}
    if variants:
        stage.SetEditTarget(stage.GetSessionLayer())
        vsets = root.GetVariantSets()
        for set_name, sel in variants.items():
            if not vsets.HasVariantSet(set_name):
                raise ValueError(f"variants={variants!r}: {root.GetPath()} has no variant set {set_name!r}; "
                                 f"it has {list(vsets.GetNames())}")
            vs = vsets.GetVariantSet(set_name)
            if sel not in vs.GetVariantNames():
                raise ValueError(f"variants={variants!r}: {set_name!r} must be one of {list(vs.GetVariantNames())}")
            vs.SetVariantSelection(sel)
        stage.Load(Sdf.Path.absoluteRootPath)
    if root and root.IsValid() and root != stage.GetPseudoRoot():
        vsets = root.GetVariantSets()
        active = {n: vsets.GetVariantSet(n).GetVariantSelection() for n in vsets.GetNames()}

    xcache = UsdGeom.XformCache(Usd.TimeCode.Default())
    parts, film = [], None
    for prim in Usd.PrimRange(root, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        img = UsdGeom.Imageable(prim)
        if img.ComputeVisibility() == UsdGeom.Tokens.invisible:
            continue
        if img.ComputePurpose() not in (UsdGeom.Tokens.default_, UsdGeom.Tokens.render):
            continue
        res = _read_mesh(prim, xcache, mpu, stage)
        if res is None:
            continue
        part, pf = res
        parts.append(part)
        if pf is not None and film is None:
            film = pf
    if not parts:
        raise ValueError(f"path={os.fspath(path)!r}: no visible mesh under {root.GetPath()}")
    return RenderScene(root_layer=layer_path, parts=tuple(parts), film=film, variants=active)

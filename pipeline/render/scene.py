"""Read a written rockdove USD asset back into plain numpy arrays for the GL renderer and the CPU reference.

The verifier checks what was *written*: this module opens the root layer from disk with pxr (payloads loaded,
a chosen ``shading`` variant), and returns a :class:`RenderScene` of numpy arrays only (no pxr objects), so
that the pyrender path (:mod:`pipeline.render.gl`) and the CPU reference see exactly the same data.

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
- the thin-film physics authored with ``RockDoveThinFilmAPI`` (:class:`ThinFilmParams`).

Conventions: texture images are returned by :func:`read_texture` with row 0 at the *top* of the image (file
order); :func:`sample_texture` looks up USD ``st`` (t = 0 at the bottom) the way OpenGL does with an image
uploaded bottom-row-first, bilinear, texel centres at ``(k + 0.5) / N``, clamp-to-edge. sRGB textures are
decoded to linear with the IEC 61966-2-1 EOTF (colour-science ``cctf_decoding``); raw textures are not.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..usd.material import OPACITY_THRESHOLD

#: Attribute-name prefix of the RockDoveThinFilmAPI schema (docs/design.md, "USD asset").
FILM_PREFIX = "rockdove:film:"
LUT_PREFIX = "rockdove:lut:"
#: Shader prim names of the materials (docs/design.md, "USD asset").
BASE_COLOR_SHADER = "BaseColorTexture"
MASK_SHADER = "MaskTexture"
#: Shader inputs that may hold a constant base colour for untextured parts (UsdPreviewSurface, MaterialX).
CONSTANT_COLOUR_INPUTS = ("diffuseColor", "base_color", "baseColor")
#: The feathers' alpha cut-off when none is authored: the one the asset authors (UsdPreviewSurface
#: ``opacityThreshold``, :data:`pipeline.usd.material.OPACITY_THRESHOLD`; docs/design.md "Conventions").
DEFAULT_OPACITY_THRESHOLD = OPACITY_THRESHOLD


@dataclass(frozen=True)
class ThinFilmParams:
    """The thin-film physics authored on the feathers with ``RockDoveThinFilmAPI``.

    Attributes
    ----------
    model : str
        ``rockdove:film:model``, e.g. ``"keratin_cauchy"`` or ``"paper"``.
    cauchy_a : float
        ``n(lambda) = cauchy_a + cauchy_b_nm2 / lambda_nm**2`` (dimensionless).
    cauchy_b_nm2 : float
        Cauchy B coefficient, nm^2.
    k : float
        ``rockdove:film:k``: constant extinction coefficient, the film index is ``n(lambda) + i k`` (k >= 0).
    incident_index, substrate_index : float
        Refractive indices of the incident medium (air) and the substrate below the film.
    thickness_primvar : str
        Name of the primvar holding the film thickness (without ``primvars:``).
    thickness_units : str
        ``"nm"``.
    lut_file : str
        Absolute path of the LUT EXR.
    lut_colour_space : str
        Colour space of the LUT (``lin_rec709`` or ``acescg``).
    angle_warp_gamma : float
        LUT angle-axis warp, ``cos_theta = x ** gamma``.
    thickness_range_nm : (float, float)
        LUT thickness axis ``(lo, hi)``, nm.
    illuminant, observer : str
        Colorimetry the LUT was baked with.
    """

    model: str
    cauchy_a: float
    cauchy_b_nm2: float
    incident_index: float
    substrate_index: float
    thickness_primvar: str
    thickness_units: str
    lut_file: str
    lut_colour_space: str
    angle_warp_gamma: float
    thickness_range_nm: tuple
    illuminant: str = "D65"
    observer: str = "CIE 1931 2 Degree Standard Observer"
    k: float = 0.0

    def film(self):
        """The recorded film as a :class:`pipeline.films.FilmModel` (its index model is the one of the bake)."""
        from ..films import FilmModel

        return FilmModel(self.model, self.cauchy_a, self.cauchy_b_nm2, k=self.k, n_incident=self.incident_index,
                         n_substrate=self.substrate_index)

    def film_index(self, wavelength_nm):
        """Film index ``A + B / lambda^2 (+ i k)`` for ``wavelength_nm`` (nm), same shape; complex when ``k != 0``
        (:meth:`pipeline.films.FilmModel.n_film`)."""
        return self.film().n_film(wavelength_nm)

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["thickness_range_nm"] = list(self.thickness_range_nm)
        return d


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

    def load_lut(self):
        """Read the LUT EXR named by ``rockdove:lut:file`` into a :class:`pipeline.lut.ThinFilmLUT`."""
        if self.film is None:
            raise ValueError(f"the scene {self.root_layer!r} has no thin-film feathers, so no LUT")
        return read_lut(self.film.lut_file)


# -- helpers ----------------------------------------------------------------------------------------------
def fan_triangulate(face_vertex_counts, face_vertex_indices, left_handed: bool = False) -> np.ndarray:
    """Fan-triangulate polygons: face ``(v0, v1, ..., vk)`` -> ``(v0, vi, vi+1)``, i = 1..k-1.

    Parameters
    ----------
    face_vertex_counts : array_like, (F,) int
        Vertices per face, each >= 3.
    face_vertex_indices : array_like, (sum(counts),) int
        Concatenated face vertex indices.
    left_handed : bool
        USD ``orientation = leftHanded``: the winding is reversed so output triangles are counter-clockwise.

    Returns
    -------
    ndarray, (sum(counts - 2), 3) int64
        Triangles. Indices are into ``face_vertex_indices``'s vertex numbering.
    """
    counts = np.asarray(face_vertex_counts, dtype=np.int64)
    fvi = np.asarray(face_vertex_indices, dtype=np.int64)
    if counts.size and counts.min() < 3:
        raise ValueError(f"face_vertex_counts must all be >= 3, got a face with {int(counts.min())}")
    if counts.sum() != fvi.size:
        raise ValueError(f"face_vertex_indices has {fvi.size} entries, face_vertex_counts sum to {counts.sum()}")
    tri_corners = fan_triangulate_corners(counts)
    tris = fvi[tri_corners]
    if left_handed:
        tris = tris[:, [0, 2, 1]]
    return tris


def fan_triangulate_corners(face_vertex_counts) -> np.ndarray:
    """Like :func:`fan_triangulate` but returns indices of face *corners* (positions in face_vertex_indices)."""
    counts = np.asarray(face_vertex_counts, dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    ntri = counts - 2
    face = np.repeat(np.arange(counts.size), ntri)
    first_tri = np.concatenate([[0], np.cumsum(ntri)[:-1]])
    k = np.arange(ntri.sum()) - first_tri[face] + 1
    s = starts[face]
    return np.stack([s, s + k, s + k + 1], axis=1)


def vertex_normals(positions, triangles) -> np.ndarray:
    """Area-weighted vertex normals, (V, 3) float32 unit (zero-area vertices get +Y)."""
    p = np.asarray(positions, dtype=np.float64)
    t = np.asarray(triangles)
    fn = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])
    n = np.zeros_like(p)
    for c in range(3):
        np.add.at(n, t[:, c], fn)
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(norm > 1e-30, n / np.maximum(norm, 1e-30), [0.0, 1.0, 0.0])
    return n.astype(np.float32)


def read_texture(path, srgb: bool) -> np.ndarray:
    """Read a PNG (any Pillow format) as linear float32, (H, W, C), row 0 = top of the image.

    ``srgb``: decode the colour channels with the sRGB EOTF (alpha, a 4th channel, stays linear). Values in
    [0, 1]. Grey images give C = 1, grey+alpha C = 2.
    """
    from PIL import Image

    with Image.open(path) as im:
        mode = im.mode
        if mode in ("P", "CMYK", "YCbCr", "LAB", "HSV", "1"):
            im = im.convert("RGBA" if "transparency" in im.info else "RGB")
        arr = np.asarray(im)
    if arr.dtype == np.uint16 or arr.dtype == np.int32:
        a = arr.astype(np.float32) / 65535.0
    elif arr.dtype == np.uint8:
        a = arr.astype(np.float32) / 255.0
    elif arr.dtype == np.bool_:
        a = arr.astype(np.float32)
    else:
        a = arr.astype(np.float32)
    if a.ndim == 2:
        a = a[:, :, None]
    if srgb:
        from .._compat import import_colour

        colour = import_colour()

        nc = 3 if a.shape[2] >= 3 else 1
        a = a.copy()
        a[:, :, :nc] = colour.cctf_decoding(a[:, :, :nc], function="sRGB")
    return np.ascontiguousarray(a, dtype=np.float32)


def sample_texture(image, st) -> np.ndarray:
    """Bilinear, clamp-to-edge lookup of ``image`` at USD ``st``, as OpenGL does (texel centres at (k+.5)/N).

    Parameters
    ----------
    image : ndarray, (H, W, C)
        Row 0 = top of the image (as :func:`read_texture` returns it); ``t = 0`` is the bottom row.
    st : ndarray, (..., 2)

    Returns
    -------
    ndarray, (..., C) float64
    """
    img = np.asarray(image, dtype=np.float64)
    h, w = img.shape[:2]
    st = np.asarray(st, dtype=np.float64)
    x = np.clip(st[..., 0] * w - 0.5, 0, w - 1)
    y = np.clip(st[..., 1] * h - 0.5, 0, h - 1)  # from the bottom
    x0 = np.minimum(np.floor(x).astype(np.intp), max(w - 2, 0))
    y0 = np.minimum(np.floor(y).astype(np.intp), max(h - 2, 0))
    x1 = np.minimum(x0 + 1, w - 1)
    y1 = np.minimum(y0 + 1, h - 1)
    tx = (x - x0)[..., None]
    ty = (y - y0)[..., None]
    rows0, rows1 = h - 1 - y0, h - 1 - y1  # bottom-up -> top-down rows
    c0 = img[rows0, x0] * (1 - tx) + img[rows0, x1] * tx
    c1 = img[rows1, x0] * (1 - tx) + img[rows1, x1] * tx
    return c0 * (1 - ty) + c1 * ty


def read_lut(path):
    """Read a LUT EXR (:func:`pipeline.lut.exr.read_exr`) into a :class:`pipeline.lut.ThinFilmLUT`."""
    from pipeline.lut.exr import read_exr

    if not os.path.isfile(path):
        raise ValueError(f"LUT file {path!r} (rockdove:lut:file) does not exist")
    return read_exr(path)


# -- USD reading ------------------------------------------------------------------------------------------
def register_schema() -> None:
    """Register the RockDoveThinFilmAPI codeless schema with USD before any stage is opened in this process.

    USD builds its schema registry once, at the first stage opened; a later registration is not seen, which
    would break other code in the same process (the USD stage's authoring and validation). The reader itself
    reads the attributes by name and does not need the schema. A no-op when the registry was already built
    without it (:func:`pipeline.usd.schema.register`).
    """
    from pipeline.usd.schema import register

    try:
        register()
    except RuntimeError:
        pass


def _asset_abs(attr, value) -> str | None:
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


def _primvar_array(pv, n_points: int, face_vertex_counts, name: str, prim_path: str):
    """Flattened primvar values and interpolation ('vertex' or 'faceVarying'; constant/uniform expanded)."""
    vals = pv.ComputeFlattened()
    if vals is None:
        return None, None
    a = np.asarray(vals)
    interp = pv.GetInterpolation()
    n_faces = len(face_vertex_counts)
    if interp == "constant":
        return np.repeat(a.reshape(1, *a.shape[1:]) if a.ndim else a[None], n_points, axis=0), "vertex"
    if interp == "uniform":
        if len(a) != n_faces:
            raise ValueError(f"{prim_path}: primvar {name} is uniform with {len(a)} values for {n_faces} faces")
        return np.repeat(a, face_vertex_counts, axis=0), "faceVarying"
    if interp in ("vertex", "varying"):
        if len(a) != n_points:
            raise ValueError(f"{prim_path}: primvar {name} has {len(a)} values for {n_points} points")
        return a, "vertex"
    if interp == "faceVarying":
        if len(a) != int(np.sum(face_vertex_counts)):
            raise ValueError(f"{prim_path}: faceVarying primvar {name} has {len(a)} values")
        return a, "faceVarying"
    raise ValueError(f"{prim_path}: primvar {name} has unsupported interpolation {interp!r}")


def _material_info(prim, stage):
    """(material kind from the name, base texture, srgb?, mask texture, constant colour, opacity threshold)."""
    from pxr import Usd, UsdShade

    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    if not mat:
        return None, None, True, None, None, DEFAULT_OPACITY_THRESHOLD
    name = mat.GetPrim().GetName()
    kind = name[: -len("Material")].lower() if name.endswith("Material") and len(name) > 8 else name.lower()
    base = mask = colour_const = None
    srgb = True
    threshold = DEFAULT_OPACITY_THRESHOLD
    for p in Usd.PrimRange(mat.GetPrim()):
        if not p.IsA(UsdShade.Shader):
            continue
        sh = UsdShade.Shader(p)
        if p.GetName() in (BASE_COLOR_SHADER, MASK_SHADER):
            inp = sh.GetInput("file")
            if not inp:
                raise ValueError(f"{p.GetPath()}: texture shader has no inputs:file")
            path = _asset_abs(inp.GetAttr(), inp.Get())
            if path is None:
                raise ValueError(f"{p.GetPath()}: inputs:file is empty")
            if not os.path.isfile(path):
                raise ValueError(f"{p.GetPath()}: texture {path!r} does not exist")
            if p.GetName() == BASE_COLOR_SHADER:
                base = path
                cs = sh.GetInput("sourceColorSpace")
                cs_val = cs.Get() if cs else None
                if cs_val is None:  # MaterialX: colorspace metadata on the file input
                    cs_val = inp.GetAttr().GetColorSpace() or "sRGB"
                srgb = str(cs_val).lower() not in ("raw", "lin_rec709", "linear")
            else:
                mask = path
        for key in CONSTANT_COLOUR_INPUTS:
            inp = sh.GetInput(key)
            if inp and colour_const is None and not inp.HasConnectedSource():
                v = inp.Get()
                if v is not None:
                    colour_const = np.asarray(v, dtype=np.float32).reshape(3)
        thr = sh.GetInput("opacityThreshold")
        if thr and thr.Get() is not None and float(thr.Get()) > 0:
            threshold = float(thr.Get())
    return kind, base, srgb, mask, colour_const, threshold


def _film_params(prim) -> ThinFilmParams | None:
    attr_model = prim.GetAttribute(FILM_PREFIX + "model")
    if not attr_model or attr_model.Get() is None:
        return None

    def get(name, required=True):
        a = prim.GetAttribute(name)
        v = a.Get() if a else None
        if v is None and required:
            raise ValueError(f"{prim.GetPath()}: RockDoveThinFilmAPI attribute {name} is missing")
        return a, v

    a_lut, lut = get(LUT_PREFIX + "file")
    lut_path = _asset_abs(a_lut, lut)
    if lut_path is None or not os.path.isfile(lut_path):
        raise ValueError(f"{prim.GetPath()}: rockdove:lut:file {getattr(lut, 'path', lut)!r} does not resolve "
                         "to a file")
    rng = get(LUT_PREFIX + "thicknessRangeNm")[1]
    _, illum = get(LUT_PREFIX + "illuminant", required=False)
    _, obs = get(LUT_PREFIX + "observer", required=False)
    return ThinFilmParams(
        model=str(attr_model.Get()),
        cauchy_a=float(get(FILM_PREFIX + "cauchyA")[1]),
        cauchy_b_nm2=float(get(FILM_PREFIX + "cauchyB_nm2")[1]),
        k=float(get(FILM_PREFIX + "k", required=False)[1] or 0.0),  # the schema's fallback: not absorbing
        incident_index=float(get(FILM_PREFIX + "incidentIndex")[1]),
        substrate_index=float(get(FILM_PREFIX + "substrateIndex")[1]),
        thickness_primvar=str(get(FILM_PREFIX + "thicknessPrimvar")[1]),
        thickness_units=str(get(FILM_PREFIX + "thicknessUnits")[1]),
        lut_file=lut_path,
        lut_colour_space=str(get(LUT_PREFIX + "colorSpace")[1]),
        angle_warp_gamma=float(get(LUT_PREFIX + "angleWarpGamma")[1]),
        thickness_range_nm=(float(rng[0]), float(rng[1])),
        illuminant=str(illum) if illum is not None else "D65",
        observer=str(obs) if obs is not None else "CIE 1931 2 Degree Standard Observer",
    )


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

    film = _film_params(prim)
    pvapi = UsdGeom.PrimvarsAPI(prim)
    attrs = {}  # name -> (values, interpolation)
    want = {"st": "st", "neck_s": "neckS"}
    if film is not None:
        want["thickness"] = film.thickness_primvar
    for key, pv_name in want.items():
        pv = pvapi.GetPrimvar(pv_name)
        if pv and pv.HasValue():
            attrs[key] = _primvar_array(pv, len(pts), counts, pv_name, path)
    if film is not None and "thickness" not in attrs:
        raise ValueError(f"{path}: thickness primvar primvars:{film.thickness_primvar} is missing")
    normals = mesh.GetNormalsAttr().Get()
    n_interp = mesh.GetNormalsInterpolation()
    pv_n = pvapi.GetPrimvar("normals")
    if pv_n and pv_n.HasValue():
        attrs["normals"] = _primvar_array(pv_n, len(pts), counts, "normals", path)
    elif normals is not None and len(normals):
        class _N:  # adapter so authored normals go through the same interpolation handling
            def ComputeFlattened(self):
                return normals

            def GetInterpolation(self):
                return n_interp

        attrs["normals"] = _primvar_array(_N(), len(pts), counts, "normals", path)

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
    world = (positions @ m[:3, :3] + m[3, :3]) * meters_per_unit
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
    if thickness is not None and film is not None and film.thickness_units != "nm":
        raise ValueError(f"{path}: rockdove:film:thicknessUnits={film.thickness_units!r}; only 'nm' is allowed")

    kind, base_tex, srgb, mask_tex, colour_const, threshold = _material_info(prim, stage)
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

"""Compare a GL render with the CPU reference: dE2000 maps, statistics and the image checks of issue 5.

What is compared
----------------
Both renders hold linear ``lin_rec709`` radiance, unclipped (thin-film colours are often outside the Rec.709
gamut, so a component may be negative). The dE2000 map is computed on that linear data, not on the 8-bit
display images: the display transform (clip to [0, 1], sRGB OETF, 8 bits) is for people and would hide
out-of-gamut and quantisation differences. Colours go to CIELAB with the D65 white at Y = 1 through
:func:`rockdove.spectral.RGB_to_Lab` and are compared with CIEDE2000 (Sharma, Wu and Dalal 2005, as
implemented by colour-science) through :func:`rockdove.spectral.delta_E_2000`.

Pixels compared: feather pixels away from silhouette edges, i.e. covered by a feather part in BOTH renders,
with the same part id, after eroding each render's feather coverage by ``erode_px`` pixels (8-connected).
Edge pixels are excluded because a rasteriser and a ray caster legitimately disagree there (coverage rules,
texture filtering of the alpha cut-out).

Checks
------
- finite: no NaN or Inf anywhere in either render.
- black holes: lit feather pixels (reference ``N.L >= LIT_N_DOT_L``) whose GL radiance is ~zero
  (max channel below ``BLACK_RADIANCE``); a correct render has none, because every film colour has a
  luminance of at least a few per cent.
- hue: CIELAB hue angle ``h_ab = atan2(b*, a*)`` of the structural feather pixels (reference mask >= 0.5)
  that are chromatic (``C*ab / L* >= HUE_MIN_SATURATION``: a ratio, so that dimly lit pixels keep their hue),
  histogrammed in ``HUE_BIN_DEG`` bins and classified into the two bands of the rock dove's neck:
  :data:`GREEN_BAND_DEG` and :data:`PURPLE_BAND_DEG` (measured on the Airy colours of a 480-700 nm keratin
  film under D65: greens have h_ab 115-205 deg, purples/magentas 310-355 deg).
- boundary straightness: see :func:`boundary_straightness`.
"""

from __future__ import annotations

from copy import deepcopy
from dataclasses import dataclass, field, fields

import numpy as np

#: Goals of issue 5: a verification fails above these (dE2000 over the compared feather pixels).
MEDIAN_DE_GOAL = 1.0
P95_DE_GOAL = 2.0
#: A feather pixel is "lit" when the reference's N.L is at least this.
LIT_N_DOT_L = 0.1
#: Radiance (max channel, linear, light = 1) below which a lit pixel counts as a black hole. The darkest
#: film colour of the presets has Y > 0.02 and the feather base colour is well above 1e-3 linear.
BLACK_RADIANCE = 1e-4
#: A verification fails when more than this fraction of the lit feather pixels are black holes.
BLACK_FRACTION_GOAL = 0.002
#: Pixels with less chroma per lightness (C*ab / L*) than this are grey, not green or purple. The film colours
#: of the presets have C*/L* of 0.4-1.3 (0.35 at the 650 nm film's blue transition near cos theta = 0.707).
HUE_MIN_SATURATION = 0.15
#: Pixels darker than this (L*) have no hue.
HUE_MIN_LIGHTNESS = 1.0
#: Reference mask from which a feather pixel counts as structural colour in the hue statistics.
STRUCTURAL_MASK = 0.5
HUE_BIN_DEG = 30.0
#: Hue bands (h_ab, degrees, half-open [lo, hi), wrapping through 360 when lo > hi).
GREEN_BAND_DEG = (100.0, 210.0)
PURPLE_BAND_DEG = (280.0, 15.0)
#: The green side of the hue circle, [lo, hi): the purple side is the rest. The splits are the middles of the
#: gaps between the bands (blue, 210-280 deg, and red-yellow, 15-100 deg).
SIDE_SPLIT_DEG = (57.5, 245.0)
#: Reach of the green/purple contact zone, pixels (see :func:`boundary_points`).
BOUNDARY_REACH_PX = 2


def _as_image(name: str, a, channels: int | None) -> np.ndarray:
    a = np.asarray(a)
    ok = a.ndim == 3 and a.shape[2] == channels if channels else a.ndim == 2
    if not ok:
        want = f"(H, W, {channels})" if channels else "(H, W)"
        raise ValueError(f"{name} must have shape {want}, got {a.shape}")
    return a


def erode(mask: np.ndarray, pixels: int) -> np.ndarray:
    """Binary erosion of a boolean image by ``pixels`` with the 3 x 3 (8-connected) structuring element.

    Pixels outside the image count as background, so image borders are eroded too.
    """
    from scipy import ndimage

    mask = np.asarray(mask, dtype=bool)
    if pixels < 0:
        raise ValueError(f"pixels must be >= 0, got {pixels}")
    if pixels == 0:
        return mask.copy()
    out = np.zeros_like(mask)
    box = _bounding_box(mask)
    if box is not None:  # outside the mask's bounding box every pixel is background, as the border is: eroding
        # the box alone (its border taken as background) is the whole image's erosion, for a fraction of the work
        out[box] = ndimage.binary_erosion(mask[box], structure=np.ones((3, 3), bool), iterations=pixels,
                                          border_value=0)
    return out


def _bounding_box(mask: np.ndarray) -> tuple[slice, slice] | None:
    """The smallest ``(rows, columns)`` slices holding every True pixel of an (H, W) mask; None if it has none."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return None
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def comparison_mask(gl_part, ref_part, feather_part_ids, erode_px: int = 1) -> np.ndarray:
    """Feather pixels away from silhouette edges that both renders agree on.

    Parameters
    ----------
    gl_part, ref_part : ndarray, shape (H, W), int
        Part id per pixel (-1 for background) of each render.
    feather_part_ids : sequence of int
        Ids of the feather parts.
    erode_px : int
        Erosion of each render's feather coverage, pixels.

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    gl_part = _as_image("gl_part", gl_part, None)
    ref_part = _as_image("ref_part", ref_part, None)
    if gl_part.shape != ref_part.shape:
        raise ValueError(f"gl_part {gl_part.shape} and ref_part {ref_part.shape} must have the same shape")
    ids = np.asarray(list(feather_part_ids), dtype=np.int64)
    gl_f = erode(np.isin(gl_part, ids), erode_px)
    ref_f = erode(np.isin(ref_part, ids), erode_px)
    return gl_f & ref_f & (gl_part == ref_part)


def rgb_to_lab(rgb_linear: np.ndarray) -> np.ndarray:
    """Linear lin_rec709 colour (unclipped) to CIELAB (D65 white at Y = 1), shape (..., 3)."""
    from .. import spectral

    return np.asarray(spectral.RGB_to_Lab(np.asarray(rgb_linear, np.float64)), np.float64)


def delta_e_map(gl_rgb, ref_rgb, mask=None) -> np.ndarray:
    """CIEDE2000 between the colours of two linear renders.

    Parameters
    ----------
    gl_rgb, ref_rgb : ndarray, shape (H, W, 3)
        Linear lin_rec709 radiance.
    mask : ndarray, shape (H, W), bool, optional
        Pixels to compute; others are NaN.

    Returns
    -------
    ndarray, shape (H, W), float64: dE2000, NaN outside ``mask``.
    """
    from .. import spectral

    gl_rgb = _as_image("gl_rgb", gl_rgb, 3)
    ref_rgb = _as_image("ref_rgb", ref_rgb, 3)
    if gl_rgb.shape != ref_rgb.shape:
        raise ValueError(f"gl_rgb {gl_rgb.shape} and ref_rgb {ref_rgb.shape} must have the same shape")
    if mask is None:
        mask = np.ones(gl_rgb.shape[:2], bool)
    out = np.full(gl_rgb.shape[:2], np.nan)
    if mask.any():
        lab_gl = rgb_to_lab(gl_rgb[mask])
        lab_ref = rgb_to_lab(ref_rgb[mask])
        out[mask] = np.asarray(spectral.delta_E_2000(lab_gl, lab_ref), np.float64)
    return out


def _in_band(h_deg: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    lo, hi = band
    return (h_deg >= lo) & (h_deg < hi) if lo <= hi else (h_deg >= lo) | (h_deg < hi)


def hue_classes(rgb_linear: np.ndarray, sides: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hue angle, chroma and class of displayed colours.

    Parameters
    ----------
    rgb_linear : ndarray, (..., 3), linear lin_rec709
    sides : bool
        False: the strict bands (1 green, 2 purple, 3 any other hue). True: every chromatic colour goes to the
        nearer side of the hue circle, split at :data:`SIDE_SPLIT_DEG` (the middles of the gaps between the two
        bands), so 1 = green side, 2 = purple side; used for the boundary, because the film passes from
        green to purple through blue or through red-yellow hues, depending on the thickness.

    Returns
    -------
    h_deg : ndarray, shape (...), CIELAB hue angle h_ab in [0, 360)
    chroma : ndarray, shape (...), C*ab
    cls : ndarray, shape (...), int8: 0 grey (C*ab / L* < HUE_MIN_SATURATION or L* < HUE_MIN_LIGHTNESS),
        1 green, 2 purple, 3 other hue
    """
    return lab_hue_classes(rgb_to_lab(rgb_linear), sides)


def lab_hue_classes(lab: np.ndarray, sides: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`hue_classes` of colours already in CIELAB (:func:`rgb_to_lab`), shape (..., 3)."""
    lab = np.asarray(lab, np.float64)
    h = np.degrees(np.arctan2(lab[..., 2], lab[..., 1])) % 360.0
    c = np.hypot(lab[..., 1], lab[..., 2])
    if sides:
        cls = np.where(_in_band(h, SIDE_SPLIT_DEG), 1, 2).astype(np.int8)
    else:
        cls = np.full(h.shape, 3, np.int8)
        cls[_in_band(h, GREEN_BAND_DEG)] = 1
        cls[_in_band(h, PURPLE_BAND_DEG)] = 2
    cls[(c < HUE_MIN_SATURATION * lab[..., 0]) | (lab[..., 0] < HUE_MIN_LIGHTNESS)] = 0
    return h, c, cls


def hue_histogram(rgb_pixels: np.ndarray) -> dict:
    """Histogram of CIELAB hue over chromatic pixels, and the green/purple/grey/other counts.

    Parameters
    ----------
    rgb_pixels : ndarray, shape (N, 3), linear lin_rec709

    Returns
    -------
    dict with ``bin_edges_deg`` (list), ``counts`` (list), ``green``, ``purple``, ``grey``, ``other`` (int)
    """
    rgb_pixels = np.asarray(rgb_pixels, np.float64).reshape(-1, 3)
    return lab_hue_histogram(rgb_to_lab(rgb_pixels) if len(rgb_pixels) else np.zeros((0, 3)))


def lab_hue_histogram(lab_pixels: np.ndarray) -> dict:
    """:func:`hue_histogram` of pixels already in CIELAB (:func:`rgb_to_lab`), shape (N, 3)."""
    lab_pixels = np.asarray(lab_pixels, np.float64).reshape(-1, 3)
    edges = np.arange(0.0, 360.0 + HUE_BIN_DEG, HUE_BIN_DEG)
    if len(lab_pixels) == 0:
        counts, cls = np.zeros(len(edges) - 1, int), np.zeros(0, np.int8)
    else:
        h, _, cls = lab_hue_classes(lab_pixels)
        counts, _ = np.histogram(h[cls > 0], bins=edges)
    return {
        "bin_edges_deg": edges.tolist(),
        "counts": [int(c) for c in counts],
        "grey": int(np.sum(cls == 0)),
        "green": int(np.sum(cls == 1)),
        "purple": int(np.sum(cls == 2)),
        "other": int(np.sum(cls == 3)),
        "min_saturation": HUE_MIN_SATURATION,
        "green_band_deg": list(GREEN_BAND_DEG),
        "purple_band_deg": list(PURPLE_BAND_DEG),
    }


def boundary_points(cls: np.ndarray, reach_px: int = BOUNDARY_REACH_PX) -> np.ndarray:
    """Pixels on the green/purple boundary of a class image.

    The boundary is the contact zone of the two classes: pixels within ``reach_px`` (8-connected steps) of a
    green pixel AND within ``reach_px`` of a purple pixel. Unlike plain 4-adjacency this bridges the narrow
    band of low-chroma or blue pixels that the film shows between green and purple (at 650 nm and cos theta
    near 0.707 the chroma drops to ~12) and the grey feather bases between coloured tips, so gaps up to
    ``2 * reach_px`` pixels still give a boundary. For a straight boundary the zone is a band about
    ``2 * reach_px`` wide, which adds ~``2 * reach_px / sqrt(12)`` px to the RMS of
    :func:`boundary_straightness`.

    Parameters
    ----------
    cls : ndarray, shape (H, W), int: the classes of :func:`hue_classes` (1 green, 2 purple; others ignored),
        normally with ``sides=True``
    reach_px : int, >= 1

    Returns
    -------
    ndarray, shape (P, 2), float64: (x, y) in pixels (x = column, y = row, pixel centres at integers)
    """
    from scipy import ndimage

    cls = _as_image("cls", cls, None)
    if int(reach_px) != reach_px or reach_px < 1:
        raise ValueError(f"reach_px must be an integer >= 1, got {reach_px!r}")
    st = np.ones((3, 3), bool)
    near_green = ndimage.binary_dilation(cls == 1, structure=st, iterations=int(reach_px))
    near_purple = ndimage.binary_dilation(cls == 2, structure=st, iterations=int(reach_px))
    r, c = np.nonzero(near_green & near_purple)
    return np.stack([c.astype(float), r.astype(float)], axis=1)


def boundary_straightness(cls: np.ndarray, min_points: int = 8, bin_px: float = 2.0) -> dict:
    """How far the green/purple boundary of a class image departs from a straight line.

    Method:

    1. the contact-zone pixels of :func:`boundary_points`;
    2. a first line through them by total least squares (TLS: the principal axis of the points, the line
       minimising the sum of squared perpendicular distances);
    3. the zone's centreline: the points are binned along that line in ``bin_px`` steps and each bin is
       replaced by its mean point, so the zone's own width does not count as curvature;
    4. a TLS line through the centreline; the measure is the RMS perpendicular distance of the centreline
       points from it, in pixels, and as a fraction of the boundary's length (the centreline's extent along the
       line), which does not depend on the image size. To be robust to a stray feather tip of the other colour,
       the fit is repeated once without centreline points farther than 3 x their median distance (when at least
       half remain).

    A straight boundary gives a fraction of the pixel quantisation (~0.3 px); a bent one its sagitta over
    ~3 (a parabola of sagitta 40 px gives ~12 px).

    Parameters
    ----------
    cls : ndarray, shape (H, W), int
        Classes as from :func:`hue_classes`, normally ``sides=True`` (1 green side, 2 purple side).
    min_points : int
        Fewer centreline points than this give no measure (``rms_px`` NaN).
    bin_px : float
        Bin length along the boundary, pixels.

    Returns
    -------
    dict: ``n_points`` (contact-zone pixels), ``n_centreline``, ``rms_px``, ``length_px``, ``rms_fraction``
    (rms_px / length_px), ``direction`` (unit (x, y)), ``centre`` ((x, y) px).
    """
    pts = boundary_points(cls)
    out = {"n_points": int(len(pts)), "n_centreline": 0, "rms_px": float("nan"), "length_px": float("nan"),
           "rms_fraction": float("nan"), "direction": None, "centre": None}
    if len(pts) < 2:
        return out

    def fit(p):
        centre = p.mean(axis=0)
        _, _, vt = np.linalg.svd(p - centre, full_matrices=False)
        return centre, vt[0], (p - centre) @ vt[1]

    centre, direction, _ = fit(pts)
    along = (pts - centre) @ direction
    bins = np.floor((along - along.min()) / bin_px).astype(np.int64)
    counts = np.bincount(bins)
    used = counts > 0
    line = np.stack([np.bincount(bins, weights=pts[:, k])[used] / counts[used] for k in (0, 1)], axis=1)
    out["n_centreline"] = int(len(line))
    if len(line) < min_points:
        return out
    centre, direction, dist = fit(line)
    med = np.median(np.abs(dist))
    keep = np.abs(dist) <= 3.0 * max(med, 0.5)
    if keep.sum() >= max(min_points, len(line) // 2) and not keep.all():
        line = line[keep]
        centre, direction, dist = fit(line)
    along = (line - centre) @ direction
    length = float(along.max() - along.min())
    rms = float(np.sqrt(np.mean(dist**2)))
    out.update(n_centreline=int(len(line)), rms_px=rms, length_px=length,
               rms_fraction=rms / length if length > 0 else float("nan"),
               direction=[float(v) for v in direction], centre=[float(v) for v in centre])
    return out


@dataclass
class ViewMetrics:
    """Metrics of one view: the GL render against the reference.

    Attributes
    ----------
    view : str
    n_pixels : int
        Compared feather pixels (see :func:`comparison_mask`).
    de_median, de_p95, de_max, de_mean : float
        dE2000 statistics over those pixels (NaN when there are none).
    de_fraction_over_p95_goal : float
        Fraction of those pixels above :data:`P95_DE_GOAL` (isolated alpha-edge disagreements show here).
    finite : bool
        No NaN/Inf in either render.
    n_lit, n_black : int
        Lit feather pixels and, among them, black holes in the GL render.
    black_fraction : float
    hue : dict
        :func:`hue_histogram` of the GL render's compared structural feather pixels.
    passed : bool
        dE goals met (vacuously when ``n_pixels`` is 0), finite, black fraction within its goal.
    failures : list of str
        Why not, one line each.
    de_map : ndarray, shape (H, W)
        dE2000, NaN where not compared (not serialised by :meth:`summary`).
    cls : ndarray, shape (H, W), int8
        Hue side (:func:`hue_classes` with ``sides=True``) of the GL render's compared structural pixels, -1 elsewhere
        (not serialised); the input of :func:`boundary_straightness`.
    strict : ndarray, shape (H, W), int8
        The strict hue bands (:func:`hue_classes`, ``sides=False``) of the same pixels, -1 elsewhere (not
        serialised); with ``cls`` the input of :func:`rockdove.verify.boundary.class_shape`.
    """

    view: str
    n_pixels: int
    de_median: float
    de_p95: float
    de_max: float
    de_mean: float
    de_fraction_over_p95_goal: float
    finite: bool
    n_lit: int
    n_black: int
    black_fraction: float
    hue: dict
    passed: bool
    failures: list = field(default_factory=list)
    de_map: np.ndarray | None = field(default=None, repr=False)
    cls: np.ndarray | None = field(default=None, repr=False)
    strict: np.ndarray | None = field(default=None, repr=False)

    def summary(self) -> dict:
        """JSON-ready dict of every metric (no images)."""
        return {f.name: _copy(getattr(self, f.name)) for f in fields(self) if f.name not in _IMAGES}


#: The fields of :class:`ViewMetrics` that are images (not in its summary).
_IMAGES = ("de_map", "cls", "strict")


def _copy(value):
    """A field's value as :func:`dataclasses.asdict` gives it (containers copied deeply, so the summary shares no
    list or dict with the metrics), without copying the images first."""
    return deepcopy(value) if isinstance(value, (dict, list)) else value


def compare_arrays(
    view: str,
    gl_rgb,
    ref_rgb,
    gl_part,
    ref_part,
    feather_part_ids,
    ref_n_dot_l=None,
    ref_mask=None,
    erode_px: int = 1,
) -> ViewMetrics:
    """:func:`compare` on plain arrays.

    Parameters
    ----------
    view : str
    gl_rgb, ref_rgb : ndarray, shape (H, W, 3), linear lin_rec709
    gl_part, ref_part : ndarray, shape (H, W), int, -1 background
    feather_part_ids : sequence of int
    ref_n_dot_l : ndarray, shape (H, W), optional
        The reference's max(N.L, 0) per pixel; without it, no black-hole check (n_lit = 0).
    ref_mask : ndarray, shape (H, W), optional
        The reference's structural-colour mask; the hue statistics use compared pixels with mask >=
        :data:`STRUCTURAL_MASK` (all compared pixels without it).
    erode_px : int
    """
    from .. import spectral

    # Only the compared pixels are converted, classified and checked (a few per cent of the image); every number
    # is that of the whole-image formulation: the dE map is NaN elsewhere, and the black-hole and hue pixels are
    # subsets of the compared ones. Non-finite values count as 0 in the statistics (``finite`` reports them).
    gl_rgb = _as_image("gl_rgb", gl_rgb, 3)
    ref_rgb = _as_image("ref_rgb", ref_rgb, 3)
    if gl_rgb.shape != ref_rgb.shape:
        raise ValueError(f"gl_rgb {gl_rgb.shape} and ref_rgb {ref_rgb.shape} must have the same shape")
    finite = bool(np.isfinite(gl_rgb).all() and np.isfinite(ref_rgb).all())
    mask = comparison_mask(gl_part, ref_part, feather_part_ids, erode_px)
    gl_px, ref_px = (_finite_or_zero(a[mask]) for a in (gl_rgb, ref_rgb))
    n = int(gl_px.shape[0])
    lab_gl = rgb_to_lab(gl_px)
    de = np.full(mask.shape, np.nan)
    vals = np.asarray(spectral.delta_E_2000(lab_gl, rgb_to_lab(ref_px)), np.float64) if n else np.zeros(0)
    de[mask] = vals
    stats = (np.median(vals), np.percentile(vals, 95), vals.max(), vals.mean()) if n else (np.nan,) * 4
    if ref_n_dot_l is not None:
        lit = np.asarray(ref_n_dot_l)[mask] >= LIT_N_DOT_L
        n_lit = int(lit.sum())
        n_black = int(np.sum(np.abs(gl_px[lit]).max(axis=1) < BLACK_RADIANCE))
    else:
        n_lit = n_black = 0
    black_fraction = n_black / n_lit if n_lit else 0.0
    structural = np.asarray(ref_mask)[mask] >= STRUCTURAL_MASK if ref_mask is not None else np.ones(n, bool)
    hue_mask = np.zeros(mask.shape, bool)
    hue_mask[mask] = structural
    lab_hue = lab_gl[structural]
    cls_img = np.full(mask.shape, -1, np.int8)
    strict_img = np.full(mask.shape, -1, np.int8)
    if lab_hue.size:
        cls_img[hue_mask] = lab_hue_classes(lab_hue, sides=True)[2]
        strict_img[hue_mask] = lab_hue_classes(lab_hue)[2]
    failures = []
    if not finite:
        failures.append(f"{view}: NaN or Inf in a render")
    if n > 0:  # a view without feather pixels (neck hidden, tiny image) has nothing to fail; verify checks the total
        if stats[0] > MEDIAN_DE_GOAL:
            failures.append(f"{view}: median dE2000 {stats[0]:.3f} > {MEDIAN_DE_GOAL}")
        if stats[1] > P95_DE_GOAL:
            failures.append(f"{view}: p95 dE2000 {stats[1]:.3f} > {P95_DE_GOAL}")
    if black_fraction > BLACK_FRACTION_GOAL:
        failures.append(f"{view}: {n_black} of {n_lit} lit feather pixels are black ({black_fraction:.2%})")
    return ViewMetrics(
        view=view, n_pixels=n, de_median=float(stats[0]), de_p95=float(stats[1]), de_max=float(stats[2]),
        de_mean=float(stats[3]), de_fraction_over_p95_goal=float(np.mean(vals > P95_DE_GOAL)) if n else float("nan"),
        finite=finite, n_lit=n_lit, n_black=n_black, black_fraction=black_fraction,
        hue=lab_hue_histogram(lab_hue), passed=not failures, failures=failures, de_map=de, cls=cls_img,
        strict=strict_img,
    )


def _finite_or_zero(rgb_pixels: np.ndarray) -> np.ndarray:
    """(N, 3) pixels as float64, NaN and Inf replaced by 0."""
    a = np.asarray(rgb_pixels, np.float64)
    return np.where(np.isfinite(a), a, 0.0)


def gl_arrays(result) -> dict:
    """The arrays of a GL :class:`rockdove.render.gl.RenderResult` that the comparison needs."""

    def get(*names):
        for n in names:
            v = getattr(result, n, None)
            if v is not None:
                return np.asarray(v)
        raise ValueError(f"gl_result ({type(result).__name__}) has no attribute {names[0]!r}")

    return {"rgb": get("radiance_rgb"), "part_id": get("part_id")}


def compare(gl_result, ref_result, scene, erode_px: int = 1) -> ViewMetrics:
    """Compare one view's GL render with its reference render (see :func:`compare_arrays`).

    Parameters
    ----------
    gl_result : rockdove.render.gl.RenderResult
    ref_result : rockdove.verify.reference_image.ReferenceResult
    scene : rockdove.render.scene.RenderScene
        Gives the feather part ids (``index + 1`` of feather parts).
    """
    g = gl_arrays(gl_result)
    feather_ids = [i + 1 for i, p in enumerate(scene.parts) if p.is_feather]
    return compare_arrays(ref_result.view, g["rgb"], ref_result.rgb, g["part_id"], ref_result.part_id,
                          feather_ids, ref_n_dot_l=ref_result.n_dot_l, ref_mask=ref_result.mask,
                          erode_px=erode_px)


def reference_classes(ref_result, scene) -> np.ndarray:
    """Hue classes of the reference's feather pixels (used when there is no GL render)."""
    feather = np.isin(ref_result.part_id, [i + 1 for i, p in enumerate(scene.parts) if p.is_feather])
    feather &= ref_result.mask >= STRUCTURAL_MASK
    cls = np.full(feather.shape, -1, np.int8)
    if feather.any():
        cls[feather] = hue_classes(ref_result.rgb[feather].astype(np.float64), sides=True)[2]
    return cls

"""Compare a GL render with the CPU reference: dE2000 maps, statistics and the image checks.

Both renders hold linear ``lin_rec709`` radiance, unclipped (thin-film colours are often outside the Rec.709
gamut); the dE2000 map is computed on that, not on the 8-bit display images, which would hide out-of-gamut and
quantisation differences: CIELAB with the D65 white at Y = 1, CIEDE2000 (Sharma, Wu and Dalal 2005, as implemented
by colour-science) through :mod:`rockdove.spectral`. Pixels compared: a feather part with the same id in BOTH
renders after eroding each coverage by ``erode_px`` pixels: a rasteriser and a ray caster legitimately disagree at
silhouette edges (coverage rules, texture filtering of the alpha cut-out).

Checks: no NaN or Inf; no black holes (lit feather pixels whose GL radiance is ~zero: every film colour has a
luminance of at least a few per cent); the CIELAB hue ``h_ab = atan2(b*, a*)`` of the chromatic structural pixels
(``C*ab / L*``: a ratio, so dimly lit pixels keep their hue), classified into the two bands of the rock dove's neck
(the Airy colours of a 480-700 nm keratin film under D65: greens h_ab 115-205 deg, purples 310-355 deg)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .. import spectral
from ..errors import UsageError
from .records import Record

#: The goals: a verification fails above these (dE2000 over the compared feather pixels).
MEDIAN_DE_GOAL = 1.0
P95_DE_GOAL = 2.0
#: A feather pixel is "lit" when the reference's N.L is at least this.
LIT_N_DOT_L = 0.1
#: Radiance (max channel, linear, light = 1) below which a lit pixel counts as a black hole. The darkest
#: film colour of the presets has Y > 0.02 and the feather base colour is well above 1e-3 linear.
BLACK_RADIANCE = 1e-4
#: A verification fails when more than this fraction of the lit feather pixels are black holes.
BLACK_FRACTION_GOAL = 0.002
#: Pixels with less chroma per lightness (C*ab / L*) than this, or darker than L* 1, are grey. The film colours
#: of the presets have C*/L* of 0.4-1.3 (0.35 at the 650 nm film's blue transition near cos theta = 0.707).
HUE_MIN_SATURATION = 0.15
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


def _same_shape(name_a: str, a, name_b: str, b, channels: int | None) -> tuple[np.ndarray, np.ndarray]:
    """``a`` and ``b`` as arrays of one (H, W) or (H, W, channels) shape; ValueError naming the one that is not."""
    a, b = np.asarray(a), np.asarray(b)
    for name, x in ((name_a, a), (name_b, b)):
        if not (x.ndim == 3 and x.shape[2] == channels if channels else x.ndim == 2):
            want = f"(H, W, {channels})" if channels else "(H, W)"
            raise UsageError(f"{name} must have shape {want}, got {x.shape}")
    if a.shape != b.shape:
        raise UsageError(f"{name_a} {a.shape} and {name_b} {b.shape} must have the same shape")
    return a, b


def erode(mask: np.ndarray, pixels: int) -> np.ndarray:
    """Binary erosion of a boolean image by ``pixels`` (3 x 3, 8-connected); outside the image is background."""
    from scipy import ndimage

    mask = np.asarray(mask, dtype=bool)
    if pixels < 0:
        raise UsageError(f"pixels must be >= 0, got {pixels}")
    if pixels == 0:
        return mask.copy()
    out = np.zeros_like(mask)
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size:  # outside the mask's bounding box every pixel is background, as the border is: eroding the
        # box alone (its border taken as background) is the whole image's erosion, for a fraction of the work
        box = slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)
        out[box] = ndimage.binary_erosion(mask[box], structure=np.ones((3, 3), bool), iterations=pixels,
                                          border_value=0)
    return out


def comparison_mask(gl_part, ref_part, feather_part_ids, erode_px: int = 1) -> np.ndarray:
    """(H, W) bool: feather pixels away from silhouette edges that both renders agree on (module docstring);
    ``gl_part``, ``ref_part``: (H, W) part ids (-1 background); ``erode_px``: erosion of each coverage."""
    gl_part, ref_part = _same_shape("gl_part", gl_part, "ref_part", ref_part, None)
    ids = np.asarray(list(feather_part_ids), dtype=np.int64)
    return erode(np.isin(gl_part, ids), erode_px) & erode(np.isin(ref_part, ids), erode_px) & (gl_part == ref_part)


def rgb_to_lab(rgb_linear: np.ndarray) -> np.ndarray:
    """Linear lin_rec709 colour (unclipped) to CIELAB (D65 white at Y = 1), shape (..., 3)."""
    return np.asarray(spectral.RGB_to_Lab(np.asarray(rgb_linear, np.float64)), np.float64)


def pixel_de(a_px: np.ndarray, b_px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CIEDE2000 of (N, 3) pairs of linear colours, and the first's CIELAB: every comparison's colour difference."""
    lab = rgb_to_lab(a_px)
    de = np.asarray(spectral.delta_E_2000(lab, rgb_to_lab(b_px)), np.float64) if len(a_px) else np.zeros(0)
    return de, lab


def _in_band(h_deg: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    lo, hi = band
    return (h_deg >= lo) & (h_deg < hi) if lo <= hi else (h_deg >= lo) | (h_deg < hi)


def hue_classes(rgb_linear: np.ndarray, sides: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(h_ab in degrees [0, 360), C*ab, class)`` of (..., 3) linear colours; class (int8) 0 grey, else the strict
    bands (1 green, 2 purple, 3 other), or with ``sides`` the side of the hue circle (1 green, 2 purple): the
    boundary's classes, since the film passes from green to purple through blue or red-yellow with thickness."""
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


@dataclass(frozen=True)
class HueHistogram:
    """Pixels by CIELAB hue: ``counts`` of the chromatic ones per bin, how many are ``grey``, ``green``, ``purple``
    or ``other``, and the thresholds used. Histograms of several views add up (``+``)."""

    bin_edges_deg: list[float]
    counts: list[int]
    grey: int
    green: int
    purple: int
    other: int
    min_saturation: float
    green_band_deg: list[float]
    purple_band_deg: list[float]

    def __add__(self, more: HueHistogram) -> HueHistogram:
        return dataclasses.replace(self, counts=[a + b for a, b in zip(self.counts, more.counts)], **{
            k: getattr(self, k) + getattr(more, k) for k in ("grey", "green", "purple", "other")})

    @property
    def chromatic(self) -> int:
        return self.green + self.purple + self.other


def hue_histogram(rgb_pixels: np.ndarray | None, lab_pixels: np.ndarray | None = None) -> HueHistogram:
    """:class:`HueHistogram` of (N, 3) linear pixels, or of ``lab_pixels`` already in CIELAB."""
    if lab_pixels is None:
        lab_pixels = rgb_to_lab(np.asarray(rgb_pixels, np.float64).reshape(-1, 3))
    lab_pixels = np.asarray(lab_pixels, np.float64).reshape(-1, 3)
    edges = np.arange(0.0, 360.0 + HUE_BIN_DEG, HUE_BIN_DEG)
    h, _, cls = lab_hue_classes(lab_pixels)  # no pixels: empty classes, zero counts
    counts, _ = np.histogram(h[cls > 0], bins=edges)
    return HueHistogram(edges.tolist(), [int(c) for c in counts], *(int(np.sum(cls == k)) for k in range(4)),
                        HUE_MIN_SATURATION, list(GREEN_BAND_DEG), list(PURPLE_BAND_DEG))


@dataclass
class ViewMetrics(Record):
    """Metrics of one view, the GL render against the reference; dE statistics NaN without pixels. Not in
    :meth:`to_json`: ``de_map`` (NaN where not compared), ``cls`` and ``strict`` (hue sides and strict bands of the
    compared structural pixels, -1 elsewhere: the boundary's input)."""

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
    hue: HueHistogram
    passed: bool
    failures: list = field(default_factory=list)
    de_map: np.ndarray | None = field(default=None, repr=False)
    cls: np.ndarray | None = field(default=None, repr=False)
    strict: np.ndarray | None = field(default=None, repr=False)
    _PRIVATE = ("de_map", "cls", "strict")  # to_json: every metric but the images, copied


def compare_arrays(view: str, gl_rgb, ref_rgb, gl_part, ref_part, feather_part_ids, ref_n_dot_l=None,
                   ref_mask=None, erode_px: int = 1) -> ViewMetrics:
    """:func:`compare` on plain arrays: (H, W, 3) linear renders, (H, W) part ids (-1 background);
    ``ref_n_dot_l``: the reference's max(N.L, 0) (without it no black-hole check); ``ref_mask``: its
    structural-colour mask (the hue statistics take compared pixels with mask >= :data:`STRUCTURAL_MASK`)."""
    # Only the compared pixels (a few per cent of the image) are converted, classified and checked; non-finite values
    # count as 0 in the statistics (``finite`` reports them).
    gl_rgb, ref_rgb = _same_shape("gl_rgb", gl_rgb, "ref_rgb", ref_rgb, 3)
    finite = bool(np.isfinite(gl_rgb).all() and np.isfinite(ref_rgb).all())
    mask = comparison_mask(gl_part, ref_part, feather_part_ids, erode_px)
    gl_px, ref_px = (np.where(np.isfinite(a[mask]), a[mask], 0.0).astype(np.float64) for a in (gl_rgb, ref_rgb))
    n = int(gl_px.shape[0])
    vals, lab_gl = pixel_de(gl_px, ref_px)
    de = np.full(mask.shape, np.nan)
    de[mask] = vals
    stats = (np.median(vals), np.percentile(vals, 95), vals.max(), vals.mean()) if n else (np.nan,) * 4
    lit = np.asarray(ref_n_dot_l)[mask] >= LIT_N_DOT_L if ref_n_dot_l is not None else np.zeros(n, bool)
    n_lit, n_black = int(lit.sum()), int(np.sum(np.abs(gl_px[lit]).max(axis=1) < BLACK_RADIANCE))
    black_fraction = n_black / n_lit if n_lit else 0.0
    structural = np.asarray(ref_mask)[mask] >= STRUCTURAL_MASK if ref_mask is not None else np.ones(n, bool)
    hue_mask = np.zeros(mask.shape, bool)
    hue_mask[mask] = structural
    lab_hue = lab_gl[structural]
    cls_img, strict_img = np.full((2, *mask.shape), -1, np.int8)
    cls_img[hue_mask] = lab_hue_classes(lab_hue, sides=True)[2]
    strict_img[hue_mask] = lab_hue_classes(lab_hue)[2]
    failures = [] if finite else [f"{view}: NaN or Inf in a render"]
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
        hue=hue_histogram(None, lab_hue), passed=not failures, failures=failures, de_map=de, cls=cls_img,
        strict=strict_img,
    )


def feather_ids(scene) -> list:
    """The part ids (1-based, as the renders' ``part_id``) of the scene's feather parts."""
    return [i + 1 for i, p in enumerate(scene.parts) if p.is_feather]


def compare(gl_result, ref_result, scene, erode_px: int = 1) -> ViewMetrics:
    """Compare one view's GL render (:class:`rockdove.render.gl.RenderResult`) with its reference render
    (:class:`rockdove.verify.reference_image.ReferenceResult`); the scene gives the feather part ids."""
    return compare_arrays(ref_result.view, gl_result.radiance_rgb, ref_result.rgb, gl_result.part_id,
                          ref_result.part_id, feather_ids(scene), ref_n_dot_l=ref_result.n_dot_l,
                          ref_mask=ref_result.mask, erode_px=erode_px)


def reference_classes(ref_result, scene) -> np.ndarray:
    """Hue classes of the reference's feather pixels (used when there is no GL render)."""
    feather = np.isin(ref_result.part_id, feather_ids(scene)) & (ref_result.mask >= STRUCTURAL_MASK)
    cls = np.full(feather.shape, -1, np.int8)
    cls[feather] = hue_classes(ref_result.rgb[feather].astype(np.float64), sides=True)[2]
    return cls

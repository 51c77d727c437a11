"""The shape of the green/purple pattern on the neck: coherence of the colour regions, curvature of their boundary.

On a real rock dove the green and purple of the neck form a few large regions whose boundary is a curve that
moves with the light; one fixed film thickness makes it a straight line; an uncorrelated per-feather thickness
makes a salt-and-pepper of both colours. Two measures per view tell the three apart:

Coherence (:func:`class_coherence`): for each strict hue class (green, purple, other; grey left out), the share of
its pixels held by its largest 4-connected region, optionally after bridging gaps of up to ``2 * reach_px`` grey or
non-feather pixels (never another hue class). 4- rather than 8-connectivity, and no bridging through the other
colours: on a mosaic of independently coloured feathers at 50 % each, diagonally connected regions percolate for
*both* colours (site percolation threshold 0.407 with 8 neighbours, 0.593 with 4), so speckle would pass as
coherent. A coherent pattern has shares near 1.

Curvature (:func:`boundary_curvature`): the green/purple contact zone (on the hue *sides*) is reduced to its
centreline (mean point of ``bin_px`` bins along its principal axis), whose perpendicular offset ``o(t)`` is fitted
by least squares with a line and a cubic (t scaled to [-1, 1]). Their RMS ratio ``line / curve`` (the curve's
residual at least :data:`NOISE_FLOOR_PX`, pixel quantisation) is about 1 or less for a straight boundary, >=
:data:`CURVED_RATIO` for a curved one. One robust pass drops centreline points farther than 3x the cubic's median
residual (when half remain), so a stray feather tip of the other colour does not bend the fit."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from .compare import lab_hue_classes, rgb_to_lab
from .records import Record

#: A class is coherent when its largest connected region holds at least this share of its pixels. 0.7 was
#: the first goal; a per-card uniform draw reaches 0.70 / 0.69 (green / purple) on the default bird's 90 degree
#: sweep view at 512 x 512 and the coherent field 0.91 / 1.00, so the line is drawn at 0.8.
COHERENT_SHARE = 0.8
#: Gaps bridged by the coherence measure, pixels: none, since on the bird the feather tips of one colour overlap
#: or touch (with 1-2 px, a speckle's same-coloured tips join across the hairline gaps: 0.81 / 0.79).
COHERENCE_REACH_PX = 0
#: Residuals below this are pixel quantisation (the contact zone is a few pixels wide and its centreline is
#: binned): the curvature ratio divides by max(curve residual, this). Without it the paper preset's straight
#: boundary (line 0.72 px, cubic 0.36 px at 512 x 512) would score a ratio of 2.
NOISE_FLOOR_PX = 1.0
#: A boundary is curved when the straight line's RMS residual is at least this multiple of the cubic's.
CURVED_RATIO = 2.0
#: The closing note calls a boundary that is not curved straight when the line's RMS residual is at most this
#: fraction of the boundary's length (the paper preset: ~0.75 px over ~200 px at 512 x 512), else irregular.
STRAIGHT_FRACTION = 0.02
#: Degree of the smooth curve fitted to the boundary's centreline.
CURVE_DEGREE = 3
#: Reach of the green/purple contact zone, pixels (see :func:`boundary_points`).
BOUNDARY_REACH_PX = 2
CLASSES = {"green": 1, "purple": 2, "other": 3}
_NAN = float("nan")


@dataclass(frozen=True)
class Straightness(Record):
    """:func:`boundary_straightness`; the line's direction and centre (x, y) None, the rest NaN, when not fitted."""

    n_points: int
    n_centreline: int
    rms_px: float = _NAN
    length_px: float = _NAN
    rms_fraction: float = _NAN
    direction: tuple[float, float] | None = None
    centre: tuple[float, float] | None = None


@dataclass(frozen=True)
class Regions:
    """A strict hue class's pixels, the share its largest connected region holds (NaN without pixels), regions."""

    pixels: int
    largest_share: float
    regions: int


@dataclass(frozen=True)
class Coherence:
    """:func:`class_coherence`."""

    reach_px: int
    green: Regions
    purple: Regions
    other: Regions


@dataclass(frozen=True)
class Curvature:
    """:func:`boundary_curvature`; NaN but the counts when there are too few points."""

    n_points: int
    n_centreline: int
    curve_degree: int
    length_px: float = _NAN
    line_rms_px: float = _NAN
    curve_rms_px: float = _NAN
    ratio: float = _NAN


@dataclass(frozen=True, kw_only=True)
class BoundaryShape(Straightness):
    """A light-sweep view's green/purple pattern (:func:`class_shape`): its boundary's line and curvature, the
    classes' coherence, whether the pattern is coherent and the boundary curved."""

    coherence: Coherence
    curvature: Curvature
    coherent: bool
    curved: bool


@dataclass(frozen=True)
class Boundary(Record):
    """The report's boundary: the light-sweep views' shapes by view, and how they were measured."""

    per_view: dict[str, BoundaryShape]
    method: str = ("TLS line through green/purple boundary points; RMS perpendicular distance (px) and RMS / "
                   "boundary length; coherence and curvature: rockdove.verify.boundary")


def boundary_points(cls: np.ndarray, reach_px: int = BOUNDARY_REACH_PX) -> np.ndarray:
    """(P, 2) float (x = column, y = row) pixels within ``reach_px`` 8-connected steps of a green (1) AND a purple (2)
    pixel of a class image. This bridges the narrow band of low-chroma or blue pixels the film shows between green
    and purple (at 650 nm and cos theta near 0.707 the chroma drops to ~12) and the grey bases between tips."""
    from scipy import ndimage

    near = [ndimage.binary_dilation(np.asarray(cls) == k, structure=np.ones((3, 3), bool), iterations=int(reach_px))
            for k in (1, 2)]
    r, c = np.nonzero(near[0] & near[1])
    return np.stack([c.astype(float), r.astype(float)], axis=1)


def boundary_straightness(cls: np.ndarray, min_points: int = 8, centreline=None) -> Straightness:
    """RMS perpendicular distance of the green/purple boundary's centreline (hue sides) from its total-least-squares
    line, in pixels and as a fraction of its length, with the same robust pass; NaN under ``min_points`` points.
    A straight boundary gives ~0.3 px (pixel quantisation); a bent one its sagitta over ~3 (40 px gives ~12 px).
    ``centreline``: :func:`boundary_centreline` of ``cls``, when the caller has it."""
    n, line = centreline or boundary_centreline(cls)
    if len(line) < min_points:
        return Straightness(n, len(line))
    line = _without_outliers(line, _tls(line)[2], min_points)
    centre, direction, dist = _tls(line)
    along = (line - centre) @ direction
    length = float(along.max() - along.min())
    rms = float(np.sqrt(np.mean(dist**2)))
    return Straightness(n, len(line), rms, length, rms / length if length > 0 else _NAN,
                        (float(direction[0]), float(direction[1])), (float(centre[0]), float(centre[1])))


def boundary_centreline(cls: np.ndarray, bin_px: float = 2.0) -> tuple[int, np.ndarray]:
    """``(the number of boundary points of ``cls``, their (K, 2) centreline)``, K = 0 under two points."""
    pts = boundary_points(cls)
    return len(pts), _centreline(pts, bin_px) if len(pts) >= 2 else np.zeros((0, 2))


def _without_outliers(line: np.ndarray, residual: np.ndarray, need: int) -> np.ndarray:
    """``line`` without the points farther than 3x the median ``residual`` (>= 0.5 px), if ``need`` and half remain."""
    keep = np.abs(residual) <= 3.0 * max(np.median(np.abs(residual)), 0.5)
    return line[keep] if keep.sum() >= max(need, len(line) // 2) else line


def _tls(p: np.ndarray):
    """The total-least-squares line through (K, 2) points: centre, unit direction, signed distances (K,)."""
    centre = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - centre, full_matrices=False)
    return centre, vt[0], (p - centre) @ vt[1]


def class_coherence(cls: np.ndarray, reach_px: int = COHERENCE_REACH_PX) -> Coherence:
    """Per strict hue class (1 green, 2 purple, 3 other), the share of its pixels held by its largest connected
    region (module docstring)."""
    from scipy import ndimage

    cls = np.asarray(cls)
    st = ndimage.generate_binary_structure(2, 1)  # 4-connected

    def regions(label: int) -> Regions:
        own = cls == label
        n = int(own.sum())
        if n == 0:
            return Regions(0, _NAN, 0)
        passable = own | (cls <= 0)  # the class itself, grey (0) and non-feather (-1) pixels
        grown = (ndimage.binary_dilation(own, structure=st, iterations=int(reach_px), mask=passable)
                 if reach_px else own)
        labels, count = ndimage.label(grown, structure=st)
        sizes = np.bincount(labels[own], minlength=count + 1)[1:]  # the class's own pixels per region
        return Regions(n, float(sizes.max() / n), int(np.sum(sizes > 0)))
    return Coherence(int(reach_px), *(regions(label) for label in CLASSES.values()))


def _centreline(pts: np.ndarray, bin_px: float) -> np.ndarray:
    """(K, 2) mean points of ``bin_px`` bins of (P, 2) points along their principal axis."""
    centre, axis, _ = _tls(pts)
    along = (pts - centre) @ axis
    bins = np.floor((along - along.min()) / bin_px).astype(np.int64)
    counts = np.bincount(bins)
    used = counts > 0
    return np.stack([np.bincount(bins, weights=pts[:, k])[used] / counts[used] for k in (0, 1)], axis=1)


def _fits(line: np.ndarray, degree: int):
    """Residuals (K,) of a degree-1 and a degree-``degree`` polynomial offset(t) in the centreline's frame."""
    centre, axis, o = _tls(line)
    t = (line - centre) @ axis
    half = max(float(np.abs(t).max()), 1e-9)
    x = t / half
    fitted = (o - a @ np.linalg.lstsq(a, o, rcond=None)[0] for a in (np.vander(x, 2), np.vander(x, degree + 1)))
    return *fitted, float(t.max() - t.min())


def boundary_curvature(cls: np.ndarray, min_points: int = 8, degree: int = CURVE_DEGREE,
                       centreline=None) -> Curvature:
    """RMS residuals of a line and a degree-``degree`` fit of the green/purple boundary of a hue-side image and
    their ``ratio`` (module docstring); NaN under ``min_points`` or ``degree + 3`` centreline points.
    ``centreline``: :func:`boundary_centreline` of ``cls``, when the caller has it."""
    n, line = centreline or boundary_centreline(cls)
    need = max(int(min_points), int(degree) + 3)
    if len(line) < need:
        return Curvature(n, len(line), int(degree))
    line = _without_outliers(line, _fits(line, degree)[1], need)
    r_line, r_curve, length = _fits(line, degree)
    rms_line, rms_curve = (float(np.sqrt(np.mean(r**2))) for r in (r_line, r_curve))
    return Curvature(n, len(line), int(degree), length, rms_line, rms_curve, rms_line / max(rms_curve, NOISE_FLOOR_PX))


def boundary_shape(rgb_linear: np.ndarray, region: np.ndarray, reach_px: int = COHERENCE_REACH_PX) -> BoundaryShape:
    """:func:`class_shape` of the pixels of ``region`` of an (H, W, 3) linear render, classified here."""
    rgb = np.asarray(rgb_linear, np.float64)
    region = np.asarray(region, bool)
    if rgb.shape[:2] != region.shape or rgb.ndim != 3 or rgb.shape[2] != 3:
        raise UsageError(f"rgb_linear (H, W, 3) and region (H, W) must match, got {rgb.shape} and {region.shape}")
    strict, sides = np.full((2, *region.shape), -1, np.int8)
    lab = rgb_to_lab(np.where(np.isfinite(rgb[region]), rgb[region], 0.0))  # no pixels: none classified
    strict[region] = lab_hue_classes(lab)[2]
    sides[region] = lab_hue_classes(lab, sides=True)[2]
    return class_shape(strict, sides, reach_px)


def class_shape(strict: np.ndarray, sides: np.ndarray, reach_px: int = COHERENCE_REACH_PX) -> BoundaryShape:
    """The ``line`` (:func:`boundary_straightness`) and ``curvature`` (:func:`boundary_curvature`) of the hue
    ``sides``, the ``coherence`` (:func:`class_coherence`) of the ``strict`` classes, ``coherent`` (green and purple
    largest regions >= :data:`COHERENT_SHARE`) and ``curved`` (ratio >= :data:`CURVED_RATIO`) of classified pixels
    (-1 elsewhere: ViewMetrics' ``strict`` and ``cls``)."""
    centreline = boundary_centreline(sides)  # the line and the curve are fitted to the one centreline
    coherence, curvature = class_coherence(strict, reach_px), boundary_curvature(sides, centreline=centreline)
    shares = [coherence.green.largest_share, coherence.purple.largest_share]
    return BoundaryShape(**vars(boundary_straightness(sides, centreline=centreline)), coherence=coherence,
                         curvature=curvature,
                         coherent=bool(all(np.isfinite(s) and s >= COHERENT_SHARE for s in shares)),
                         curved=bool(np.isfinite(curvature.ratio) and curvature.ratio >= CURVED_RATIO))


def boundary_note(view: str, boundary: BoundaryShape) -> str:
    """One line for the report's notes: the coherence and curvature of ``view`` and what they mean."""
    coh, cur = boundary.coherence, boundary.curvature
    shares = ", ".join(f"{k} {c.largest_share:.2f} of {c.pixels} px"
                       for k, c in zip(CLASSES, (coh.green, coh.purple, coh.other)) if c.pixels)
    if boundary.curved:
        kind = "curved"
    elif cur.line_rms_px <= STRAIGHT_FRACTION * cur.length_px:
        kind = "straight (the line fits about as well as the curve)"
    else:
        kind = "irregular (neither the line nor the curve fits)"
    return (f"boundary at {view}: largest connected region holds {shares or 'no chromatic pixels'} "
            f"({'coherent' if boundary.coherent else 'not coherent'}: green and purple each need >= "
            f"{COHERENT_SHARE:.0%}); green/purple boundary line residual {cur.line_rms_px:.2f} px, "
            f"cubic {cur.curve_rms_px:.2f} px, ratio {cur.ratio:.2f}: {kind} (curved at >= {CURVED_RATIO:g})")

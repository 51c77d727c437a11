"""The neck band and blue-noise sampling of it.

The band is the body surface within ``sdf.NECK_BAND_RADIUS_M`` of the neck axis (``sdf.NECK_BASE_M`` ->
``sdf.NECK_TOP_M``) between its ends; s is the projection on the axis (:func:`neck_s`), 0 at the base, 1 at the top.

Blue noise: uniform candidates by triangle area (Turk, "Generating random points in triangles", Graphics
Gems, 1990: ``p = (1 - sqrt(r1)) a + sqrt(r1) (1 - r2) b + sqrt(r1) r2 c``), then weighted sample
elimination down to exactly N (Yuksel, "Sample Elimination for Generating Poisson Disk Sample Sets",
Computer Graphics Forum 34(2), 2015): r_max = sqrt(A / (2 sqrt(3) N)) (eq. 5, 2-D), weight of a pair
w_ij = (1 - d_ij / (2 r_max))^8 for d_ij < 2 r_max (eq. 1, alpha = 8). Weight limiting is not used: as
implemented here (d_ij -> max(d_ij, 2 r_min)) it dropped the smallest spacing of 1,000 samples on the band from
0.38 to 0.04 of 2 r_max, because it makes all close pairs weigh the same. Yuksel removes the heaviest sample one
at a time with a heap; here the elimination is done in parallel rounds: every live sample whose weight is the
strict maximum among its live neighbours is removed at once (the heaviest first when fewer are needed). Those
samples are never neighbours of one another, so removing them together changes none of their weights: the
result is the heap algorithm's, up to the order of removals between distant samples."""

from __future__ import annotations

import numpy as np

from rockdove.geometry import sdf as _sdf
from rockdove.geometry.sdf import neck_s

from ..errors import UsageError

#: Candidates per output sample (Yuksel 2015 uses 5; 3 is enough on a smooth surface and faster).
CANDIDATES_PER_SAMPLE = 3.0
#: Weight exponent alpha of Yuksel 2015, eq. 1.
WEIGHT_EXPONENT = 8.0


def in_band(points_m: np.ndarray, s_max: float = 1.0) -> np.ndarray:
    """(N,) bool: points (on the body surface) that lie in the neck band (up to ``s_max``, 1 by default)."""
    s, r = neck_s(points_m)
    return (s >= 0.0) & (s <= s_max) & (r <= _sdf.NECK_BAND_RADIUS_M)


def band_faces(vertices_m: np.ndarray, faces: np.ndarray, s_max: float = 1.0) -> np.ndarray:
    """(F,) bool: triangles with at least one corner in the band (a superset used to draw candidates)."""
    return in_band(vertices_m, s_max)[faces].any(axis=1)


def triangle_areas(vertices_m, faces) -> np.ndarray:
    """(F,) areas of the triangles ``faces`` (F, 3), m^2."""
    tri = vertices_m[faces]
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def sample_triangles(vertices_m, faces, count: int, rng: np.random.Generator) -> np.ndarray:
    """(count, 3) uniform random points on a triangle set, by area (Turk 1990)."""
    tri = vertices_m[faces]
    cdf = np.cumsum(triangle_areas(vertices_m, faces))
    face_index = np.minimum(np.searchsorted(cdf, rng.random(count) * cdf[-1], side="right"), len(faces) - 1)
    r1 = np.sqrt(rng.random(count))
    r2 = rng.random(count)
    bary = np.stack([1.0 - r1, r1 * (1.0 - r2), r1 * r2], axis=1)
    return np.einsum("nk,nkd->nd", bary, tri[face_index])


def band_area_m2(vertices_m, faces, s_max: float = 1.0) -> float:
    """Area of the neck band up to ``s_max``, m^2 (Monte Carlo: 200k samples, fixed seed, on the candidates)."""
    sel = faces[band_faces(vertices_m, faces, s_max)]
    pts = sample_triangles(vertices_m, sel, 200_000, np.random.default_rng(12345))
    return float(triangle_areas(vertices_m, sel).sum() * in_band(pts, s_max).mean())


def sample_band_uniform(vertices_m, faces, count: int, rng: np.random.Generator, s_max: float = 1.0) -> np.ndarray:
    """(count, 3) independent uniform points in the band (rejection from the candidate triangles)."""
    sub = faces[band_faces(vertices_m, faces, s_max)]
    out, have = [], 0
    batch = int(count * 1.5) + 64
    while have < count:  # a few rounds of rejection, never a loop over points
        pts = sample_triangles(vertices_m, sub, batch, rng)
        out.append(pts[in_band(pts, s_max)])
        have += len(out[-1])
    return np.concatenate(out)[:count]


def eliminate(points_m: np.ndarray, count: int, area_m2: float, rng: np.random.Generator) -> np.ndarray:
    """Sorted int64 indices of the ``count`` samples of the (M, 3) candidates ``points_m`` on a surface of
    ``area_m2`` (which sets r_max) that weighted sample elimination (Yuksel 2015, in parallel rounds: module
    docstring) keeps; ``rng`` breaks ties between equal weights."""
    m = len(points_m)
    if count > m:
        raise UsageError(f"count={count} must not exceed the number of candidates ({m})")
    if count == m:
        return np.arange(m)
    from scipy.spatial import cKDTree

    r_max = np.sqrt(area_m2 / (2.0 * np.sqrt(3.0) * count))
    pairs = cKDTree(points_m).query_pairs(2.0 * r_max, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    diff = points_m[i] - points_m[j]
    d = np.sqrt(np.einsum("ij,ij->i", diff, diff))
    x = 1.0 - d / (2.0 * r_max)
    x *= x
    x *= x
    w = x * x  # (1 - d / 2 r_max)^8 by squaring: WEIGHT_EXPONENT = 8
    tiebreak = rng.permutation(m).astype(np.float64) / m  # distinct priorities in [0, 1) for equal weights
    alive = np.ones(m, dtype=bool)
    n_alive = m
    while n_alive > count:  # rounds (tens), each vectorised over all live pairs
        live_pair = alive[i] & alive[j]
        i, j, w = i[live_pair], j[live_pair], w[live_pair]  # pairs with a dead end never matter again
        weight = np.bincount(i, w, minlength=m) + np.bincount(j, w, minlength=m)
        # strict total order by (weight, tiebreak): the lighter end of every live pair is not a local maximum
        wi, wj = weight[i], weight[j]
        i_lighter = (wi < wj) | ((wi == wj) & (tiebreak[i] < tiebreak[j]))
        is_max = alive & (weight > 0)
        is_max[i[i_lighter]] = False
        is_max[j[~i_lighter]] = False
        cand = np.flatnonzero(is_max)
        need = n_alive - count
        if len(cand) == 0:  # no live sample has a live neighbour: drop the lowest-priority ones
            cand = np.flatnonzero(alive)
            cand = cand[np.argsort(tiebreak[cand], kind="stable")][:need]
        elif len(cand) > need:  # the heaviest first
            order = np.lexsort((tiebreak[cand], weight[cand]))[::-1]
            cand = cand[order[:need]]
        alive[cand] = False
        n_alive -= len(cand)
    return np.flatnonzero(alive)


def blue_noise_band(vertices_m, faces, count: int, rng: np.random.Generator, s_max: float = 1.0,
                    area_m2: float | None = None) -> np.ndarray:
    """(count, 3) blue-noise points in the neck band up to ``s_max``, uniform in area. ``area_m2``: the band's
    area (:func:`band_area_m2`), worth passing when sampling one body many times (estimating it costs more than
    sampling a thousand points), else estimated."""
    pts = sample_band_uniform(vertices_m, faces, int(np.ceil(CANDIDATES_PER_SAMPLE * count)) + 8, rng, s_max)
    area = band_area_m2(vertices_m, faces, s_max) if area_m2 is None else area_m2
    return pts[eliminate(pts, int(count), area, rng)]

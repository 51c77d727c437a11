"""The neck band and blue-noise sampling of it.

The band is the part of the body surface around the neck axis (``sdf.NECK_BASE_M`` -> ``sdf.NECK_TOP_M``):
points whose projection on the axis lies between its ends and that are within ``sdf.NECK_BAND_RADIUS_M`` of
it. The coordinate s is that projection, 0 at the base of the neck, 1 at the top below the head; on the
rest of the body it is clipped to [0, 1].

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
result is the heap algorithm's, up to the order of removals between distant samples.
"""

from __future__ import annotations

import numpy as np

from rockdove.geometry import sdf as _sdf

#: Candidates per output sample (Yuksel 2015 uses 5; 3 is enough on a smooth surface and faster).
CANDIDATES_PER_SAMPLE = 3.0
#: Weight exponent alpha of Yuksel 2015, eq. 1.
WEIGHT_EXPONENT = 8.0


def neck_s(points_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Neck coordinate of points.

    Parameters
    ----------
    points_m : np.ndarray
        (N, 3) points, metres.

    Returns
    -------
    s : np.ndarray
        (N,) float64 projection on the neck axis, 0 at its base, 1 at its top (not clipped).
    radius_m : np.ndarray
        (N,) float64 distance from the neck axis line, metres.
    """
    p = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)
    axis = _sdf.NECK_TOP_M - _sdf.NECK_BASE_M
    length = np.linalg.norm(axis)
    q = p - _sdf.NECK_BASE_M
    s = (q @ axis) / (length * length)
    radial = q - s[:, None] * axis
    return s, np.linalg.norm(radial, axis=1)


def in_band(points_m: np.ndarray, s_max: float = 1.0) -> np.ndarray:
    """(N,) bool: points (on the body surface) that lie in the neck band (up to ``s_max``, 1 by default)."""
    s, r = neck_s(points_m)
    return (s >= 0.0) & (s <= s_max) & (r <= _sdf.NECK_BAND_RADIUS_M)


def neck_axis_direction() -> np.ndarray:
    """(3,) unit vector up the neck, from its base to its top."""
    axis = _sdf.NECK_TOP_M - _sdf.NECK_BASE_M
    return axis / np.linalg.norm(axis)


def band_faces(vertices_m: np.ndarray, faces: np.ndarray, s_max: float = 1.0) -> np.ndarray:
    """(F,) bool: triangles with at least one corner in the band (a superset used to draw candidates)."""
    vin = in_band(vertices_m, s_max)
    return vin[faces].any(axis=1)


def sample_triangles(vertices_m, faces, count: int, rng: np.random.Generator):
    """Uniform random points on a triangle set, by area (Turk 1990).

    Returns
    -------
    points_m : np.ndarray
        (count, 3).
    face_index : np.ndarray
        (count,) int64 triangle of each point.
    barycentric : np.ndarray
        (count, 3) weights of the triangle's corners.
    """
    tri = vertices_m[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    cdf = np.cumsum(area)
    face_index = np.searchsorted(cdf, rng.random(count) * cdf[-1], side="right")
    face_index = np.minimum(face_index, len(faces) - 1)
    r1 = np.sqrt(rng.random(count))
    r2 = rng.random(count)
    bary = np.stack([1.0 - r1, r1 * (1.0 - r2), r1 * r2], axis=1)
    points = np.einsum("nk,nkd->nd", bary, tri[face_index])
    return points, face_index, bary


def band_area_m2(vertices_m, faces, s_max: float = 1.0, rng=None, samples: int = 200_000) -> float:
    """Area of the neck band, m^2 (Monte Carlo over the candidate triangles, deterministic by default)."""
    rng = np.random.default_rng(12345) if rng is None else rng
    sel = faces[band_faces(vertices_m, faces, s_max)]
    tri = vertices_m[sel]
    total = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    pts, _, _ = sample_triangles(vertices_m, sel, samples, rng)
    return float(total * in_band(pts, s_max).mean())


def sample_band_uniform(vertices_m, faces, count: int, rng: np.random.Generator, s_max: float = 1.0):
    """Exactly ``count`` independent uniform points in the band (rejection from the candidate triangles).

    Returns ``(points_m (count, 3), face_index (count,) into faces, barycentric (count, 3))``.
    """
    face_ids = np.flatnonzero(band_faces(vertices_m, faces, s_max))
    sub = faces[face_ids]
    pts_out, fid_out, bary_out = [], [], []
    have = 0
    batch = int(count * 1.5) + 64
    while have < count:  # a few rounds of rejection, never a loop over points
        pts, fid, bary = sample_triangles(vertices_m, sub, batch, rng)
        keep = in_band(pts, s_max)
        pts_out.append(pts[keep])
        fid_out.append(face_ids[fid[keep]])
        bary_out.append(bary[keep])
        have += int(keep.sum())
    return (np.concatenate(pts_out)[:count], np.concatenate(fid_out)[:count], np.concatenate(bary_out)[:count])


def eliminate(points_m: np.ndarray, count: int, area_m2: float, rng: np.random.Generator) -> np.ndarray:
    """Weighted sample elimination (Yuksel 2015) in parallel rounds, down to exactly ``count`` samples.

    Parameters
    ----------
    points_m : np.ndarray
        (M, 3) candidate points on a surface, M >= count.
    count : int
        Samples to keep, N.
    area_m2 : float
        Area of the sampled surface (sets r_max).
    rng : np.random.Generator
        Breaks ties between equal weights.

    Returns
    -------
    np.ndarray
        (N,) sorted int64 indices into ``points_m`` of the kept samples.
    """
    m = len(points_m)
    if count > m:
        raise ValueError(f"count={count} must not exceed the number of candidates ({m})")
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
                    area_m2: float | None = None):
    """Exactly ``count`` blue-noise points in the neck band (up to ``s_max``), uniform in area.

    ``area_m2`` is the band's area, :func:`band_area_m2` of the same mesh and ``s_max``; pass it when sampling
    one body many times (estimating it costs more than the sampling at a thousand points), else it is estimated.

    Returns
    -------
    points_m : np.ndarray
        (count, 3) on the triangle mesh.
    face_index : np.ndarray
        (count,) triangle of each point.
    barycentric : np.ndarray
        (count, 3).
    """
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ValueError(f"count={count!r} must be an integer >= 1")
    m = int(np.ceil(CANDIDATES_PER_SAMPLE * count)) + 8
    pts, fid, bary = sample_band_uniform(vertices_m, faces, m, rng, s_max)
    area = band_area_m2(vertices_m, faces, s_max) if area_m2 is None else area_m2
    keep = eliminate(pts, int(count), area, rng)
    return pts[keep], fid[keep], bary[keep]

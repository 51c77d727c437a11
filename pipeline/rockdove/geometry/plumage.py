"""The rock dove's plumage in real-time terms: feather-shaped cards over the body, the folded wings, the tail.

Each feather is a card of feather-shaped geometry (the groom-card technique of Unreal Engine and Weta without the
alpha: the outline is in the mesh, so every host draws it opaque, without alpha sorting or test): :data:`SHAPE_V`
rows from the quill (v = 0) to a pointed, rounded tip (v = 1) of half-widths :data:`SHAPE_W`, 9 vertices and 7
triangles. Its st lies in one tile of the palette strip along the bottom of ``body_base.png``
(:data:`PALETTE_STRIP`, painted by :func:`rockdove.textures.palette_strip`): a feather image in one colour of the
coat, so the cards need no material of their own.

- ``CoatFeathers``: contour feathers (about 2 cm, chosen by eye against photographs) on blue-noise roots over the
  body outside the neck band and the head (:func:`rockdove.geometry.neck.eliminate`), lying tailward and down
  like shingles; normals are the body field's gradient, so the coat shades as one smooth surface; tiles from
  :func:`rockdove.geometry.colours.coat_tiles` (grey, the dark neck, the white rump).
- ``Wings``: each folded wing as layered rows (primaries under secondaries and tertials, greater coverts over
  them, median coverts on top) laid out in the side view and draped over the body at the row's layer offset
  (:func:`drape_x`); the primaries run on past the rump, tips meeting over the tail. The greater coverts and the
  secondaries/tertials carry the black subterminal band: the rock dove's two wing bars.
- ``Tail``: twelve rectrices (Columba livia has 12) in a shallow fan from the rump, with the dark terminal band.
"""

from __future__ import annotations

import numpy as np

from rockdove.geometry import cards as _cards
from rockdove.geometry import neck as _neck
from rockdove.geometry import sdf as _sdf
from rockdove.geometry.colours import (  # noqa: F401
    BODY_DISPLAY_COLOR,
    RAMP,
    T_BAR,
    T_BAR2,
    T_PRIMARY,
    T_RECTRIX,
    T_WHITE,
    TILES,
    coat_tiles,
)
from rockdove.geometry.types import MeshPart, triangle_part, unit

#: The parts made of feather cards (two-sided, bound to the body's material).
CARD_PARTS = ("CoatFeathers", "Wings", "Tail")
#: Fraction of the body texture's height (at its bottom, t in [0, PALETTE_STRIP]) holding the feather tiles.
PALETTE_STRIP = 0.125
#: Where the body's charts begin (t): a guard band above the strip, so that filtering and mipmaps at a card's tip
#: take the strip's own colours, not a neighbouring chart's.
ATLAS_START = 0.145
#: The card outline: rows at v (quill 0 .. tip 1) and their widths as fractions of the card width (tip: 0).
SHAPE_V = np.array([0.0, 0.3, 0.62, 0.86, 1.0])
SHAPE_W = np.array([0.45, 0.92, 1.0, 0.72, 0.0])
VERTICES_PER_CARD = 2 * (len(SHAPE_V) - 1) + 1
#: Coat cards: count, length and width ranges (m), lift and bend (as in cards.py: low, so the shingles stack
#: ~1 mm deep and shadow maps see one smooth coat), root depth (m), clearance (m).
COAT_COUNT = 1400
COAT_LENGTH_M = (0.018, 0.026)
COAT_WIDTH_M = (0.013, 0.018)
COAT_LIFT, COAT_BEND, COAT_DEPTH_M, COAT_CLEARANCE_M = 0.015, 0.01, 0.0008, 0.0005
#: Direction the coat lies in before projection onto the skin: tailward and down.
COAT_FLOW = np.array([0.0, -0.55, -0.83])
#: Coat roots are kept off the neck band (by this margin in the neck's radius, m: the neck cards lying down from
#: the band cover it) and off the head, so no coat card stands in front of the iridescent cards.
COAT_NECK_MARGIN_M, COAT_HEAD_MARGIN_M = 0.010, 0.004
STREAM_COAT = 4


def strips(centre, across, width, tile):
    """Feather cards from their centre lines: (N, R, 3) rows (the last the tip), (N, R, 3) unit across
    directions (t x n: counter-clockwise seen from the outside n), (N,) widths (m), (N,) tile indices.

    Returns ``(points (N*9, 3), normals (N*9, 3) geometric, st (N*9, 2), faces (N*7, 3))``.
    """
    n, rows = centre.shape[:2]
    half = (0.5 * width[:, None] * SHAPE_W[None, :-1])[..., None] * across[:, :-1]
    pts = np.concatenate([np.stack([centre[:, :-1] - half, centre[:, :-1] + half], axis=2).reshape(n, -1, 3),
                          centre[:, -1:]], axis=1)
    along = np.gradient(centre, axis=1)
    nrm = unit(np.cross(across, along))
    normals = np.concatenate([np.repeat(nrm[:, :-1], 2, axis=1), nrm[:, -1:]], axis=1)
    su = np.concatenate([np.tile([0.1, 0.9], rows - 1), [0.5]])
    sv = np.concatenate([np.repeat(SHAPE_V[:-1], 2), [1.0]])
    st = np.empty((n, len(su), 2))
    st[..., 0] = (tile[:, None] + su[None, :]) / TILES
    st[..., 1] = PALETTE_STRIP * (0.04 + 0.92 * sv)[None, :]
    j = np.arange(rows - 2)
    tri = np.concatenate([np.stack([2 * j, 2 * j + 1, 2 * j + 3], 1), np.stack([2 * j, 2 * j + 3, 2 * j + 2], 1),
                          [[2 * rows - 4, 2 * rows - 3, 2 * rows - 2]]])
    faces = (tri[None] + VERTICES_PER_CARD * np.arange(n)[:, None, None]).reshape(-1, 3)
    return pts.reshape(-1, 3), normals.reshape(-1, 3), st.reshape(-1, 2), faces


def _part(name, pieces) -> MeshPart:
    return triangle_part(name, [(p, unit(n), st, f) for p, n, st, f in pieces], "body", BODY_DISPLAY_COLOR)


def _shingles(roots, n, t, length, lift, bend, depth, clearance):
    """Centre rows and across directions of cards rooted at ``roots`` lying along ``t`` over skin normals ``n``."""
    v = SHAPE_V[None, :]  # the neck cards' centre line (cards.py), at the rows of the feather outline
    h = -depth * (1.0 - v) ** 4 + length[:, None] * (lift * v + bend * v * v)
    centre = roots[:, None] + (length[:, None] * v)[..., None] * t[:, None] + h[..., None] * n[:, None]
    rest = centre[:, 1:].reshape(-1, 3)
    centre[:, 1:] = _cards._push_out(rest, np.repeat(n, len(SHAPE_V) - 1, axis=0), clearance).reshape(
        centre[:, 1:].shape)
    return centre, np.repeat(unit(np.cross(t, n))[:, None], len(SHAPE_V), axis=1)


def wing_outline_yz() -> np.ndarray:
    """(K, 2) the folded wing's outline in the side view, (y, z) metres, counter-clockwise: roots of the median
    coverts, the tertials, the tips of secondaries and primaries, the roots of the primaries."""
    rows = {r[0]: r for r in WING_ROWS}
    med, sec, pri = rows["median coverts"], rows["secondaries"], rows["primaries"]
    return np.array([med[1][0], med[1][1], sec[1][1], sec[2][1], pri[2][0], pri[1][1], pri[1][0]])


def inside_polygon(yz, poly) -> np.ndarray:
    """(N,) bool: points (N, 2) inside the polygon (K, 2), by the crossing rule."""
    y, z = yz[:, 0:1], yz[:, 1:2]
    a, b = poly[None, :, :], np.roll(poly, -1, 0)[None, :, :]
    crosses = (a[..., 0] > y) != (b[..., 0] > y)
    dy = np.where(b[..., 0] == a[..., 0], 1e-12, b[..., 0] - a[..., 0])
    zc = a[..., 1] + (y - a[..., 0]) * (b[..., 1] - a[..., 1]) / dy
    return (crosses & (z < zc)).sum(1) % 2 == 1


def coat_region(points_m) -> np.ndarray:
    """(N,) bool: body points that carry contour-feather cards: not the neck band, the head, or the flank under
    the folded wing (a wing-width margin inside its outline, so the coat meets the wing's edge)."""
    s, r = _neck.neck_s(points_m)
    neck = ((s >= -0.1) & (r <= _sdf.NECK_BAND_RADIUS_M + COAT_NECK_MARGIN_M)) | (s > 0.9)
    poly = wing_outline_yz()
    inner = poly + 0.25 * (poly.mean(0) - poly)  # the outline shrunk by a quarter toward its centre
    under_wing = (np.abs(points_m[:, 0]) > 0.012) & inside_polygon(points_m[:, 1:3], inner)
    return ~neck & ~under_wing & (_sdf.HEAD.sdf(points_m) > COAT_HEAD_MARGIN_M) & ~((s > 1.0) & (r < 0.045))


def build_coat(vertices_m, faces, seed: int, count: int = COAT_COUNT) -> MeshPart:
    """``CoatFeathers``: ``count`` contour-feather cards on blue-noise roots over :func:`coat_region`."""
    rng = _cards.stream(seed, STREAM_COAT)
    cand = _neck.sample_triangles(vertices_m, faces, int(4 * count), rng)
    keep = coat_region(cand)
    cand = cand[keep]
    area = _neck.triangle_areas(vertices_m, faces).sum() * keep.mean()
    n, roots = _cards.snap_to_skin(cand[_neck.eliminate(cand, min(count, len(cand)), area, rng)])
    t = COAT_FLOW[None] - (n @ COAT_FLOW)[:, None] * n
    yaw = np.deg2rad(12.0) * rng.uniform(-1, 1, len(roots))
    t = unit(unit(t) * np.cos(yaw)[:, None] + np.cross(n, unit(t)) * np.sin(yaw)[:, None])
    length, width = rng.uniform(*COAT_LENGTH_M, len(roots)), rng.uniform(*COAT_WIDTH_M, len(roots))
    centre, across = _shingles(roots, n, t, length, COAT_LIFT, COAT_BEND, COAT_DEPTH_M, COAT_CLEARANCE_M)
    pts, _, st, tris = strips(centre, across, width, coat_tiles(roots))
    pts = pts.reshape(len(roots), VERTICES_PER_CARD, 3)
    rest = pts[:, 2:].reshape(-1, 3)  # beyond the quill the card's edges clear the skin too (concave places)
    pts[:, 2:] = _cards._push_out(rest, np.repeat(n, VERTICES_PER_CARD - 2, axis=0), COAT_CLEARANCE_M).reshape(
        pts[:, 2:].shape)
    pts = pts.reshape(-1, 3)
    return _part("CoatFeathers", [(pts, _sdf.sdf_gradient(_sdf.body_sdf, pts), st, tris)])


def drape_x(y, z, offset_m, x_max: float = 0.07, steps: int = 22):
    """(N,) |x| where the surface ``offset_m`` outside the body crosses the line (y, z) seen from the side
    (bisection on body_sdf - offset; 0 where the line misses it)."""
    y, z = np.asarray(y, float).ravel(), np.asarray(z, float).ravel()
    off = np.broadcast_to(np.asarray(offset_m, float), y.shape)
    def f(x):
        return _sdf.body_sdf(np.stack([x, y, z], 1)) - off

    lo, hi = np.zeros_like(y), np.full_like(y, x_max)
    hit = f(lo) < 0
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        inside = f(mid) < 0
        lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
    return np.where(hit, 0.5 * (lo + hi), 0.0)


#: The folded wing in the side view, (y, z) metres: per row (first feather, last feather) of roots and tips,
#: count, width (m), layer offset over the body (m), x of the tips where they leave the body (m), tile.
#: Primaries under secondaries and tertials, greater coverts over them, median coverts on top; the tips of
#: the outer primaries meet over the tail (tip gap of 2 x 4 mm).
WING_ROWS = (
    ("primaries", ((0.108, 0.024), (0.099, -0.012)), ((0.037, -0.140), (0.058, -0.098)), 10, 0.020, 0.0016,
     (0.004, 0.016), T_PRIMARY),
    ("secondaries", ((0.113, 0.032), (0.138, -0.016)), ((0.070, -0.080), (0.104, -0.066)), 13, 0.022, 0.0027,
     (0.016, 0.012), T_BAR2),
    ("greater coverts", ((0.114, 0.040), (0.140, -0.002)), ((0.090, -0.012), (0.118, -0.032)), 12, 0.016, 0.0038,
     (0.03, 0.02), T_BAR),
    ("median coverts", ((0.108, 0.046), (0.142, 0.012)), ((0.096, 0.022), (0.126, -0.006)), 14, 0.014, 0.0046,
     (0.03, 0.02), None),
)
#: Ramp tile of the coverts' pale grey.
COVERT_TILE = RAMP - 1


def build_wings() -> MeshPart:
    """``Wings``: both folded wings (:data:`WING_ROWS`), draped over the body."""
    pieces = []
    v = SHAPE_V[None, :]
    for side in (1.0, -1.0):
        for _, roots, tips, count, width, offset, tip_x, tile in WING_ROWS:
            a = np.linspace(0.0, 1.0, count)[:, None]
            r0 = (1 - a) * np.array(roots[0]) + a * np.array(roots[1])
            r1 = (1 - a) * np.array(tips[0]) + a * np.array(tips[1])
            yz = r0[:, None] + (r1 - r0)[:, None] * v[..., None]  # (count, rows, 2)
            off = offset + 0.00012 * np.arange(count)[:, None] * np.ones_like(v)  # each feather over the last
            xs = drape_x(yz[..., 0], yz[..., 1], off.ravel()).reshape(off.shape)
            xt = (1 - a) * tip_x[0] + a * tip_x[1]
            x = np.maximum(xs, xt + (xs[:, :1] - xt) * (1.0 - v) ** 2)
            centre = np.stack([side * x, yz[..., 0], yz[..., 1]], -1)
            grad = _sdf.sdf_gradient(_sdf.body_sdf, centre.reshape(-1, 3)).reshape(centre.shape)
            w = np.clip(1.0 - _sdf.body_sdf(centre.reshape(-1, 3)).reshape(off.shape) / 0.012, 0, 1)[..., None]
            hint = unit(w * grad + (1 - w) * np.array([side, 0.5, 0.0]))
            t = unit(np.gradient(centre, axis=1))
            across = unit(np.cross(t, hint))
            pts, nrm, st, tris = strips(centre, across, np.full(count, width),
                                        np.full(count, COVERT_TILE if tile is None else tile))
            pieces.append((pts, nrm, st, tris))
    return _part("Wings", pieces)


#: Rectrices: count, root (y, z) m, direction below the horizontal (deg), fan half-angle (deg), lengths (centre,
#: outer) m, width m, root spread (m, half). Columba livia: 12 rectrices, tail 9.5-12 cm (see anatomy).
TAIL_COUNT, TAIL_ROOT_M, TAIL_PITCH_DEG, TAIL_FAN_DEG = 12, (0.056, -0.076), 24.0, 11.0
TAIL_LENGTH_M, TAIL_WIDTH_M, TAIL_SPREAD_M = (0.114, 0.108), 0.028, 0.017


def build_tail() -> MeshPart:
    """``Tail``: :data:`TAIL_COUNT` rectrices in a shallow fan, the central pair on top, dark terminal band."""
    k = np.arange(TAIL_COUNT) - 0.5 * (TAIL_COUNT - 1)
    f = np.abs(k) / np.abs(k).max()
    pitch, yaw = np.deg2rad(TAIL_PITCH_DEG), np.deg2rad(TAIL_FAN_DEG) * k / np.abs(k).max()
    d = np.stack([np.sin(yaw) * np.cos(pitch), np.full_like(yaw, -np.sin(pitch)), -np.cos(yaw) * np.cos(pitch)], 1)
    length = TAIL_LENGTH_M[0] + (TAIL_LENGTH_M[1] - TAIL_LENGTH_M[0]) * f
    root = np.stack([TAIL_SPREAD_M * k / np.abs(k).max(), TAIL_ROOT_M[0] + 0.002 * (1 - f),
                     np.full_like(k, TAIL_ROOT_M[1])], 1)
    v = SHAPE_V[None, :, None]
    droop = (-0.004 * f[:, None] * SHAPE_V[None, :] ** 2)[..., None] * np.array([0.0, 1.0, 0.0])
    centre = root[:, None] + length[:, None, None] * v * d[:, None] + droop
    order = np.argsort(-f, kind="stable")  # outer rectrices first, the central pair last (drawn on top)
    centre = centre[order]
    t = unit(np.gradient(centre, axis=1))
    across = unit(np.cross(t, np.array([0.0, 1.0, 0.0])))
    return _part("Tail", [strips(centre, across, np.full(TAIL_COUNT, TAIL_WIDTH_M), np.full(TAIL_COUNT, T_RECTRIX))])


def build_plumage(vertices_m, faces, seed: int) -> tuple:
    """``(CoatFeathers, Wings, Tail)`` over the welded body mesh."""
    return build_coat(vertices_m, faces, seed), build_wings(), build_tail()

"""The rock dove's plumage in real-time terms: feather cards over the head and body, the folded wings, the tail.

Each feather is a card (docs/plumage.md): a strip of :data:`SHAPE_V` rows from the quill (v = 0) to the tip
(v = 1), three vertices across (the vane's edges and the raised rachis), on one tile of the plumage atlas
(:data:`rockdove.geometry.colours.ATLAS`) whose kind sets the outline, size and pattern; each card draws one of its
kind's variants and may be mirrored, so no pattern repeats. Every card is one connected component of its part (the
rig binds each rigidly). Parts (:data:`CARD_PARTS`): :func:`build_head`, :func:`build_coat` (normals the body
field's gradient, so the coat shades as one surface), :func:`build_wings` (the black subterminal patches line up
into the two curved wing bars) and :func:`build_tail` (Columba livia has 12 rectrices)."""

from __future__ import annotations

import numpy as np

from rockdove.geometry import cards as _cards
from rockdove.geometry import neck as _neck
from rockdove.geometry import parts as _parts
from rockdove.geometry import sdf as _sdf
from rockdove.geometry.colours import (
    BODY_DISPLAY_COLOR,
    FEATHER_HALF_WIDTH,
    HEAD_SRGB,
    PRIMARIES_SRGB,
    TAIL_SRGB,
    TILE_START,
    WING_SRGB,
    atlas_st,
    coat_tiles,
    half_width,
)
from rockdove.geometry.types import MeshPart, triangle_part, unit

#: The parts made of feather cards (two-sided, bound to the plumage material).
CARD_PARTS = ("HeadFeathers", "CoatFeathers", "Wings", "Tail")
#: Rows of every card along the feather (quill 0 .. tip 1).
SHAPE_V = np.array([0.0, 0.3, 0.62, 0.86, 1.0])
#: The rachis is raised above the vane's edges by this fraction of the card's width (the feather's camber).
CAMBER = 0.06
#: Coat cards: count, length (m) by region, lift and bend (low, so the shingles stack ~1 mm deep and shadow maps see
#: one smooth coat), root depth and clearance (m).
COAT_COUNT = 1700
COAT_LENGTH_M, COAT_NECK_LENGTH_M, COAT_TAIL_LENGTH_M = 0.024, 0.014, 0.036
COAT_LIFT, COAT_BEND, COAT_DEPTH_M, COAT_CLEARANCE_M = 0.015, 0.01, 0.0008, 0.0005
#: Extra clearance of the coat cards rooted round the folded wing, which lie over its edge (m).
COAT_OVER_WING_M = 0.0032
#: Direction the coat lies in before projection onto the skin: tailward and down.
COAT_FLOW = np.array([0.0, -0.55, -0.83])
#: Coat roots are kept off the neck band (by this margin in the neck's radius, m: the neck cards lying down from
#: the band cover it) and off the head, so no coat card stands in front of the iridescent cards.
COAT_NECK_MARGIN_M, COAT_HEAD_MARGIN_M = 0.010, 0.004
#: Head feathers: count, length range (m), their clearance over the skin on the crown and where they lie over the
#: neck cards' roots (m), and the bare skin kept free round the bill's root and the eye's ring (m).
HEAD_COUNT, HEAD_LENGTH_M = 1000, (0.007, 0.012)
HEAD_CLEARANCE_M, HEAD_OVER_NECK_M = 0.0003, 0.002
BILL_CLEAR_M, EYE_CLEAR_M = 0.005, 0.0008
STREAM_COAT, STREAM_HEAD, STREAM_WINGS = 4, 5, 6


def tile(kind: str, srgb, rng, count: int) -> np.ndarray:
    """(count,) atlas tiles of ``kind`` in tone ``srgb`` (:data:`colours.TILE_START`), variants from ``rng``."""
    start, variants = TILE_START[kind, srgb]
    return start + rng.integers(0, variants, count)


def hull(kind: str) -> np.ndarray:
    """(R,) the fraction of its tile's width a card of ``kind`` keeps at each row of :data:`SHAPE_V`: the widest
    the feather's outline (:func:`~rockdove.geometry.colours.half_width`) gets between the neighbouring rows, plus
    the soft edge, so the card hugs the feather and its empty corners are cut off."""
    v = np.linspace(0.0, 1.0, 201)
    w = half_width(kind, v)
    lo, hi = np.r_[0.0, SHAPE_V[:-1]], np.r_[SHAPE_V[1:], 1.0]
    return np.minimum(1.0, np.array([2 * w[(v >= a) & (v <= b)].max() + 0.1 for a, b in zip(lo, hi)]))


def feather_cards(centre, across, width, tiles, up, mirror=None, thick_m: float = 0.0, kind: str = "contour",
                  camber: float = CAMBER):
    """Feather cards from their centre lines: ``centre`` (N, R, 3) rows (the last the tip), ``across`` (N, R, 3)
    unit (``t x up``: counter-clockwise seen from ``up``), ``width`` (N,) m of the tile, ``tiles`` (N,) atlas tiles
    of ``kind`` (each row :func:`hull` wide), ``up`` (N, R, 3) unit outward normals (the shading normals),
    ``mirror`` (N,) bool (u flipped), the rachis raised by ``camber`` x width. ``thick_m`` > 0 closes each card
    underneath with a row that far under the rachis (a lens: the edges shared). Returns ``(points (N*R*C, 3),
    normals, st, faces)``, C = 3 (4 with the underside) vertices per row."""
    n, rows = centre.shape[:2]
    g = hull(kind)
    half = (0.5 * width)[:, None, None] * g[None, :, None] * across
    cols = [centre - half, centre + (camber * width)[:, None, None] * up, centre + half]
    nrm = [up, up, up]
    if thick_m:
        cols, nrm = cols + [centre - thick_m * up], nrm + [-up]
    c = len(cols)
    pts, normals = np.stack(cols, 2), np.stack(nrm, 2)
    u = 0.5 + np.array([-0.5, 0.0, 0.5, 0.0])[None, :c] * g[:, None]  # (R, C)
    u = np.where((np.zeros(n, bool) if mirror is None else mirror)[:, None, None], 1.0 - u, u)
    st = atlas_st(tiles[:, None, None], u, SHAPE_V[None, :, None])  # (N, R, C, 2)
    j = c * np.arange(rows - 1)
    quads = [(0, 1), (1, 2)] + ([(3, 0), (2, 3)] if thick_m else [])  # (a, b): a_j, b_j, b_j+1, a_j+1
    tri = np.concatenate([np.concatenate([np.stack([j + a, j + b, j + c + b], -1), np.stack([j + a, j + c + b,
                                                                                            j + c + a], -1)])
                          for a, b in quads])
    faces = (tri[None] + rows * c * np.arange(n)[:, None, None]).reshape(-1, 3)
    return pts.reshape(-1, 3), normals.reshape(-1, 3), st.reshape(-1, 2), faces


def _part(name, pieces) -> MeshPart:
    return triangle_part(name, [(p, unit(n), st, f) for p, n, st, f in pieces], "plumage", BODY_DISPLAY_COLOR)


def _shingles(roots, n, t, length, width, tiles, rng, lift, bend, depth, clearance, kind="contour", camber=CAMBER):
    """Cards rooted at ``roots`` lying along ``t`` over skin normals ``n``, groomed onto the skin: each row at
    length ``v L`` along ``t`` is moved onto the skin, then raised ``h(v) = -depth (1 - v)^4 + L (lift v + bend
    v^2)`` plus ``clearance`` (m, scalar or per card) along the skin's normal there, so a card follows the body's
    curvature; shaded with the body field's gradient."""
    v = SHAPE_V[None, :]
    gap = np.broadcast_to(np.asarray(clearance, float).reshape(-1, 1), (len(roots), 1))
    h = -depth * (1.0 - v) ** 4 + length[:, None] * (lift * v + bend * v * v) + gap * (v > 0)
    on = (roots[:, None] + (length[:, None] * v)[..., None] * t[:, None]).reshape(-1, 3)
    for _ in range(2):
        up, on = _cards.snap_to_skin(on)
    up = up.reshape(len(roots), -1, 3)
    centre = on.reshape(up.shape) + h[..., None] * up
    across = unit(np.cross(np.gradient(centre, axis=1), up))
    pts, _, st, faces = feather_cards(centre, across, width, tiles, up, rng.random(len(roots)) < 0.5, kind=kind,
                                      camber=camber)
    pts = pts.reshape(len(roots), -1, 3)
    rest, gaps = pts[:, 3:].reshape(-1, 3), np.repeat(gap[:, 0], pts.shape[1] - 3)
    for g in np.unique(gaps):  # the vane's edges clear the skin too (concave places)
        sel = gaps == g
        rest[sel] = _cards._push_out(rest[sel], np.repeat(n, pts.shape[1] - 3, axis=0)[sel], g)
    pts[:, 3:] = rest.reshape(pts[:, 3:].shape)
    pts = pts.reshape(-1, 3)
    return pts, _sdf.sdf_gradient(_sdf.body_sdf, pts), st, faces


def _roots(vertices_m, faces, keep, count, rng):
    """(normals, roots) of ``count`` blue-noise points on the skin where ``keep(points)`` holds."""
    faces = faces[keep(vertices_m)[faces].any(axis=1)]  # the triangles that reach the region
    cand = _neck.sample_triangles(vertices_m, faces, 4 * count, rng)
    inside = keep(cand)
    area = _neck.triangle_areas(vertices_m, faces).sum() * inside.mean()
    cand = cand[inside]
    return _cards.snap_to_skin(cand[_neck.eliminate(cand, min(count, len(cand)), area, rng)])


def _along(n, flow):
    """(N, 3) unit directions ``flow`` (N, 3) projected onto the tangent planes of the normals ``n``."""
    return unit(flow - np.einsum("ij,ij->i", flow, n)[:, None] * n)


def _yaw(t, n, rng, deg):
    a = np.deg2rad(deg) * rng.uniform(-1, 1, len(t))
    return unit(t * np.cos(a)[:, None] + np.cross(n, t) * np.sin(a)[:, None])


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


def head_region(points_m) -> np.ndarray:
    """(N,) bool: skin that carries head feathers: the head and the top of the neck above the neck cards' roots
    (s > :data:`rockdove.geometry.cards.BAND_S_MAX` near its axis)."""
    s, r = _neck.neck_s(points_m)
    return ((_sdf.HEAD.sdf(points_m) < COAT_HEAD_MARGIN_M) & (s > _cards.BAND_S_MAX - 0.04)) | (
        (s > _cards.BAND_S_MAX) & (r < _sdf.NECK_BAND_RADIUS_M + 0.01))


def coat_region(points_m) -> np.ndarray:
    """(N,) bool: body points that carry contour-feather cards: not the neck band, the head, or the flank under
    the folded wing (its outline seen from the side: the coat beside it lies under its edge)."""
    s, r = _neck.neck_s(points_m)
    neck = ((s >= -0.1) & (r <= _sdf.NECK_BAND_RADIUS_M + COAT_NECK_MARGIN_M)) | (s > 0.9)
    under_wing = (np.abs(points_m[:, 0]) > 0.012) & inside_polygon(points_m[:, 1:3], wing_outline_yz())
    return ~neck & ~under_wing & (_sdf.HEAD.sdf(points_m) > COAT_HEAD_MARGIN_M) & ~((s > 1.0) & (r < 0.045))


def build_coat(vertices_m, faces, seed: int, count: int = COAT_COUNT) -> MeshPart:
    """``CoatFeathers``: ``count`` contour-feather cards on blue-noise roots over :func:`coat_region`, shorter by
    the neck, longer as the coverts over and under the tail's base, which lie along the tail."""
    rng = _cards.stream(seed, STREAM_COAT)
    n, roots = _roots(vertices_m, faces, coat_region, count, rng)
    _, r = _neck.neck_s(roots)
    pitch = np.deg2rad(TAIL_PITCH_DEG)  # the tail's root and axis
    root, axis = np.array([0.0, *TAIL_ROOT_M]), np.array([0.0, -np.sin(pitch), -np.cos(pitch)])
    by_tail = 1.0 - _sdf.smoothstep(0.01, 0.03, np.linalg.norm(roots - root, axis=1))
    by_neck = 1.0 - _sdf.smoothstep(0.045, 0.065, r)
    t = _yaw(_along(n, COAT_FLOW[None] * (1 - by_tail[:, None]) + axis[None] * by_tail[:, None]), n, rng, 12.0)
    length = (COAT_LENGTH_M + (COAT_NECK_LENGTH_M - COAT_LENGTH_M) * by_neck
              + (COAT_TAIL_LENGTH_M - COAT_LENGTH_M) * by_tail) * rng.uniform(0.75, 1.25, len(roots))
    width = length * rng.uniform(0.6, 0.72, len(roots))
    poly = wing_outline_yz()  # round the folded wing, the coat lies over its edge (scapulars, the breast's sides)
    over = (np.abs(roots[:, 0]) > 0.012) & inside_polygon(roots[:, 1:], poly + 0.35 * (poly - poly.mean(0)))
    return _part("CoatFeathers", [_shingles(roots, n, t, length, width, coat_tiles(roots, rng), rng, COAT_LIFT,
                                            COAT_BEND, COAT_DEPTH_M, COAT_CLEARANCE_M + COAT_OVER_WING_M * over,
                                            camber=CAMBER / 3)])


def build_head(vertices_m, faces, seed: int, count: int = HEAD_COUNT) -> MeshPart:
    """``HeadFeathers``: small rounded feathers over :func:`head_region`, lying away from the bill and, toward the
    neck, down it; those over the neck cards' roots stand off the skin above them; none within
    :data:`BILL_CLEAR_M` of the bill's root or over the bare ring round an eye."""
    rng = _cards.stream(seed, STREAM_HEAD)
    bill = _parts.bill_root_m()
    n, roots = _roots(vertices_m, faces, lambda p: head_region(p) & (np.linalg.norm(p - bill, axis=1) > BILL_CLEAR_M),
                      count, rng)
    s, _ = _neck.neck_s(roots)
    down = _sdf.smoothstep(1.25, 1.0, s)[:, None]
    axis = unit(_sdf.NECK_BASE_M - _sdf.NECK_TOP_M)
    t = _yaw(_along(n, unit(roots - bill) * (1 - down) + axis * down), n, rng, 15.0)
    length = rng.uniform(*HEAD_LENGTH_M, len(roots)) * (1.0 - 0.15 * down[:, 0])
    ends = roots[:, None] + length[:, None, None] * SHAPE_V[None, :, None] * t[:, None]
    clear = np.ones(len(roots), bool)
    for side in (1.0, -1.0):  # the bare orbital ring stays free: no card (its centre line, its half-width) over it
        centre, _ = _parts._eye_axis(side)
        gap = np.linalg.norm(ends - centre, axis=2).min(1) - 0.3 * length
        clear &= gap > _parts.EYE_RING_RADII_M[1] + EYE_CLEAR_M
    keep = np.flatnonzero(clear)
    lift = HEAD_CLEARANCE_M + (HEAD_OVER_NECK_M - HEAD_CLEARANCE_M) * np.round(down[keep, 0], 1)
    tiles = tile("head", HEAD_SRGB, rng, len(keep))
    return _part("HeadFeathers", [_shingles(roots[keep], n[keep], t[keep], length[keep], 0.8 * length[keep], tiles,
                                            rng, 0.02, 0.02, 0.0004, lift, kind="head")])


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
#: count, feather width (m), layer offset over the body (m), x of the tips where they leave the body (m), kind and
#: tone, and how far the middle of the row's tip line bows out (m, toward the tips: the bars curve).
#: Primaries under secondaries and tertials, greater coverts over them, median coverts on top; the tips of
#: the outer primaries meet over the tail (tip gap of 2 x 4 mm).
WING_ROWS = (
    ("primaries", ((0.108, 0.024), (0.099, -0.012)), ((0.037, -0.140), (0.062, -0.094)), 10, 0.022, 0.0008,
     (0.004, 0.016), ("primary", PRIMARIES_SRGB), 0.004),
    ("secondaries", ((0.113, 0.032), (0.138, -0.016)), ((0.074, -0.070), (0.108, -0.098)), 13, 0.024, 0.0013,
     (0.016, 0.012), ("secondary", WING_SRGB), 0.008),
    ("greater coverts", ((0.114, 0.040), (0.140, -0.002)), ((0.090, -0.012), (0.118, -0.032)), 12, 0.018, 0.0018,
     (0.03, 0.02), ("greater", WING_SRGB), 0.006),
    ("median coverts", ((0.108, 0.046), (0.142, 0.012)), ((0.096, 0.022), (0.126, -0.006)), 14, 0.016, 0.0022,
     (0.03, 0.02), ("covert", WING_SRGB), 0.004),
)


def build_wings(seed: int = 0) -> MeshPart:
    """``Wings``: both folded wings (:data:`WING_ROWS`), draped over the body."""
    rng = _cards.stream(seed, STREAM_WINGS)
    pieces = []
    v = SHAPE_V[None, :]
    for side in (1.0, -1.0):
        for _, roots, tips, count, width, offset, tip_x, kind, bow in WING_ROWS:
            a = np.linspace(0.0, 1.0, count)[:, None]
            r0 = (1 - a) * np.array(roots[0]) + a * np.array(roots[1])
            r1 = (1 - a) * np.array(tips[0]) + a * np.array(tips[1])
            chord = np.array(tips[1]) - np.array(tips[0])
            r1 = r1 + bow * 4 * a * (1 - a) * unit(np.array([chord[1], -chord[0]]))  # tips on an arc
            yz = r0[:, None] + (r1 - r0)[:, None] * v[..., None]  # (count, rows, 2)
            off = COAT_CLEARANCE_M + offset * (0.4 + 0.6 * v) + 0.00004 * np.arange(count)[:, None]  # over the coat,
            # the roots tucked, each feather over the last
            xs = drape_x(yz[..., 0], yz[..., 1], off.ravel()).reshape(off.shape)
            xt = (1 - a) * tip_x[0] + a * tip_x[1]
            x = np.maximum(xs, xt + (xs[:, :1] - xt) * (1.0 - v) ** 2)
            centre = np.stack([side * x, yz[..., 0], yz[..., 1]], -1)
            grad = _sdf.sdf_gradient(_sdf.body_sdf, centre.reshape(-1, 3)).reshape(centre.shape)
            w = np.clip(1.0 - _sdf.body_sdf(centre.reshape(-1, 3)).reshape(off.shape) / 0.012, 0, 1)[..., None]
            hint = unit(w * grad + (1 - w) * np.array([side, 0.5, 0.0]))
            t = unit(np.gradient(centre, axis=1))
            across = unit(np.cross(t, hint))
            pts, nrm, st, faces = feather_cards(centre, across, np.full(count, width / (2 * FEATHER_HALF_WIDTH)),
                                                tile(*kind, rng, count),
                                                unit(np.cross(across, t)), rng.random(count) < 0.5, kind=kind[0],
                                                camber=0.5 * CAMBER)
            flush = drape_x(pts[:, 1], pts[:, 2], np.repeat(off, 3, axis=1).ravel() + 0.0003)  # no vane edge
            pts[:, 0] = np.where(flush > 0, np.sign(pts[:, 0]) * np.minimum(np.abs(pts[:, 0]), flush), pts[:, 0])
            pieces.append((pts, nrm, st, faces))  # stands out past the layer's surface over the body
    return _part("Wings", pieces)


#: Rectrices: count, root (y, z) m, direction below the horizontal (deg), fan half-angle (deg), lengths (centre,
#: outer) m, feather width m, root spread (m, half), how far the outer rectrices' tips lie below the central
#: pair's (m: the closed fan's arch) and each card's thickness at the rachis (m). Columba livia: 12 rectrices,
#: tail 9.5-12 cm (see anatomy), broad and rounded.
TAIL_COUNT, TAIL_ROOT_M, TAIL_PITCH_DEG, TAIL_FAN_DEG = 12, (0.056, -0.076), 21.0, 9.0
TAIL_LENGTH_M, TAIL_WIDTH_M, TAIL_SPREAD_M, TAIL_ARCH_M, TAIL_THICK_M = (0.114, 0.106), 0.030, 0.014, 0.005, 0.0012


def build_tail(seed: int = 0) -> MeshPart:
    """``Tail``: :data:`TAIL_COUNT` rectrices in a closed, arched fan, the central pair on top, each a lens
    :data:`TAIL_THICK_M` thick at the rachis, dark terminal band."""
    rng = _cards.stream(seed, STREAM_WINGS + 1)
    k = np.arange(TAIL_COUNT) - 0.5 * (TAIL_COUNT - 1)
    f = np.abs(k) / np.abs(k).max()
    pitch, yaw = np.deg2rad(TAIL_PITCH_DEG), np.deg2rad(TAIL_FAN_DEG) * k / np.abs(k).max()
    d = np.stack([np.sin(yaw) * np.cos(pitch), np.full_like(yaw, -np.sin(pitch)), -np.cos(yaw) * np.cos(pitch)], 1)
    length = TAIL_LENGTH_M[0] + (TAIL_LENGTH_M[1] - TAIL_LENGTH_M[0]) * f
    root = np.stack([TAIL_SPREAD_M * k / np.abs(k).max(), TAIL_ROOT_M[0] + 0.003 * (1 - f),
                     np.full_like(k, TAIL_ROOT_M[1])], 1)
    v = SHAPE_V[None, :, None]
    arch = -(TAIL_ARCH_M * f[:, None] ** 1.5 * SHAPE_V[None, :] ** 1.2 + 0.0015 * f[:, None])  # outer ones under
    centre = root[:, None] + length[:, None, None] * v * d[:, None] + arch[..., None] * np.array([0.0, 1.0, 0.0])
    t = unit(np.gradient(centre, axis=1))
    side = np.sign(k)[:, None, None] * np.array([1.0, 0.0, 0.0])
    up = unit(np.array([0.0, 1.0, 0.0]) + 0.35 * np.sqrt(f)[:, None, None] * side - np.einsum(
        "nrk,k->nr", t, [0.0, 1.0, 0.0])[..., None] * t)  # each rectrix tilted down to its side: the arch
    across = unit(np.cross(t, up))
    return _part("Tail", [feather_cards(centre, across, np.full(TAIL_COUNT, TAIL_WIDTH_M / (2 * FEATHER_HALF_WIDTH)),
                                        tile("rectrix", TAIL_SRGB, rng, TAIL_COUNT), unit(np.cross(across, t)),
                                        k > 0, thick_m=TAIL_THICK_M, kind="rectrix")])


def build_plumage(vertices_m, faces, seed: int) -> tuple:
    """``(HeadFeathers, CoatFeathers, Wings, Tail)`` over the welded body mesh."""
    return (build_head(vertices_m, faces, seed), build_coat(vertices_m, faces, seed), build_wings(seed),
            build_tail(seed))

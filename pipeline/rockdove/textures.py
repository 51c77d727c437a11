"""Procedural textures: the neck feathers' base colour + alpha and mask (the seed paper's two), the plumage atlas
of the other cards (docs/plumage.md) and the body's base colour in its xatlas UVs.

Image convention (docs/design.md, Textures): uint8, row 0 at the TOP, texel (row, col) of an (H, W) image at
st = ((col + 0.5) / W, 1 - (row + 0.5) / H); on a card the tip (v = 1) is at the top. Colours are blended in
linear Rec.709 and encoded sRGB (:func:`rockdove.srgb.linear_to_srgb8`); alpha and the mask are linear."""

from __future__ import annotations

import numpy as np

from .errors import UsageError
from .geometry.colours import ATLAS, ATLAS_COLUMNS, ATLAS_ROWS, KINDS, WING_BAR_SRGB, body_colour_at, half_width
from .geometry.colours import linear as _linear
from .geometry.colours import mix as _mix
from .geometry.sdf import smoothstep as _smoothstep
from .geometry.types import Bird, MeshPart
from .srgb import linear_to_srgb8 as _encode  # the project's one sRGB 8-bit encoding

#: sRGB 8-bit colour of a neck feather's vane (its rachis and down are painted paler by :func:`feather_tile`).
VANE_SRGB = (56, 61, 66)
#: Where the mask turns on along the feather: v from MASK_START to MASK_FULL (the tip part is structural).
MASK_START_V = 0.42
MASK_FULL_V = 0.60
#: Half-width of the soft edge the alpha fades over (u, the tile's width 1).
SOFT_EDGE = 0.03
#: Barbs slant toward the tip: v gained per unit of |u - rachis| along a barb (about 40 degrees from the rachis
#: in a tile twice as tall as wide).
BARB_SLANT = 0.6
#: Relief of the normal map: height of the rachis, the vane's camber and a barb, in tile widths, and the gain.
RACHIS_H, CAMBER_H, BARB_H, NORMAL_GAIN = 0.012, 0.003, 0.004, 1.0


def _resolution(value, attr="feather_texture_resolution") -> int:
    """The resolution an int or a BirdParams (its ``attr``) gives; ValueError outside [16, 8192]."""
    res = getattr(value, attr, value)
    if isinstance(res, bool) or not isinstance(res, (int, np.integer)) or not 16 <= res <= 8192:
        raise UsageError(f"resolution_or_params={value!r} must be BirdParams or an integer resolution in [16, 8192]")
    return int(res)


def feather_tile(kind: str, srgb, seed: int, height: int, width: int) -> tuple:
    """One feather of kind ``kind`` (:data:`rockdove.geometry.colours.KINDS`) in tone ``srgb``, painted over a
    ``height`` x ``width`` tile (u across, rachis at 0.5; v from the root at the bottom row to the tip at the top);
    ``seed`` draws its own rachis curve, width, tone, barb phase and splits in the vane. Returns linear RGB
    (H, W, 3), alpha (H, W) with a soft edge :data:`SOFT_EDGE` wide and a partly transparent downy base, height
    (H, W) in tile widths (rachis, camber, barbs) and roughness (H, W)."""
    _, _, _, barbs, down, outer, dark, rough = KINDS[kind]
    rng = np.random.default_rng([int(seed), 29])
    u, v = np.meshgrid((np.arange(width) + 0.5) / width, 1.0 - (np.arange(height) + 0.5) / height)
    tone = _linear(srgb) * rng.uniform(0.95, 1.05)
    if kind == "eye":  # u around the eyeball, v from its back to the cornea: iris, limbal ring, centred pupil
        streak = 1.0 + 0.12 * np.sin(2 * np.pi * (u * 37 + 0.3 * np.sin(2 * np.pi * u * 5)))
        col = tone * (streak * (1.0 - 0.6 * _smoothstep(0.86, 0.8, v) * _smoothstep(0.75, 0.8, v)))[..., None]
        col = _mix(col * _smoothstep(0.5, 0.62, v)[..., None], np.zeros(3), _smoothstep(0.885, 0.895, v))
        return col, np.ones_like(u), np.zeros_like(u), np.full_like(u, rough)
    x = u - 0.5 - rng.uniform(-0.02, 0.02) * v * v  # across, from the (curved) rachis (clear of the border)
    ax = np.abs(x)
    smooth = kind == "neck"  # the neck's iridescent feathers lie smooth and full: no splits or fraying, even widths
    w = half_width(kind, v) * (1.0 if smooth else rng.uniform(0.92, 1.0)) * np.where(x < 0, outer, 1.0) + 1e-6
    phase = barbs * (v - BARB_SLANT * ax) + rng.uniform(0, 1)
    barb = 0.5 + 0.5 * np.cos(2 * np.pi * phase)
    edge = w * (1.0 - (0.0 if smooth else 0.06) * barb * _smoothstep(0.5, 1.0, ax / w))  # barbs' ends fray it
    splits = 0 if smooth else 2
    for p_split, side in zip(rng.uniform(0.4, 0.9, splits) * barbs, rng.choice([-1, 1], splits)):  # splits
        gap = np.exp(-(((phase - p_split) / 0.2) ** 2)) * _smoothstep(0.5, 0.9, ax / w) * (np.sign(x) == side)
        edge = edge * (1.0 - 0.35 * gap)
    fluff = _smoothstep(0.2 * down, down, v)  # the downy base: loose, pale and partly transparent
    alpha = _smoothstep(-SOFT_EDGE, SOFT_EDGE, edge - ax) * (0.35 + 0.65 * fluff) * (1.0 - 0.35 * (1.0 - fluff) * barb)
    alpha = np.clip(alpha, 0.0, 1.0) * (v < 0.995)
    mottle = 1.0 + 0.05 * np.sin(2 * np.pi * (rng.uniform(1, 3) * u + rng.uniform(2, 4) * v + rng.uniform()))
    col = tone * (mottle * (0.9 + 0.1 * barb) * (1.0 + 0.25 * (1.0 - fluff)))[..., None]
    if dark is not None:  # the subterminal black of a wing bar, the tail's terminal band, the primaries' tips
        d = _smoothstep(dark[0], dark[0] + 0.04, v) * (1.0 - _smoothstep(dark[1] - 0.04, dark[1], v))
        col = _mix(col, _linear(WING_BAR_SRGB), dark[2] * d * (1.0 - 0.015 * barb))
    rachis_w = 0.018 - 0.012 * v
    on_rachis = _smoothstep(rachis_w, 0.4 * rachis_w, ax) * (v < 0.97)
    col = _mix(col, 0.02 + 1.3 * col, 0.6 * on_rachis)
    height_map = (RACHIS_H * on_rachis + CAMBER_H * np.clip(1.0 - (ax / w) ** 2, 0.0, 1.0)
                  + BARB_H * barb * _smoothstep(0.0, 0.3, ax / w)) * fluff
    roughness = rough + 0.25 * (1.0 - fluff) - 0.15 * on_rachis + 0.05 * barb
    return col, alpha, height_map, np.clip(roughness, 0.0, 1.0)


def plumage_atlas(resolution_or_params=256) -> tuple:
    """The plumage atlas of :data:`rockdove.geometry.colours.ATLAS`: every tile a feather of :func:`feather_tile`, tiles
    H / 2 x H texels (H: half BirdParams' ``feather_texture_resolution`` or of an int, clipped to [128, 512]: the soft
    edge and the bars keep a few texels) on ``ATLAS_COLUMNS`` x ``ATLAS_ROWS``, row 0 at the top. Returns ``(base (H, W,
    4) uint8`` sRGB with the alpha, ``normal (H, W, 4) uint8``: the tangent-space normal (x along u, y along v, OpenGL
    convention) as ``n / 2 + 1 / 2``, roughness in alpha)."""
    h = int(np.clip(_resolution(resolution_or_params) // 2, 128, 512))
    w = h // 2
    base = np.zeros((ATLAS_ROWS * h, ATLAS_COLUMNS * w, 4), np.uint8)
    normal = np.zeros_like(base)
    normal[..., 2] = 255
    tiles = [(kind, srgb, k) for kind, srgb, n in ATLAS for k in range(n)]
    for i, (kind, srgb, k) in enumerate(tiles):
        col, alpha, hgt, rough = feather_tile(kind, srgb, 1000 * i + k, h, w)
        dy, dx = np.gradient(hgt * w)  # in texels of height per texel (rows run down: v up is -dy)
        n = np.stack([-dx * NORMAL_GAIN, dy * NORMAL_GAIN, np.ones_like(dx)], -1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        r, c = divmod(i, ATLAS_COLUMNS)
        box = slice(r * h, (r + 1) * h), slice(c * w, (c + 1) * w)
        base[box] = np.concatenate([_encode(col), np.round(alpha * 255)[..., None].astype(np.uint8)], -1)
        normal[box] = np.round(np.concatenate([n * 0.5 + 0.5, rough[..., None]], -1) * 255).astype(np.uint8)
    return base, normal


def feather_textures(resolution_or_params=256) -> dict:
    """The feather textures, R x R texels (16 .. 8192, or BirdParams' ``feather_texture_resolution``): the seed paper's
    two for the neck's cards, ``"base"`` (R, R, 4) uint8 RGBA, the sRGB feather of :func:`feather_tile` with its soft
    silhouette in alpha, and ``"mask"`` (R, R) uint8, 255 on the tip (v >= MASK_FULL_V) where structural colour is
    drawn, 0 below MASK_START_V, also past the silhouette (edge padding for mip levels); and the other cards' atlas
    (:func:`plumage_atlas`), ``"plumage_base"`` and ``"plumage_normal"``."""
    res = _resolution(resolution_or_params)
    col, alpha, _, _ = feather_tile("neck", VANE_SRGB, 7, res, res)
    base = np.concatenate([_encode(col), np.round(alpha * 255.0).astype(np.uint8)[..., None]], axis=-1)
    # not cut by the silhouette: a host's mip levels average the mask past the cut-out edge (a mask of 0 there
    # drew a dark outline round every card in Storm, p95 dE2000 6.2 -> 0.45 at 512 px)
    v = np.broadcast_to(1.0 - (np.arange(res)[:, None] + 0.5) / res, (res, res))
    mask = np.round(_smoothstep(MASK_START_V, MASK_FULL_V, v) * 255.0).astype(np.uint8)
    atlas, normal = plumage_atlas(res)
    return {"base": base, "mask": mask, "plumage_base": atlas, "plumage_normal": normal}


#: Widening of a triangle's texel box, texels: far above what the barycentric tolerance (1e-9) admits outside a
#: triangle (1e-9 of its size), far below a texel.
BBOX_SLACK_TEXELS = 1e-6


def rasterize_uv(st: np.ndarray, faces: np.ndarray, resolution: int, chunk: int = 4096):
    """Which of the triangles ``faces`` (F, 3) with texture coordinates ``st`` (V, 2) covers each texel centre of
    an R x R image (vectorised over triangles and texels): (rows, cols, face, barycentrics (K, 3)) of the K covered
    texels, row 0 at the top (t = 1)."""
    res = int(resolution)
    xy = np.stack([st[:, 0] * res - 0.5, (1.0 - st[:, 1]) * res - 0.5], axis=1)  # texel-centre units
    out = ([], [], [], [])
    for start in range(0, len(faces), chunk):  # chunks bound the memory; each is vectorised
        f = faces[start:start + chunk]
        tri = xy[f]  # (C, 3, 2)
        # texel centres (integers here) within the triangle's bounding box, widened by BBOX_SLACK_TEXELS so
        # that no centre the barycentric test below accepts is left out
        lo = np.clip(np.ceil(tri.min(axis=1) - BBOX_SLACK_TEXELS).astype(np.int64), 0, res - 1)
        hi = np.clip(np.floor(tri.max(axis=1) + BBOX_SLACK_TEXELS).astype(np.int64), 0, res - 1)
        nx = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
        ny = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
        n = nx * ny
        tid = np.repeat(np.arange(len(f)), n)
        local = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
        px = lo[tid, 0] + local % nx[tid]
        py = lo[tid, 1] + local // nx[tid]
        a, b, c = tri[tid, 0], tri[tid, 1], tri[tid, 2]
        v0, v1 = b - a, c - a
        v2 = np.stack([px, py], axis=1) - a
        den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
        ok = np.abs(den) > 1e-12
        den = np.where(ok, den, 1.0)
        w1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
        w2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
        w0 = 1.0 - w1 - w2
        inside = ok & (w0 >= -1e-9) & (w1 >= -1e-9) & (w2 >= -1e-9)
        for o, found in zip(out, (py, px, start + tid, np.stack([w0, w1, w2], axis=1))):
            o.append(found[inside])
    return tuple(np.concatenate(o) for o in out)


def body_base_colour(resolution_or_params, bird) -> np.ndarray:
    """(R, R, 3) uint8 sRGB base colour of the body in its xatlas UVs (R: 16 .. 8192 or BirdParams'
    ``body_texture_resolution``; ``bird``: a Bird, a Body or the Body MeshPart): each covered texel the colour of its
    3-D point (:func:`body_colour_at`), the empty texels between charts the nearest covered one's, so bilinear
    filtering and mipmaps do not bleed background into the seams."""
    from scipy import ndimage

    res = _resolution(resolution_or_params, attr="body_texture_resolution")
    part = bird.part("Body") if isinstance(bird, Bird) else getattr(bird, "part", bird)  # Body.part
    if not isinstance(part, MeshPart):
        raise UsageError(f"bird={type(bird).__name__} must be a Bird, a Body or the Body MeshPart")
    faces = part.face_vertex_indices.reshape(-1, 3).astype(np.int64)
    rows, cols, face, bary = rasterize_uv(part.st.astype(np.float64), faces, res)
    pts = np.einsum("nk,nkd->nd", bary, part.points_m.astype(np.float64)[faces[face]])
    img = np.zeros((res, res, 3), dtype=np.uint8)
    img[rows, cols] = _encode(body_colour_at(pts))
    empty = np.ones((res, res), dtype=bool)
    empty[rows, cols] = False
    if empty.any():
        _, (ri, ci) = ndimage.distance_transform_edt(empty, return_indices=True)
        img = img[ri, ci]
    return img

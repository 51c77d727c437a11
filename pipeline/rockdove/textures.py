"""Procedural textures: the feather base colour + alpha silhouette and mask (the seed paper's two feather
textures), and the body's base colour in its xatlas UVs with the feather cards' palette strip.

Image convention (docs/design.md, Textures): uint8 arrays, row 0 is the TOP of the image, so texel (row, col) of
an (H, W) image sits at st = ((col + 0.5) / W, 1 - (row + 0.5) / H) (USD's st has t = 0 at the bottom). On a
feather card u runs across the feather and v from the root (0) to the tip (1): the tip is at the top of the
feather images. Colours are blended in linear Rec.709 and encoded sRGB (:func:`rockdove.srgb.linear_to_srgb8`);
alpha and the mask are linear. The palette: :mod:`rockdove.geometry.colours`.
"""

from __future__ import annotations

import numpy as np

from .geometry import plumage as _pl
from .geometry.colours import WING_BAR_SRGB, body_colour_at, coat_tiles, palette_colours  # noqa: F401
from .geometry.colours import linear as _linear, mix as _mix
from .geometry.sdf import smoothstep as _smoothstep
from .errors import UsageError

#: sRGB 8-bit colours of a neck feather: the vane, the rachis, the downy base.
VANE_SRGB = (56, 61, 66)
RACHIS_SRGB = (110, 112, 116)
DOWN_SRGB = (128, 132, 138)

#: Where the mask turns on along the feather: v from MASK_START to MASK_FULL (the tip part is structural).
MASK_START_V = 0.42
MASK_FULL_V = 0.60
#: Barbs across the vane (count from root to tip) and their slant (dv per unit of |u - 0.5|).
BARB_COUNT = 42
BARB_SLANT = 0.9


def _resolution(value, attr="feather_texture_resolution") -> int:
    """The resolution an int or a BirdParams (its ``attr``) gives; ValueError outside [16, 8192]."""
    res = getattr(value, attr, value)
    if isinstance(res, bool) or not isinstance(res, (int, np.integer)) or not 16 <= res <= 8192:
        raise UsageError(f"resolution_or_params={value!r} must be BirdParams or an integer resolution in [16, 8192]")
    return int(res)


def _encode(linear: np.ndarray) -> np.ndarray:
    from rockdove.srgb import linear_to_srgb8  # the project's one sRGB 8-bit encoding

    return linear_to_srgb8(linear)


def feather_half_width(v: np.ndarray) -> np.ndarray:
    """Half-width of the feather silhouette in u at v (0 root .. 1 tip): quill, widening vane, rounded tip."""
    vv = np.clip((np.asarray(v, dtype=np.float64) - 0.06) / 0.92, 0.0, None)
    widen = 0.47 * (0.12 + 0.88 * np.sin(0.5 * np.pi * np.clip(vv / 0.62, 0.0, 1.0)))
    tip = 0.47 * np.sqrt(np.clip(1.0 - ((vv - 0.62) / 0.38) ** 2, 0.0, 1.0))
    w = np.where(vv < 0.62, widen, tip)
    quill = np.where(np.asarray(v) < 0.09, 0.018, 0.0)
    return np.where(np.asarray(v) < 0.06, quill, np.maximum(w, quill))


def feather_textures(resolution_or_params=256) -> dict:
    """The seed paper's two feather textures, R x R texels (16 .. 8192, or BirdParams' ``feather_texture_resolution``):
    ``"base"`` (R, R, 4) uint8 RGBA, the sRGB feather (dark slate vane with barbs, pale rachis, downy base) with its
    silhouette in alpha (antialiased over a texel); ``"mask"`` (R, R) uint8, 255 on the tip (v >= MASK_FULL_V)
    where structural colour is drawn, 0 below MASK_START_V, also past the silhouette
    (edge padding for mip levels)."""
    res = _resolution(resolution_or_params)
    c = (np.arange(res) + 0.5) / res
    u, v = np.meshgrid(c, 1.0 - c)  # at texel centres, row 0 at the top (the tip)
    x = np.abs(u - 0.5)
    half = feather_half_width(v)
    # ragged vane edge: barbs end at slightly different lengths
    phase = (v - BARB_SLANT * x) * BARB_COUNT
    ragged = 1.0 - 0.03 * np.abs(np.sin(np.pi * phase * 0.5)) * _smoothstep(0.1, 0.3, v)
    texel = 1.0 / res
    alpha = np.clip(((half * ragged) - x) / texel + 0.5, 0.0, 1.0)

    vane = _linear(VANE_SRGB)
    down = _linear(DOWN_SRGB)
    rachis = _linear(RACHIS_SRGB)
    barbs = 0.8 + 0.2 * np.cos(2.0 * np.pi * phase)  # light/dark alternation of barbs
    col = _mix(vane[None, None, :], down[None, None, :], 1.0 - _smoothstep(0.15, 0.38, v))
    col = col * barbs[..., None]
    rachis_half = np.maximum(0.012 * (1.0 - 0.75 * v), 0.6 * texel)
    col = _mix(col, rachis[None, None, :], np.clip((rachis_half - x) / texel + 0.5, 0.0, 1.0) * (v < 0.97))
    base = np.concatenate([_encode(col), np.round(alpha * 255.0).astype(np.uint8)[..., None]], axis=-1)
    # not cut by the silhouette: a host's mip levels average the mask past the cut-out edge (a mask of 0 there
    # drew a dark outline round every card in Storm, p95 dE2000 6.2 -> 0.45 at 512 px)
    mask = _smoothstep(MASK_START_V, MASK_FULL_V, v)
    return {"base": base, "mask": np.round(mask * 255.0).astype(np.uint8)}


# ---- body and the feather cards' palette ---------------------------------------------------------------
def palette_strip(resolution: int) -> np.ndarray:
    """(rows, R, 3) uint8 sRGB: the feather tiles of the body texture's bottom strip (rockdove.geometry.plumage),
    each a feather drawn across its tile (vane, pale rachis, barbs, downy base); the wing-bar tiles have the black
    subterminal band (narrower on the secondaries'), the rectrix tile the dark terminal band, the primary tile a
    darker tip."""
    res = int(resolution)
    rows = max(1, int(round(res * _pl.PALETTE_STRIP)))
    tv = 1.0 - (np.arange(rows) + 0.5) / rows  # row 0 at the top of the strip
    v = np.clip((tv - 0.04) / 0.92, 0.0, 1.0)[:, None]  # feather coordinate (cards map v into [0.04, 0.96])
    sc = (np.arange(res) + 0.5) / res * _pl.TILES
    tile, u = np.minimum(sc.astype(int), _pl.TILES - 1), np.clip((sc % 1.0 - 0.1) / 0.8, 0.0, 1.0)
    x = np.abs(u - 0.5)[None, :]
    shade = (0.78 + 0.22 * (1.0 - (2 * x) ** 2)) * (0.9 + 0.1 * np.cos(2 * np.pi * (v - 0.9 * x) * BARB_COUNT / 2))
    shade = shade * (0.82 + 0.18 * _smoothstep(0.0, 0.35, v)) + 0.25 * (x < 0.035) * (v < 0.97)
    col = palette_colours()[tile][None, :, :] * shade[..., None]
    black = np.zeros((rows, res))
    bar, rect, prim, bar2 = (tile == t for t in (_pl.T_BAR, _pl.T_RECTRIX, _pl.T_PRIMARY, _pl.T_BAR2))
    black[:, bar] = (_smoothstep(0.56, 0.62, v) * (1 - _smoothstep(0.8, 0.86, v)) * np.ones((1, bar.sum())))
    black[:, bar2] = (_smoothstep(0.6, 0.63, v) * (1 - _smoothstep(0.71, 0.74, v)) * np.ones((1, bar2.sum())))
    black[:, rect] = _smoothstep(0.8, 0.86, v) * np.ones((1, rect.sum()))
    black[:, prim] = 0.5 * _smoothstep(0.55, 0.9, v) * np.ones((1, prim.sum()))
    col = _mix(col, _linear(WING_BAR_SRGB) * 0.8, black)
    return _encode(col)


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
        out[0].append(py[inside])
        out[1].append(px[inside])
        out[2].append(start + tid[inside])
        out[3].append(np.stack([w0, w1, w2], axis=1)[inside])
    return tuple(np.concatenate(o) for o in out)


def body_base_colour(resolution_or_params, bird) -> np.ndarray:
    """(R, R, 3) uint8 sRGB base colour of the body in its xatlas UVs (R: 16 .. 8192 or BirdParams'
    ``body_texture_resolution``; ``bird``: a Bird, a Body or the Body MeshPart).

    Every texel a UV triangle covers gets the colour of its 3-D point (:func:`body_colour_at`); the bottom strip
    holds the feather cards' tiles (:func:`palette_strip`); the empty texels between charts take the colour of the
    nearest covered texel, so bilinear filtering and mipmaps do not bleed background into the seams.
    """
    from scipy import ndimage

    from rockdove.geometry.types import Bird, MeshPart

    res = _resolution(resolution_or_params, attr="body_texture_resolution")
    part = bird.part("Body") if isinstance(bird, Bird) else getattr(bird, "part", bird)  # Body.part
    if not isinstance(part, MeshPart):
        raise UsageError(f"bird={type(bird).__name__} must be a Bird, a Body or the Body MeshPart")
    faces = part.face_vertex_indices.reshape(-1, 3).astype(np.int64)
    st = part.st.astype(np.float64)
    points = part.points_m.astype(np.float64)
    rows, cols, face, bary = rasterize_uv(st, faces, res)
    pts = np.einsum("nk,nkd->nd", bary, points[faces[face]])
    img = np.zeros((res, res, 3), dtype=np.uint8)
    img[rows, cols] = _encode(body_colour_at(pts))
    empty = np.ones((res, res), dtype=bool)
    empty[rows, cols] = False
    strip = palette_strip(res)  # and its top row repeated over half the guard band below the body's charts
    guard = int(0.5 * res * (_pl.ATLAS_START - _pl.PALETTE_STRIP))
    strip = np.concatenate([np.repeat(strip[:1], guard, axis=0), strip])
    img[res - len(strip):], empty[res - len(strip):] = strip, False
    if empty.any():
        _, (ri, ci) = ndimage.distance_transform_edt(empty, return_indices=True)
        img = img[ri, ci]
    return img

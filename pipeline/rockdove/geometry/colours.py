"""The bird's colour field: the base colour of the body's surface at any point (blue-grey, the slate head and
neck, the white rump patch) and the palette of the feather tiles the coat, wing and tail cards sample.
:mod:`rockdove.textures` paints images from it and :mod:`rockdove.geometry.plumage` picks each coat card's tile.

The rock-dove palette follows field-guide descriptions of Columba livia (Gibbs, Barnes and Cox, "Pigeons and
Doves", 2001: blue-grey, darker head and neck, two black wing bars, a dark terminal tail band, "white lower
back"); the values are chosen by eye.
"""

from __future__ import annotations

import numpy as np

from .sdf import smoothstep

#: sRGB 8-bit palette of the body.
BODY_SRGB = (150, 158, 172)
HEAD_SRGB = (104, 110, 126)
NECK_SRGB = (84, 90, 102)
WING_SRGB = (162, 169, 181)
WING_BAR_SRGB = (28, 28, 32)
PRIMARIES_SRGB = (88, 92, 102)
TAIL_SRGB = (120, 127, 140)
RUMP_SRGB = (236, 238, 240)
#: Display colour (linear RGB) of the body and the cards that sample its texture: rock-dove blue-grey.
BODY_DISPLAY_COLOR = (0.25, 0.28, 0.33)

#: The feather tiles of the palette strip (rockdove.geometry.plumage, rockdove.textures.palette_strip): tile i
#: spans s in [i, i + 1] / TILES; tiles 0 .. RAMP - 1 are the coat's greys from the dark neck to the pale wing.
TILES = 32
RAMP = 20
T_WHITE, T_BAR, T_RECTRIX, T_PRIMARY, T_BAR2 = 20, 21, 22, 23, 24


def linear(srgb8) -> np.ndarray:
    """Linear Rec.709 of 8-bit sRGB values (colour-science's CCTF, IEC 61966-2-1)."""
    from ..srgb import srgb_decode

    return srgb_decode(np.asarray(srgb8, dtype=np.float64) / 255.0)


def mix(a, b, w):
    """``a (1 - w) + b w``, the weights ``w`` over the last axis of the colours."""
    w = np.asarray(w, dtype=np.float64)[..., None]
    return a * (1.0 - w) + b * w


def body_colour_at(points_m: np.ndarray) -> np.ndarray:
    """Linear Rec.709 base colour of the body at surface points: (N, 3) metres -> (N, 3) float64.

    Blue-grey, the dark slate head and neck, the white rump patch over the tail base. Each layer is evaluated
    only where its weight is above 0: elsewhere a mix with weight 0 would leave the colour unchanged, bit for bit.
    """
    from . import neck as _neck
    from . import sdf as _sdf

    p = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)
    col = np.broadcast_to(linear(BODY_SRGB), p.shape).copy()
    rump = 1.0 - smoothstep(0.012, 0.02, np.linalg.norm((p - np.array([0.0, 0.088, -0.062])) * [0.8, 1.2, 0.7], axis=1))
    i = np.flatnonzero(rump > 0.0)
    col[i] = mix(col[i], linear(RUMP_SRGB), rump[i])
    s, r = _neck.neck_s(p)
    near_neck = 1.0 - smoothstep(0.030, 0.05, r)
    neck_w = smoothstep(-0.45, 0.05, s) * near_neck
    i = np.flatnonzero(neck_w > 0.0)
    col[i] = mix(col[i], linear(NECK_SRGB), neck_w[i])
    head_w = 1.0 - smoothstep(-0.001, 0.006, _sdf.HEAD.sdf(p))
    head_w = np.maximum(head_w, smoothstep(1.0, 1.15, s) * near_neck)
    i = np.flatnonzero(head_w > 0.0)
    col[i] = mix(col[i], linear(HEAD_SRGB), head_w[i])
    return col


def palette_colours() -> np.ndarray:
    """(TILES, 3) linear colour of each feather tile: the grey ramp from the neck's slate to the coverts' pale
    grey, white, wing bar, rectrix and primary."""
    w = np.linspace(0.0, 1.0, RAMP)[:, None]
    out = np.broadcast_to(linear(BODY_SRGB), (TILES, 3)).copy()
    out[:RAMP] = linear(NECK_SRGB) * (1 - w) + linear(WING_SRGB) * w
    for tile, srgb in ((T_WHITE, RUMP_SRGB), (T_BAR, WING_SRGB), (T_RECTRIX, TAIL_SRGB),
                       (T_PRIMARY, PRIMARIES_SRGB), (T_BAR2, WING_SRGB)):
        out[tile] = linear(srgb)
    return out


def coat_tiles(points_m) -> np.ndarray:
    """(N,) int: the palette tile (ramp or white) nearest :func:`body_colour_at` at each point."""
    pal = palette_colours()[:T_WHITE + 1]
    col = body_colour_at(points_m)
    return np.argmin(((col[:, None, :] - pal[None]) ** 2).sum(-1), axis=1)

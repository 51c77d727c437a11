"""The bird's colour field: the base colour of the body's surface at any point (blue-grey, the slate head and
neck, the white rump patch) and the catalogue of the plumage atlas the feather cards sample (kinds, tones,
variants). :mod:`rockdove.textures` paints both and :mod:`rockdove.geometry.plumage` picks each card's tile.

The rock-dove palette follows field-guide descriptions of Columba livia (Gibbs, Barnes and Cox, "Pigeons and
Doves", 2001: blue-grey, darker head and neck, two black wing bars, a dark terminal tail band, "white lower
back"); the values are chosen by eye."""

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
EYE_SRGB = (224, 92, 32)  # the iris (orange-red)
RUMP_SRGB = (236, 238, 240)
#: Display colour (linear RGB) of the body and the cards that sample its texture: rock-dove blue-grey.
BODY_DISPLAY_COLOR = (0.25, 0.28, 0.33)

#: Feather kinds of the plumage atlas (painted by :func:`rockdove.textures.feather_tile`): v of the widest point
#: (root 0, tip 1), width at the root (of the widest), tip exponent (1 pointed, 2 round, 4 square), barbs per vane,
#: end of the downy base (v), outer vane's width (asymmetry), dark pattern (v from, v to, darkness) or None, and
#: roughness of the vane. Shapes after Lucas and Stettenheim, "Avian Anatomy: Integument" (1972): small rounded
#: head feathers with much down, ovate contour feathers, blunt secondaries, pointed asymmetric primaries.
KINDS = {
    "head": (0.40, 0.35, 2.0, 14, 0.30, 1.0, None, 0.75),
    "contour": (0.55, 0.22, 2.2, 24, 0.30, 1.0, None, 0.7),
    "neck": (0.68, 0.45, 2.0, 24, 0.12, 1.0, None, 0.7),
    "covert": (0.50, 0.3, 2.4, 24, 0.15, 1.0, None, 0.65),
    "greater": (0.55, 0.45, 2.8, 28, 0.10, 0.8, (0.50, 0.86, 1.0), 0.6),
    "secondary": (0.70, 0.65, 3.5, 40, 0.05, 0.8, (0.52, 0.70, 1.0), 0.6),
    "primary": (0.35, 0.60, 1.4, 56, 0.04, 0.5, (0.55, 1.01, 0.5), 0.55),
    "rectrix": (0.70, 0.75, 2.6, 56, 0.05, 0.9, (0.84, 1.01, 0.95), 0.6),
    "eye": (0.0, 1.0, 2.0, 0, 0.0, 1.0, None, 0.08),
}
#: Coat tones, sRGB 8-bit: the dark neck to the pale wing (contour feathers pick the nearest to the body colour).
COAT_SRGB = tuple(tuple(int(round(a + (b - a) * k / 5)) for a, b in zip(NECK_SRGB, WING_SRGB)) for k in range(6))
#: The plumage atlas, in order: (kind, sRGB tone, variants); each variant a tile of its own seed.
ATLAS = ((("head", HEAD_SRGB, 6),) + tuple(("contour", c, 4) for c in COAT_SRGB + (RUMP_SRGB,))
         + (("covert", WING_SRGB, 4), ("greater", WING_SRGB, 4), ("secondary", WING_SRGB, 4),
            ("primary", PRIMARIES_SRGB, 4), ("rectrix", TAIL_SRGB, 4), ("eye", EYE_SRGB, 1)))
#: Atlas tiles per row and rows (each tile half as wide as it is tall).
ATLAS_COLUMNS, ATLAS_ROWS = 16, 4
#: Half-width of the widest feather in its tile (u, the tile's width 1).
FEATHER_HALF_WIDTH = 0.44


def half_width(kind: str, v) -> np.ndarray:
    """The outline of a feather of ``kind`` (:data:`KINDS`): its vane's half-width in u (tile widths) at ``v``
    (root 0 .. tip 1): widening from the root to the widest point, then closing to the tip as
    ``(1 - t^p)^(1/p)`` (p the tip exponent)."""
    widest, base_w, tip_p = KINDS[kind][:3]
    v = np.asarray(v, np.float64)
    t = np.clip((v - widest) / (1.0 - widest), 0.0, 1.0)
    w = np.where(v < widest, base_w + (1.0 - base_w) * np.sin(0.5 * np.pi * np.clip(v / max(widest, 1e-6), 0, 1)),
                 np.clip(1.0 - t ** tip_p, 0.0, 1.0) ** (1.0 / tip_p))
    return FEATHER_HALF_WIDTH * w


def atlas_st(tiles, u, v) -> np.ndarray:
    """(..., 2) st in the atlas of feather coordinates ``u`` (across, 0 .. 1) and ``v`` (root 0 .. tip 1) on
    ``tiles`` (broadcast together), kept half a per cent inside the tile (no filtering across its border)."""
    col, row = np.asarray(tiles) % ATLAS_COLUMNS, np.asarray(tiles) // ATLAS_COLUMNS
    u, v = np.clip(u, 0.005, 0.995), np.clip(v, 0.005, 0.995)
    return np.stack(np.broadcast_arrays((col + u) / ATLAS_COLUMNS, 1.0 - (row + 1.0 - v) / ATLAS_ROWS), -1)


#: The first tile of each (kind, tone) of :data:`ATLAS`, and its number of variants.
TILE_START = {(k, c): (int(i), n) for (k, c, n), i in zip(ATLAS, np.cumsum([0] + [n for *_, n in ATLAS]))}


def linear(srgb8) -> np.ndarray:
    """Linear Rec.709 of 8-bit sRGB values (colour-science's CCTF, IEC 61966-2-1)."""
    from ..srgb import srgb_decode

    return srgb_decode(np.asarray(srgb8, dtype=np.float64) / 255.0)


def mix(a, b, w):
    """``a (1 - w) + b w``, the weights ``w`` over the last axis of the colours."""
    w = np.asarray(w, dtype=np.float64)[..., None]
    return a * (1.0 - w) + b * w


def body_colour_at(points_m: np.ndarray) -> np.ndarray:
    """Linear Rec.709 base colour of the body at surface points: (N, 3) metres -> (N, 3) float64. Blue-grey, the dark
    slate head and neck, the white rump patch over the tail base. Each layer is evaluated only where its weight is above
    0: elsewhere a mix with weight 0 would leave the colour unchanged, bit for bit."""
    from . import neck as _neck
    from . import sdf as _sdf

    p = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)
    col = np.broadcast_to(linear(BODY_SRGB), p.shape).copy()
    rump = 1.0 - smoothstep(0.014, 0.024, np.linalg.norm((p - [0.0, 0.092, -0.058]) * [0.8, 1.2, 0.7], axis=1))
    s, r = _neck.neck_s(p)
    near_neck = 1.0 - smoothstep(0.030, 0.05, r)
    head = np.maximum(1.0 - smoothstep(-0.001, 0.006, _sdf.HEAD.sdf(p)), smoothstep(1.0, 1.15, s) * near_neck)
    for srgb, w in ((RUMP_SRGB, rump), (NECK_SRGB, smoothstep(-0.45, 0.05, s) * near_neck), (HEAD_SRGB, head)):
        i = np.flatnonzero(w > 0.0)
        col[i] = mix(col[i], linear(srgb), w[i])
    return col


def coat_tiles(points_m, rng) -> np.ndarray:
    """(N,) int: an atlas tile of the contour feather whose tone (:data:`COAT_SRGB`, the white rump) is nearest
    :func:`body_colour_at` at each point, its variant drawn from ``rng``."""
    tones = COAT_SRGB + (RUMP_SRGB,)
    dist = ((body_colour_at(points_m)[:, None, :] - linear(tones)[None]) ** 2).sum(-1)
    start = np.array([TILE_START["contour", t][0] for t in tones])[np.argmin(dist, axis=1)]
    return start + rng.integers(0, 4, len(start))

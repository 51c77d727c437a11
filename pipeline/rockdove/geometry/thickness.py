"""The film-thickness field on the neck feather cards.

Measured rock-dove barbule cortex: 480-580 nm at the base of the neck, 600-700 nm towards the top (Yoshioka, Nakamura
and Kinoshita, J. Phys. Soc. Jpn. 76(1), 2007). The field is the base-to-top gradient along the neck height h, plus a
smooth random field over the neck *surface*, plus a small per-card jitter, clipped to the configured range at that h:

    h = clip((y - y_base) / (y_top - y_base), 0, 1)   (y: height of the card's root; y_base, y_top: heights of
                                                      the ends of the neck axis, sdf.NECK_BASE_M, NECK_TOP_M)
    g(h) = 3 h^2 - 2 h^3                              (smoothstep: flat at both ends of the neck)
    lo(h) = base_lo + g(h) (top_lo - base_lo),  hi(h) = base_hi + g(h) (top_hi - base_hi)
    d = clip(m(h) + spread w(h) f(p) + jitter_nm e,  lo(h), hi(h))
        m(h) = (lo + hi) / 2,  w(h) = (hi - lo) / 2,  e ~ N(0, 1) per card

The gradient runs with height, not with the projection s on the leaning neck axis (``neckS``): the band's rings about
that axis are far from level (the front of a ring lies ~2 cm below its back), so a gradient along s correlates with the
root height only at ~0.6, and the measured change is from the lower neck to the throat and nape below the head.

f(p) is a zero-mean, unit-variance Gaussian random field at each card's root p, with the squared-exponential
covariance exp(-|p - p'|^2 / (2 l^2)), drawn by random Fourier features (Rahimi and Recht, "Random Features for
Large-Scale Kernel Machines", NIPS 2007): f(p) = sqrt(2 / M) sum_k cos(w_k . p + b_k), w_k ~ N(0, I / l^2),
b_k ~ U(0, 2 pi), whose covariance tends to the kernel's as M grows (Bochner's theorem). The straight distance
between skin points is within a few per cent of the distance along the neck's skin (radius ~2 cm) for l up to
~1 cm, and depends on no UV layout. So neighbouring cards share their colour (coherent green and purple regions),
every value stays inside the ranges, and with both ranges (650, 650) (the seed paper's) every card is 650 nm.

The thickness is constant over each card: a card stands for one feather, whose barbules grow together, and the
structural colour is drawn only at the tip (the mask), so a root-to-tip ramp would show on no visible pixel."""

from __future__ import annotations

import numpy as np

from rockdove.geometry import sdf as _sdf

#: Random Fourier features M of the smooth field (its marginal is within ~1/M of a normal's).
FIELD_FEATURES = 256
#: Cards evaluated per block (bounds the (block, M) temporary to ~16 MB).
FIELD_BLOCK = 8192


def neck_height(points_m: np.ndarray) -> np.ndarray:
    """(N,) float64 height coordinate h in [0, 1] of (N, 3) points: 0 at the height of the neck's base, 1 at its top."""
    y = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)[:, 1]
    y0, y1 = float(_sdf.NECK_BASE_M[1]), float(_sdf.NECK_TOP_M[1])
    return np.clip((y - y0) / (y1 - y0), 0.0, 1.0)


def thickness_bounds_nm(s: np.ndarray, base_nm, top_nm) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (N,) float64 thickness bounds, nm, at neck heights ``s`` (:func:`neck_height`) for the (min, max)
    ranges ``base_nm`` at s = 0 and ``top_nm`` at s = 1."""
    g = _sdf.smoothstep(0.0, 1.0, s)
    return base_nm[0] + g * (top_nm[0] - base_nm[0]), base_nm[1] + g * (top_nm[1] - base_nm[1])


def smooth_field(points_m: np.ndarray, correlation_length_m: float, rng: np.random.Generator) -> np.ndarray:
    """(N,) a zero-mean, unit-variance Gaussian random field of correlation length l (metres) at (N, 3) points, by
    :data:`FIELD_FEATURES` random Fourier features whose frequencies and phases ``rng`` draws (module docstring)."""
    p = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)
    w = rng.standard_normal((3, FIELD_FEATURES)) / float(correlation_length_m)  # (3, M) rad/m
    b = rng.uniform(0.0, 2.0 * np.pi, FIELD_FEATURES)
    out = np.empty(len(p))
    for start in range(0, len(p), FIELD_BLOCK):
        out[start:start + FIELD_BLOCK] = np.cos(p[start:start + FIELD_BLOCK] @ w + b).sum(axis=1)
    return out * np.sqrt(2.0 / FIELD_FEATURES)


def thickness_field(roots_m: np.ndarray, params, rng: np.random.Generator) -> np.ndarray:
    """(N, 3) float64 per card rooted at ``roots_m``: its neck height h, the smooth field in half-widths of the
    range (``spread f(p)``) and its jitter, nm: the thickness before the ranges place it (:func:`place_thickness_nm`);
    ``rng`` draws the field, then the jitter."""
    s = neck_height(roots_m)
    z = np.zeros(len(s))
    if params.thickness_spread > 0:
        z = params.thickness_spread * smooth_field(roots_m, params.thickness_correlation_length_m, rng)
    return np.stack([s, z, params.thickness_jitter_nm * rng.standard_normal(len(s))], axis=1)


def place_thickness_nm(field: np.ndarray, base_nm, top_nm) -> np.ndarray:
    """(N,) float64 thickness, nm, of cards with :func:`thickness_field` ``field`` for the ranges ``base_nm`` and
    ``top_nm``: ``clip(m(h) + w(h) z + jitter, lo(h), hi(h))`` (module docstring)."""
    lo, hi = thickness_bounds_nm(field[:, 0], base_nm, top_nm)
    return np.clip(0.5 * (lo + hi) + 0.5 * (hi - lo) * field[:, 1] + field[:, 2], lo, hi)


"""The film-thickness field on the neck feather cards.

Measured rock-dove barbule cortex: 480-580 nm at the base of the neck, 600-700 nm towards the top (Yoshioka,
Nakamura and Kinoshita, J. Phys. Soc. Jpn. 76(1), 2007, via ../shared/reference/method.md). The field is the
base-to-top gradient along the neck height h, plus a smooth random field over the neck *surface*, plus a
small per-card jitter, clipped to the configured range at that h:

    h = clip((y - y_base) / (y_top - y_base), 0, 1)   (y: height of the card's root; y_base, y_top: heights of
                                                      the ends of the neck axis, sdf.NECK_BASE_M, NECK_TOP_M)
    g(h) = 3 h^2 - 2 h^3                              (smoothstep: flat at both ends of the neck)
    lo(h) = base_lo + g(h) (top_lo - base_lo),  hi(h) = base_hi + g(h) (top_hi - base_hi)
    d = clip(m(h) + spread w(h) f(p) + jitter_nm e,  lo(h), hi(h))
        m(h) = (lo + hi) / 2,  w(h) = (hi - lo) / 2

The gradient runs with height, not with the projection s on the leaning neck axis (the ``neckS`` primvar): the
band's rings about that axis are far from level (the front of a ring lies ~2 cm below its back), so a gradient
along s correlates with the root height only at ~0.6, and the base-to-top change of the measured bird is a
change from the lower neck to the throat and nape below the head.

- f(p) is a zero-mean, unit-variance Gaussian random field evaluated at each card's root p on the skin, with
  the squared-exponential covariance exp(-|p - p'|^2 / (2 l^2)) of correlation length l (metres). It is drawn
  by random Fourier features (Rahimi and Recht, "Random Features for Large-Scale Kernel Machines", NIPS 2007):
  f(p) = sqrt(2 / M) sum_k cos(w_k . p + b_k), w_k ~ N(0, I / l^2), b_k ~ U(0, 2 pi), whose covariance tends
  to the kernel's as M grows (Bochner's theorem). The distance is the straight one between skin points, which
  on the neck (radius ~2 cm) is within a few per cent of the distance along the skin for l up to ~1 cm, and
  never depends on a UV layout. O(N M): vectorised, 100,000 cards in well under a second.
- ``spread`` (dimensionless) is the field's standard deviation as a fraction of the half-width w(s) of the
  range at that height; e ~ N(0, 1) per card, ``jitter_nm`` its standard deviation.

Neighbouring cards therefore share their colour (coherent green and purple regions whose boundary bends),
every value stays inside the configured ranges, the same seed gives the same field, and with both ranges
(650, 650) (the seed paper's preset) every card is exactly 650 nm.

The thickness is constant over each card (s taken at the card's root): a card stands for one feather, whose
barbules grow together, and the structural colour is only drawn at the tip (the mask), so a root-to-tip ramp
would show on no visible pixel; a constant also keeps the paper's straight colour boundary reproducible.
"""

from __future__ import annotations

import numpy as np

from rockdove.geometry import sdf as _sdf
from rockdove.geometry.params import DEFAULT_CORRELATION_LENGTH_M, DEFAULT_JITTER_NM, DEFAULT_SPREAD

#: Random Fourier features M of the smooth field (its marginal is within ~1/M of a normal's).
FIELD_FEATURES = 256
#: Cards evaluated per block (bounds the (block, M) temporary to ~16 MB).
FIELD_BLOCK = 8192


def smoothstep(s: np.ndarray) -> np.ndarray:
    """3 s^2 - 2 s^3 of s clipped to [0, 1]."""
    s = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def neck_height(points_m: np.ndarray) -> np.ndarray:
    """(N,) float64 height coordinate h in [0, 1] of (N, 3) points: 0 at the height of the neck's base, 1 at its top."""
    y = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)[:, 1]
    y0, y1 = float(_sdf.NECK_BASE_M[1]), float(_sdf.NECK_TOP_M[1])
    return np.clip((y - y0) / (y1 - y0), 0.0, 1.0)


def thickness_bounds_nm(s: np.ndarray, base_nm, top_nm) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper thickness bound at neck height ``s`` (:func:`neck_height`), nm.

    Parameters
    ----------
    s : np.ndarray
        (N,) neck height coordinate (clipped to [0, 1]).
    base_nm, top_nm : (float, float)
        (min, max) thickness at s = 0 and at s = 1, nm.

    Returns
    -------
    lo_nm, hi_nm : np.ndarray
        (N,) float64.
    """
    g = smoothstep(s)
    lo = base_nm[0] + g * (top_nm[0] - base_nm[0])
    hi = base_nm[1] + g * (top_nm[1] - base_nm[1])
    return lo, hi


def smooth_field(points_m: np.ndarray, correlation_length_m: float, rng: np.random.Generator,
                 features: int = FIELD_FEATURES) -> np.ndarray:
    """A zero-mean, unit-variance Gaussian random field at points, by random Fourier features.

    Covariance exp(-|p - p'|^2 / (2 l^2)) (Rahimi and Recht 2007; see the module docstring).

    Parameters
    ----------
    points_m : np.ndarray
        (N, 3) points, metres (the card roots on the skin).
    correlation_length_m : float
        l, metres, > 0.
    rng : np.random.Generator
        Draws the M frequencies and phases (nothing per point: the field is a function of position).
    features : int
        M.

    Returns
    -------
    np.ndarray
        (N,) float64.
    """
    if not (np.isfinite(correlation_length_m) and correlation_length_m > 0):
        raise ValueError(f"correlation_length_m={correlation_length_m!r} must be a finite length > 0, in metres")
    p = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)
    w = rng.standard_normal((3, features)) / float(correlation_length_m)  # (3, M) rad/m
    b = rng.uniform(0.0, 2.0 * np.pi, features)
    out = np.empty(len(p))
    for start in range(0, len(p), FIELD_BLOCK):
        phase = p[start:start + FIELD_BLOCK] @ w + b
        out[start:start + FIELD_BLOCK] = np.cos(phase).sum(axis=1)
    return out * np.sqrt(2.0 / features)


def card_thickness_nm(s: np.ndarray, base_nm, top_nm, rng: np.random.Generator, points_m=None,
                      correlation_length_m: float = DEFAULT_CORRELATION_LENGTH_M,
                      spread: float = DEFAULT_SPREAD, jitter_nm: float = DEFAULT_JITTER_NM) -> np.ndarray:
    """Film thickness of each card, nm: gradient with height + smooth field over the skin + jitter, within range.

    Parameters
    ----------
    s : np.ndarray
        (N,) neck height of each card's root (:func:`neck_height`), in [0, 1].
    base_nm, top_nm : (float, float)
        (min, max) at the base and at the top of the neck, nm (min <= max).
    rng : np.random.Generator
        Source of the field's frequencies and of the per-card jitter (drawn in that order).
    points_m : np.ndarray, optional
        (N, 3) card roots on the skin, metres; required when ``spread > 0``.
    correlation_length_m : float
        Correlation length of the smooth field, metres.
    spread : float
        Standard deviation of the smooth field as a fraction of the range's half-width at that s, >= 0.
    jitter_nm : float
        Standard deviation of the independent per-card jitter, nm, >= 0.

    Returns
    -------
    np.ndarray
        (N,) float32, nm.
    """
    for name, r in (("base_nm", base_nm), ("top_nm", top_nm)):
        if len(r) != 2 or not r[0] <= r[1]:
            raise ValueError(f"{name}={r!r} must be a (min, max) pair with min <= max, in nm")
    for name, v in (("spread", spread), ("jitter_nm", jitter_nm)):
        if not (np.isfinite(v) and v >= 0):
            raise ValueError(f"{name}={v!r} must be a finite number >= 0")
    s = np.asarray(s, dtype=np.float64).reshape(-1)
    lo, hi = thickness_bounds_nm(s, base_nm, top_nm)
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    d = mid.copy()
    if spread > 0:
        if points_m is None or np.shape(points_m) != (len(s), 3):
            raise ValueError(f"points_m must be the (N, 3) card roots (N = {len(s)}) when spread > 0")
        d += spread * half * smooth_field(points_m, correlation_length_m, rng)
    d += jitter_nm * rng.standard_normal(len(s))
    return np.clip(d, lo, hi).astype(np.float32)


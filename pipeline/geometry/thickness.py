"""The film-thickness field on the neck feather cards.

Measured rock-dove barbule cortex: 480-580 nm at the base of the neck, 600-700 nm towards the top (Yoshioka,
Nakamura and Kinoshita, J. Phys. Soc. Jpn. 76(1), 2007, via ../shared/reference/method.md). The field is a
smooth gradient along the neck coordinate s plus seeded per-card variation within the range at that s:

    g(s) = 3 s^2 - 2 s^3                         (smoothstep: flat at both ends of the neck)
    lo(s) = base_lo + g(s) (top_lo - base_lo),  hi(s) = base_hi + g(s) (top_hi - base_hi)
    d = lo(s) + u (hi(s) - lo(s)),              u ~ U(0, 1) per card, seeded

so the mean over cards at s is the mid-range line, which rises along s when the top range lies above the base
range, and every value stays inside the configured ranges. With both ranges (650, 650) (the seed paper's
preset) every card is exactly 650 nm.

The thickness is constant over each card (s taken at the card's root): a card stands for one feather, whose
barbules grow together, and the structural colour is only drawn at the tip (the mask), so a root-to-tip ramp
would show on no visible pixel; a constant also keeps the paper's straight colour boundary reproducible.
"""

from __future__ import annotations

import numpy as np


def smoothstep(s: np.ndarray) -> np.ndarray:
    """3 s^2 - 2 s^3 of s clipped to [0, 1]."""
    s = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def thickness_bounds_nm(s: np.ndarray, base_nm, top_nm) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper thickness bound at neck coordinate ``s``, nm.

    Parameters
    ----------
    s : np.ndarray
        (N,) neck coordinate (clipped to [0, 1]).
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


def card_thickness_nm(s: np.ndarray, base_nm, top_nm, rng: np.random.Generator) -> np.ndarray:
    """Film thickness of each card, nm: the gradient along s plus seeded variation within the range.

    Parameters
    ----------
    s : np.ndarray
        (N,) neck coordinate of each card's root, in [0, 1].
    base_nm, top_nm : (float, float)
        (min, max) at the base and at the top of the neck, nm (min <= max).
    rng : np.random.Generator
        Source of the per-card variation u ~ U(0, 1).

    Returns
    -------
    np.ndarray
        (N,) float32, nm.
    """
    for name, r in (("base_nm", base_nm), ("top_nm", top_nm)):
        if len(r) != 2 or not r[0] <= r[1]:
            raise ValueError(f"{name}={r!r} must be a (min, max) pair with min <= max, in nm")
    lo, hi = thickness_bounds_nm(s, base_nm, top_nm)
    u = rng.random(np.shape(s))
    return (lo + u * (hi - lo)).astype(np.float32)

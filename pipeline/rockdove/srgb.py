"""The sRGB transfer functions (IEC 61966-2-1:1999) and the exact 8-bit display encoding of linear Rec.709
(tested against colour-science's ``cctf_encoding/decoding``, tests/test_spectral.py; re-exported by spectral)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np


def srgb_encode(linear) -> np.ndarray:
    """sRGB OETF (IEC 61966-2-1:1999, eq. 5): ``12.92 L`` for L <= 0.0031308, else ``1.055 L^(1/2.4) - 0.055``.
    Values below 0 are not clipped (the linear segment continues)."""
    x = np.asarray(linear, dtype=np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 0.0031308), 1.0 / 2.4) - 0.055)


def srgb_decode(encoded) -> np.ndarray:
    """Inverse of :func:`srgb_encode` (IEC 61966-2-1:1999, eq. 2): ``V / 12.92`` at or below the encoded break
    point ``12.92 * 0.0031308`` (= 0.04044994; the standard rounds it to 0.04045, colour-science uses this
    exact one, and no 8-bit value lies between them), else ``((V + 0.055) / 1.055)^2.4``."""
    v = np.asarray(encoded, dtype=np.float64)
    knee = 12.92 * 0.0031308
    return np.where(v <= knee, v / 12.92, np.power((np.maximum(v, knee) + 0.055) / 1.055, 2.4))


def linear_to_srgb8(rgb) -> np.ndarray:
    """(..., 3) linear lin_rec709 -> (..., 3) uint8: sRGB OETF (IEC 61966-2-1) of the value clipped to [0, 1].
    docs/design.md's display transform for GL renders, reference renders and textures alike (NaN shows as black). The
    code ``round(255 * srgb_encode(clip(v, 0, 1)))`` is a step function of ``v`` with 255 steps at least 3e-4 apart
    (:func:`_srgb8_steps`), so [0, 1] is cut into :data:`_SRGB8_CELLS` cells with at most one step each
    (:func:`_srgb8_cells`): a value's code is its cell's, plus one at or above the cell's step. That gives the formula's
    codes for every float64 and float32, 8.7-9x faster than a binary search among the steps."""
    rgb = np.asarray(rgb)
    if rgb.dtype != np.float32:
        rgb = np.asarray(rgb, dtype=np.float64)
    code_at, step = _srgb8_cells(rgb.dtype)
    flat = rgb.reshape(-1)
    out = np.empty(flat.shape, np.uint8)
    block = max(1, min(_SRGB8_BLOCK, flat.size))
    scaled = np.empty(block, rgb.dtype)
    cell = np.empty(block, np.intp)
    step_of = np.empty(block, rgb.dtype)
    above = np.empty(block, bool)
    with np.errstate(over="ignore"):
        for start in range(0, flat.size, block):
            v = flat[start:start + block]
            n = v.size
            x, c, s, a, o = scaled[:n], cell[:n], step_of[:n], above[:n], out[start:start + n]
            np.multiply(v, _SRGB8_CELLS, out=x)  # exact (a power of two); beyond the float range: inf
            np.fmax(x, 0, out=x)  # NaN, -inf and negatives -> cell 0 (NaN then never compares >= a step)
            np.fmin(x, _SRGB8_CELLS - 1, out=x)  # 1, above 1 and +inf -> the last cell
            c[...] = x  # truncation = floor (x >= 0)
            code_at.take(c, out=o, mode="clip")
            step.take(c, out=s, mode="clip")
            np.greater_equal(v, s, out=a)  # False against NaN, the step of a cell without one
            np.add(o, a, out=o)
    return out.reshape(rgb.shape)


_SRGB8_CELLS = 1 << 14  # cells over [0, 1]: 6.1e-5 wide, 5 times narrower than the closest two steps
_SRGB8_BLOCK = 1 << 16  # values per block of linear_to_srgb8 (its scratch arrays stay in the cache)


@lru_cache(maxsize=2)
def _srgb8_cells(dtype) -> tuple[np.ndarray, np.ndarray]:
    """(code_at, step), each (_SRGB8_CELLS,), for :func:`linear_to_srgb8` on ``dtype`` (float64 or float32)
    values. Cell ``c`` holds the values in ``[c, c + 1) / _SRGB8_CELLS``; ``code_at[c]`` is the code at its
    start (the number of steps at or below it), ``step[c]`` the one step strictly inside it, NaN if none.
    For float32 the steps are the smallest float32s at or above the float64 steps, so that comparing a float32
    with them is comparing its exact float64 value with the float64 steps."""
    steps = _srgb8_steps()
    if np.dtype(dtype) == np.float32:
        steps32 = steps.astype(np.float32)
        steps32 = np.where(steps32.astype(np.float64) < steps, np.nextafter(steps32, np.float32(2.0)), steps32)
        steps = steps32.astype(np.float64)
    edges = np.arange(_SRGB8_CELLS + 1, dtype=np.float64) / _SRGB8_CELLS
    code_at = np.searchsorted(steps, edges[:-1], side="right")
    inside = np.searchsorted(steps, edges[1:], side="left") - code_at
    if inside.max() > 1:  # a property of the sRGB curve and _SRGB8_CELLS
        raise AssertionError("two sRGB 8-bit steps in one cell; use more cells")
    step = np.full(_SRGB8_CELLS, np.nan, dtype)
    step[inside == 1] = steps[code_at[inside == 1]]
    code_at = code_at.astype(np.uint8)
    code_at.setflags(write=False)
    step.setflags(write=False)
    return code_at, step


def _srgb8_code(v) -> np.ndarray:
    """The 8-bit code of linear values by the formula itself (:func:`linear_to_srgb8`'s definition)."""
    return np.round(np.clip(srgb_encode(np.clip(v, 0.0, 1.0)), 0.0, 1.0) * 255.0)


@lru_cache(maxsize=1)
def _srgb8_steps() -> np.ndarray:
    """(255,) float64: entry k - 1 is the smallest linear value whose code is >= k. Bisection over the ordered
    bit patterns of the non-negative float64s in [0, 1], so each step is exact to the last bit."""
    lo = np.zeros(255, np.int64)  # code(lo) < k
    hi = np.full(255, np.float64(1.0).view(np.int64))  # code(hi) >= k
    k = np.arange(1, 256)
    while np.any(hi - lo > 1):
        mid = lo + (hi - lo) // 2
        above = _srgb8_code(mid.view(np.float64)) >= k
        hi, lo = np.where(above, mid, hi), np.where(above, lo, mid)
    steps = hi.view(np.float64)
    steps.setflags(write=False)
    return steps

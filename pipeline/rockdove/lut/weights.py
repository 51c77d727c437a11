"""Colour weights of the 0.1 nm reference grid, and product-integration weights built on them.

``colour_weights(wl)`` are :func:`rockdove.spectral.spectral_weights`: ``R @ W`` is the linear colour of a spectrum
``R`` sampled on ``wl``. The other rules sample the spectrum more coarsely and integrate its interpolant against
the 0.1 nm grid's weights (product integration: Davis and Rabinowitz, Methods of Numerical Integration, 2nd ed.,
sec. 2.5), so the tabulated observer and illuminant are never undersampled and a spectrum the interpolant
reproduces integrates to exactly the 0.1 nm reference: :func:`product_weights` (4-point Lagrange on a coarser
wavelength grid), :func:`interpolant_weights` (``order``-point Lagrange on a wavenumber grid, the stencils running
past both ends) and :func:`chebyshev_weights` (mapped Chebyshev points in wavenumber, :mod:`.quadrature`)."""

from __future__ import annotations

import functools

import numpy as np

from ..errors import UsageError
from ..spectral import WAVELENGTH_RANGE_NM, colour_data, spectral_weights

#: The exact reference's wavelength step away from grazing (cos theta >= 0.003), nm; the bakers' grid.
REFERENCE_STEP_NM = 0.1
ILLUMINANTS = ("D65",)
#: Points of the Lagrange stencil of the wavenumber interpolant (:func:`interpolant_weights`), even.
INTERPOLANT_ORDER = 16
# Kosloff-Tal-Ezer map parameter alpha = sech(ln(1 / MAP_EPS) / (N - 1)) (Hale & Trefethen 2008).
MAP_EPS = 1e-9
# Elements of the (nodes x reference wavelengths) Cauchy matrix per block of chebyshev_weights, / 4.
_CHUNK_SAMPLES = 1 << 19


def check_illuminant(illuminant) -> str:
    if illuminant not in ILLUMINANTS:
        raise UsageError(f"illuminant must be one of {list(ILLUMINANTS)}, got {illuminant!r}")
    return illuminant


@functools.lru_cache(maxsize=16)
def reference_wavelengths(step_nm: float = REFERENCE_STEP_NM) -> np.ndarray:
    """The uniform grid over :data:`rockdove.spectral.WAVELENGTH_RANGE_NM` every ``step_nm`` nm (default 0.1 nm:
    shape (4201,)), read-only."""
    lo, hi = WAVELENGTH_RANGE_NM
    wl = np.linspace(lo, hi, int(round((hi - lo) / step_nm)) + 1)
    wl.setflags(write=False)
    return wl


@functools.lru_cache(maxsize=32)
def _weights_cached(key: bytes, n: int, illuminant: str, colour_space: str | None) -> np.ndarray:
    wl = np.frombuffer(key, dtype=np.float64, count=n)
    w = np.ascontiguousarray(spectral_weights(wl, illuminant=illuminant, colour_space=colour_space),
                             dtype=np.float64)
    w.setflags(write=False)
    return w


def colour_weights(wavelength_nm, *, illuminant: str = "D65", colour_space: str | None = "lin_rec709") -> np.ndarray:
    """Colour weights ``W`` (shape (N, 3)) with ``R @ W`` = linear colour; cached per grid (read-only)."""
    wl = np.ascontiguousarray(wavelength_nm, dtype=np.float64)
    return _weights_cached(wl.tobytes(), wl.shape[0], illuminant, colour_space)


def sigma_range() -> tuple[float, float]:
    """The wavenumbers ``(1 / 780, 1 / 360)`` nm^-1 of :data:`rockdove.spectral.WAVELENGTH_RANGE_NM`, increasing."""
    lo, hi = WAVELENGTH_RANGE_NM
    return 1.0 / hi, 1.0 / lo


def _stencil_weights(t, k0, order, w_fine, size):
    """Weights (size, 3) integrating the ``order``-point Lagrange interpolant on nodes ``k0 .. k0 + order - 1``
    (node coordinate ``t`` of each fine wavelength) against the fine grid's weights ``w_fine``."""
    x = t - k0  # position in the stencil
    lagrange = np.ones((order, t.size))
    for j in range(order):
        for m in range(order):
            if m != j:
                lagrange[j] *= (x - m) / (j - m)
    index = (k0[None, :] + np.arange(order)[:, None]).ravel()
    out = np.stack([np.bincount(index, weights=(lagrange * w_fine[:, ch]).ravel(), minlength=size)
                    for ch in range(w_fine.shape[1])], axis=1)
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=32)
def product_weights(step_nm: float, *, illuminant: str = "D65", colour_space: str | None = "lin_rec709") -> np.ndarray:
    """Colour weights (N, 3) of the ``step_nm`` grid with ``R_coarse @ W == R_fine @ colour_weights(0.1 nm grid)``,
    ``R_fine`` interpolated from ``R_coarse`` with the 4-point stencil nearest each wavelength (one-sided at the
    ends). Cached per step (read-only)."""
    step_nm = float(step_nm)
    fine = reference_wavelengths(REFERENCE_STEP_NM)
    coarse = reference_wavelengths(step_nm)
    if coarse.size < 4 or not np.isclose(coarse[1] - coarse[0], step_nm):
        raise UsageError(f"step_nm must divide the wavelength range into at least 3 steps, got {step_nm!r}")
    t = (fine - coarse[0]) / (coarse[1] - coarse[0])
    k0 = np.clip(np.floor(t).astype(np.int64) - 1, 0, coarse.size - 4)
    return _stencil_weights(t, k0, 4, colour_weights(fine, illuminant=illuminant, colour_space=colour_space),
                            coarse.size)


@functools.lru_cache(maxsize=64)
def wavenumber_nodes(n_intervals: int, order: int = INTERPOLANT_ORDER) -> np.ndarray:
    """Wavelengths (nm, increasing, read-only) whose wavenumbers ``1 / lambda`` split
    :data:`rockdove.spectral.WAVELENGTH_RANGE_NM` into ``n_intervals`` equal intervals, plus ``order / 2 - 1`` nodes
    beyond each end so that every ``order``-point stencil is centred (``n_intervals + order - 1`` nodes)."""
    s_lo, s_hi = sigma_range()
    n, ext = int(n_intervals), int(order) // 2 - 1
    wl = 1.0 / (s_hi - (s_hi - s_lo) * (np.arange(-ext, n + ext + 1) / n))
    wl[ext], wl[ext + n] = WAVELENGTH_RANGE_NM
    wl.setflags(write=False)
    return wl


@functools.lru_cache(maxsize=64)
def interpolant_weights(n_intervals: int, order: int = INTERPOLANT_ORDER, *, illuminant: str = "D65",
                        colour_space: str | None = "lin_rec709") -> np.ndarray:
    """Colour weights (n_intervals + order - 1, 3), one row per node of :func:`wavenumber_nodes`, integrating the
    spectrum's piecewise ``order``-point Lagrange interpolant in wavenumber (each wavelength's interval's centred
    stencil) against the 0.1 nm grid's weights. Cached (read-only)."""
    n, order = int(n_intervals), int(order)
    check_illuminant(illuminant)
    if order < 2 or order % 2 or n < 1:
        raise UsageError(f"order must be even and >= 2 and n_intervals >= 1, got order {order!r}, n_intervals {n!r}")
    fine = reference_wavelengths(REFERENCE_STEP_NM)
    s_lo, s_hi = sigma_range()
    ext = order // 2 - 1
    t = (s_hi - 1.0 / fine) * (n / (s_hi - s_lo)) + ext  # node index of each fine wavelength (increasing lambda)
    k0 = np.minimum(np.floor(t).astype(np.int64) - ext, n - 1)  # centred (the last interval's at 780 nm)
    return _stencil_weights(t, k0, order, colour_weights(fine, illuminant=illuminant, colour_space=colour_space),
                            n + 2 * ext + 1)


def map_alpha(n_nodes: int) -> float:
    """Kosloff-Tal-Ezer parameter for ``n_nodes`` points (0 for ``n_nodes < 3``: plain Chebyshev points)."""
    return 0.0 if n_nodes < 3 else float(1.0 / np.cosh(np.log(1.0 / MAP_EPS) / (n_nodes - 1)))


def _mapped(y, alpha):
    """x(y) of the Kosloff-Tal-Ezer map, [-1, 1] -> [-1, 1]."""
    return y if alpha == 0.0 else np.arcsin(alpha * y) / np.arcsin(alpha)


def _unmapped(x, alpha):
    return x if alpha == 0.0 else np.sin(x * np.arcsin(alpha)) / alpha


def chebyshev(n):
    """Chebyshev points of the second kind ``cos(pi j / (n - 1))``, their barycentric weights (-1)^j, ends halved."""
    j = np.arange(n)
    v = (-1.0) ** j
    v[[0, -1]] *= 0.5
    return np.cos(np.pi * j / (n - 1)), v


@functools.lru_cache(maxsize=64)
def chebyshev_weights(n_nodes: int, illuminant: str = "D65", colour_space: str | None = "lin_rec709"):
    """``(wavelength_nm, weights)`` of ``n_nodes >= 2`` mapped Chebyshev points in wavenumber: wavelengths
    ``1 / sigma_k`` increasing, (n_nodes,), and ``Omega_k = sum_l W_l l_k(sigma_l)``, (n_nodes, 3), with ``W`` the
    0.1 nm reference weights, so ``R(nodes) @ weights`` is the reference integral of the interpolant of ``R``.
    Read-only; cached per process and on disk (:func:`rockdove.spectral.colour_data`, keyed by the code)."""
    n = int(n_nodes)
    if n < 2:
        raise UsageError(f"n_nodes must be >= 2, got {n_nodes!r}")
    keys = ("wavelength_nm", "weights")
    found = colour_data(f"product-weights-{n}-{illuminant}-{colour_space}",
                        lambda: dict(zip(keys, _chebyshev_weights(n, illuminant, colour_space))), keys)
    return found["wavelength_nm"], found["weights"]


def _chebyshev_weights(n: int, illuminant: str, colour_space: str | None):
    s_lo, s_hi = sigma_range()
    mid, half = 0.5 * (s_hi + s_lo), 0.5 * (s_hi - s_lo)
    alpha = map_alpha(n)
    y, v = chebyshev(n)
    wl_ref = reference_wavelengths()
    w_ref = colour_weights(wl_ref, illuminant=illuminant, colour_space=colour_space)
    y_ref = _unmapped(np.clip((1.0 / wl_ref - mid) / half, -1.0, 1.0), alpha)
    # l_k(y_l) = (v_k / (y_l - y_k)) / s_l, s_l = sum_j v_j / (y_l - y_j) (barycentric formula of the second
    # kind), so Omega_k = v_k sum_l (W_l / s_l) / (y_l - y_k): two passes over the (n, L) Cauchy matrix
    omega = np.zeros((n, 3))
    block = max(64, _CHUNK_SAMPLES // (4 * n))  # reference wavelengths per block: the (n, block) matrix stays small
    for l0 in range(0, y_ref.shape[0], block):
        inv = y_ref[None, l0 : l0 + block] - y[:, None]  # (n, B)
        hit = inv == 0.0
        inv[hit] = 1.0
        np.divide(1.0, inv, out=inv)
        s = v @ inv  # (B,)
        on_node = hit.any(axis=0)
        s[on_node] = 1.0
        u = w_ref[l0 : l0 + block] / s[:, None]
        u[on_node] = 0.0
        omega += inv @ u
        if on_node.any():  # reference wavelengths that are nodes: l_k(y_l) = delta_kl
            k_hit, l_hit = np.nonzero(hit)
            np.add.at(omega, k_hit, w_ref[l0 + l_hit] / v[k_hit, None])
    omega *= v[:, None]
    wl = np.ascontiguousarray((1.0 / (mid + half * _mapped(y, alpha)))[::-1])  # sigma decreases in k: reversed
    omega = np.ascontiguousarray(omega[::-1])
    wl.setflags(write=False)
    omega.setflags(write=False)
    return wl, omega

"""Exact Fourier integration of thin-film colour.

For a film with *real* interface amplitude coefficients ``a = r_ab`` and ``b = r_bc`` (non-absorbing, no total
internal reflection) the Airy reflectance (Born & Wolf, *Principles of Optics*, 7th ed., sec. 7.6.1) is a
function of the phase ``phi = 2 pi OPD / lambda`` alone, ``OPD = 2 n_b d cos(theta_b)`` (nm), with a closed-form
Fourier series (a Poisson kernel: the geometric sum of the multiple reflections):

    R(phi) = (a^2 + b^2 + 2ab cos phi) / (1 + a^2 b^2 + 2ab cos phi)
           = c_0 + 2 sum_{m>=1} c_m cos(m phi),
    c_0 = (a^2 + b^2 - 2 a^2 b^2) / (1 - a^2 b^2),
    c_m = c_1 rho^(m-1),  c_1 = a b (1 - a^2)(1 - b^2) / (1 - a^2 b^2),  rho = -a b.

A linear colour is ``C = integral R(lambda) w(lambda) dlambda`` with ``w`` the per-nm colour weights. Hence

    C = c_0 W_0 + 2 sum_m c_m G(m OPD),   G(x) = integral w(lambda) cos(2 pi x / lambda) dlambda,  W_0 = G(0),

one table ``G`` per observer / illuminant / colour space, by one real FFT in ``sigma = 1 / lambda`` (``G(x) =
integral w(1/sigma) sigma^-2 cos(2 pi x sigma) dsigma`` on a uniform ``sigma`` grid, from the 0.1 nm reference
weights), looked up linearly on a 0.5 nm ``x`` grid (relative error ``h^2 / 8 * (2 pi / 360 nm)^2 < 1e-5``).

Truncation (:func:`n_terms_needed`). The series stops at the smaller of two counts: the strict geometric
remainder ``2 |c_1| |rho|^M max|G| / (1 - |rho|) < tol`` (what matters for thin films, whose OPD is too small
for G to decay over the terms), and the first term whose bound ``2 |c_1| max_{x >= (M+1) OPD} |G(x)|`` is
below ``tol``. Beyond the latter the terms are small and ``G(m OPD)`` oscillates in sign with ``m``, so their
sum is smaller still (measured against the 0.1 nm reference by ``rockdove bench lut`` and the tests: texel error
8e-4 dE2000 at tol 1e-4 on the default grid; a strict bound would cost 3-7x more terms, as ``|G|`` decays slowly:
5e-3 of the white at 20 um, 1e-4 at 100 um). Near grazing ``|rho| -> 1`` and only the decay of ``|G|`` bounds the
count. At ``cos theta = 0`` ``a^2 b^2 = 1`` and the formula is 0/0: the limit is ``R = 1`` (``c_0 = 1, c_m = 0``)."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .weights import REFERENCE_STEP_NM, colour_weights, reference_wavelengths

# x-grid of the G table (nm) and FFT length: Delta sigma = 1 / (N h) ~ 1.9e-6 / nm, so the FFT's periodic
# images sit at x = N h = 524 um, far beyond the table's end N h / 2 = 262 um where G has died out.
G_TABLE_STEP_NM = 0.5
G_TABLE_FFT_SIZE = 2**20


@dataclass(frozen=True, eq=False)
class GTable:
    """Tabulated ``G(x_k)``, ``x_k = k step_nm`` (nm): ``g`` (n_x, 3) in linear colour units (a perfect reflector
    is ``w0 = G(0)``) and ``g_tail`` (n_x,), ``max_{k' >= k} max_channel |G(x_k')|``, the truncation's envelope."""

    step_nm: float
    g: np.ndarray
    g_tail: np.ndarray

    @functools.cached_property
    def g_padded32(self) -> np.ndarray:
        """``g`` in float32 (relative rounding 6e-8, for the bandwidth-bound term sums) with two zero rows
        appended (shape (n_x + 2, 3)): lookups beyond the end read 0."""
        p = np.vstack([self.g, np.zeros((2, 3))]).astype(np.float32)
        p.setflags(write=False)
        return p

    @property
    def w0(self) -> np.ndarray:
        """``W_0 = G(0)``, shape (3,): the colour of a perfect reflector."""
        return self.g[0]

    @functools.cached_property
    def _neg_tail(self) -> np.ndarray:
        return -self.g_tail  # increasing, for searchsorted

    def first_x_below(self, level) -> np.ndarray:
        """Smallest grid ``x`` (nm) from which ``|G| <= level`` for good, broadcast over ``level``."""
        return np.searchsorted(self._neg_tail, -np.asarray(level, dtype=np.float64), side="left") * self.step_nm


@functools.lru_cache(maxsize=8)
def g_table(illuminant: str = "D65", colour_space: str | None = "lin_rec709", step_nm: float = G_TABLE_STEP_NM,
            fft_size: int = G_TABLE_FFT_SIZE) -> GTable:
    """The ``G`` table of one illuminant and colour space by one real FFT in wavenumber (module docstring), from
    the 0.1 nm reference weights per nm, linearly interpolated and zero outside; ``Delta sigma = 1 / (fft_size
    step_nm)``. Cached per process; arrays read-only."""
    wl = reference_wavelengths()
    dens = colour_weights(wl, illuminant=illuminant, colour_space=colour_space) / REFERENCE_STEP_NM
    d_sigma = 1.0 / (fft_size * step_nm)
    k_lo = int(np.ceil(1.0 / wl[-1] / d_sigma))
    k_hi = int(np.floor(1.0 / wl[0] / d_sigma))
    sigma = np.arange(k_lo, k_hi + 1) * d_sigma
    lam = 1.0 / sigma
    f = np.zeros((fft_size, 3))
    for c in range(3):
        f[k_lo : k_hi + 1, c] = np.interp(lam, wl, dens[:, c]) * sigma**-2 * d_sigma
    g = np.ascontiguousarray(np.fft.rfft(f, axis=0).real)  # G(x_j) = sum_k f_k cos(2 pi j k / N), x_j = j h
    tail = np.maximum.accumulate(np.abs(g).max(axis=1)[::-1])[::-1].copy()
    g.setflags(write=False)
    tail.setflags(write=False)
    return GTable(step_nm=float(step_nm), g=g, g_tail=tail)


def airy_fourier_coefficients(a, b):
    """``(c0, c1, rho)`` with ``R(phi) = c0 + 2 sum_m c1 rho^(m-1) cos(m phi)`` (module docstring) for the real
    amplitude coefficients ``a = r_ab``, ``b = r_bc`` (|a|, |b| <= 1); at ``a^2 b^2 = 1`` (grazing) the limit
    ``c0 = 1, c1 = 0``."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    a2, b2 = a * a, b * b
    den = 1.0 - a2 * b2
    limit = den <= 1e-300
    den = np.where(limit, 1.0, den)
    c0 = np.where(limit, 1.0, (a2 + b2 - 2.0 * a2 * b2) / den)
    c1 = np.where(limit, 0.0, a * b * (1.0 - a2) * (1.0 - b2) / den)
    return c0, c1, -a * b


def n_terms_needed(c1, rho, opd_nm, table: GTable, tol: float) -> np.ndarray:
    """Number of terms ``M`` (int64, the broadcast shape of ``c1, rho`` with ``opd_nm``): the smaller of the
    geometric and the G-decay counts of the module docstring, for ``tol`` in linear colour units (white = 1); a
    huge value where the series does not terminate (OPD -> 0 with |rho| -> 1)."""
    c1 = np.abs(np.asarray(c1, dtype=np.float64))
    r = np.abs(np.asarray(rho, dtype=np.float64))
    opd = np.asarray(opd_nm, dtype=np.float64)
    g_max = float(table.g_tail[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = 2.0 * c1
        # the geometric remainder bound (G bounded by its maximum): the count for thin films
        ratio = tol * (1.0 - r) / (scale * g_max)
        m_geom = np.where(ratio >= 1.0, 0.0, np.where(r > 0.0, np.ceil(np.log(ratio) / np.log(r)), 1.0))
        # decay of G alone (one search per coefficient, before broadcasting with the OPDs)
        x_star = table.first_x_below(tol / scale)
        m_dead = np.where(opd > 0.0, np.ceil(x_star / opd) - 1.0, np.inf)
    m = np.minimum(m_geom, np.maximum(m_dead, 0.0))
    m = np.where(c1 == 0.0, 0.0, m)
    return np.minimum(np.nan_to_num(m, nan=0.0, posinf=2**40), 2**40).astype(np.int64)


def fourier_colour_grid(c0, c1, rho, opd_nm, n_terms, table: GTable) -> np.ndarray:
    """Linear colour ``c0 W0 + 2 sum_{m=1..M} c_m G(m OPD)``, (T, A, 3), mean over the P polarisations. ``c0, c1, rho``:
    (A, P) per angle column; ``opd_nm``: (T, A) nm; ``n_terms``: (T, A) (:func:`n_terms_needed`; 0 where the caller
    computes the texel otherwise). Each column takes the largest count of its texels (extra terms only add accuracy), so
    the coefficient of term m, ``(2/P) sum_p c1_p rho_p^(m-1)``, is tabulated once per column, and columns with similar
    counts are summed as dense (thickness x columns x terms) blocks."""
    import scipy.sparse

    c0, c1, rho, opd = (np.asarray(v, dtype=np.float64) for v in (c0, c1, rho, opd_nm))
    n_thick, n_ang = opd.shape
    n_pol = c0.shape[1]
    out = np.broadcast_to((c0.mean(axis=1)[:, None] * table.w0[None, :])[None], (n_thick, n_ang, 3)).copy()
    m_col = np.asarray(n_terms).max(axis=0)
    m_max = int(m_col.max(initial=0))
    if m_max == 0:
        return out
    m1 = np.arange(m_max)
    coef = np.zeros((n_ang, m_max))
    for p in range(n_pol):
        coef += c1[:, p, None] * rho[:, p, None] ** m1[None, :]
    coef *= 2.0 / n_pol
    n_x = table.g.shape[0]
    order = np.argsort(m_col, kind="stable")
    order = order[m_col[order] > 0]
    start = 0
    while start < order.size:
        # a block of columns whose term counts are within 25% (+2) of each other
        lo_m = m_col[order[start]]
        stop = int(np.searchsorted(m_col[order], 1.25 * lo_m + 2, side="right"))
        cols = order[start:stop]
        start = stop
        mb = int(m_col[cols].max())
        f = opd[:, cols, None] * ((m1[:mb] + 1.0) / table.step_nm)[None, None, :]  # (T, Ab, Mb)
        k = f.astype(np.int32)
        frac = f - k
        np.minimum(k, n_x, out=k)  # beyond the table: the zero rows of g_padded32
        cb = np.broadcast_to(coef[cols, :mb][None], f.shape)
        data = np.empty(f.shape + (2,), np.float32)  # float32 halves memory traffic; G is ~1, tol >= 1e-6
        data[..., 1] = cb * frac
        data[..., 0] = cb - data[..., 1]
        indices = np.stack([k, k + 1], axis=-1)  # int32, as k
        rows = n_thick * cols.size
        indptr = np.arange(rows + 1, dtype=np.int32) * (2 * mb)
        mat = scipy.sparse.csr_matrix((data.ravel(), indices.ravel(), indptr), shape=(rows, n_x + 2))
        out[:, cols] += (mat @ table.g_padded32).reshape(n_thick, cols.size, 3)
    return out

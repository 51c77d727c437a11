"""Exact colour of dispersive films by product integration in wavenumber (method ``"quadrature"`` of the baker).

The colour of a texel is ``C = integral R(sigma) w(sigma) dsigma`` over wavenumber ``sigma = 1 / lambda``, with
``w`` the colour weights (colour-matching functions times the illuminant, normalised so that a perfect reflector
has Y = 1, then the working space's matrix) and ``R`` the unpolarised Airy reflectance (Born & Wolf, *Principles
of Optics*, 7th ed., sec. 7.6.1). The weights carry all the fine structure (tabulated CMFs and D65 are piecewise
linear: kinks every 1 and 5 nm); ``R`` is analytic in ``sigma`` for a real film, even a dispersive one:

    R(sigma) = (a^2 + b^2 + 2ab cos phi) / (1 + a^2 b^2 + 2ab cos phi),
    phi(sigma) = 4 pi d sigma sqrt(n(sigma)^2 - n_a^2 sin^2 theta),   n(sigma) = A + B sigma^2 (Cauchy),

with the Fresnel coefficients ``a(sigma), b(sigma)`` slowly varying. So the integral is split the way Filon and
Clenshaw-Curtis product rules split an oscillatory integral (Filon 1928; Sloan & Smith, *Product integration with
the Clenshaw-Curtis points*, Numer. Math. 34, 1980): ``R`` is replaced by its polynomial interpolant ``p_N`` on
``N`` Chebyshev points mapped by the Kosloff-Tal-Ezer map (Kosloff & Tal-Ezer, J. Comput. Phys. 104, 1993; Hale &
Trefethen, SIAM J. Numer. Anal. 46, 2008), and the weights are integrated against the Lagrange basis *exactly*,
once per node count (:func:`product_weights`):

    C ~= sum_k Omega_k R(sigma_k),   Omega_k = integral w(sigma) l_k(sigma) dsigma,

where ``l_k`` is the k-th Lagrange polynomial and the integral is the 0.1 nm reference quadrature of
:mod:`.reference` (so ``sum_k Omega_k R(sigma_k)`` is the reference applied to ``p_N``: the only error is the
interpolation error of the analytic ``R``, independent of the weights' kinks, and the continuous spectrum is
integrated, not sampled). Dispersion costs nothing: ``n(sigma)`` enters ``R`` only through ``phi`` and ``a, b``.

Node count. ``R`` is a Poisson kernel in ``phi`` with poles at ``Im phi = +-delta``, ``delta = -ln |ab|``; with
``phi`` spanning ``2 Phi`` over the spectrum, the poles sit ``delta / Phi`` from the interval in the normalised
variable, so the interpolation error decays like ``exp(-c N delta / Phi)`` (Bernstein ellipse, and a wider
region for the mapped points). The count is ``N = K_FULL * Phi / delta + N_MIN``, with ``K_FULL`` measured (the
tests and ``rockdove bench lut`` check the texels against the reference). Near grazing incidence ``|ab| -> 1``
and ``N`` would grow like ``1 / cos theta``; there the series form is used instead:

    R(phi) = c_0 + 2 c_1 sum_{m=1..M} rho^(m-1) cos(m phi)
           = c_0 + 2 c_1 [cos phi - rho - rho^M cos((M+1) phi) + rho^(M+1) cos(M phi)] / (1 - 2 rho cos phi + rho^2)

(the closed-form geometric sum of the Poisson series of :mod:`.fourier`, ``rho = -ab``), a trigonometric
polynomial of degree ``M`` in ``phi`` (entire in ``sigma``: ``N = K_SERIES * M * Phi + N_MIN`` nodes). The
dropped terms are those of the Fourier route: ``M`` is :func:`rockdove.lut.fourier.n_terms_needed` at the
film's smallest optical path difference, i.e. harmonics whose spectral integral ``integral w c_m cos(m phi)``
has died out (``|G(m OPD)|`` below the tolerance, ``G``'s envelope from the coarse :func:`tail_table`; with
dispersion the local frequency of ``cos(m phi)`` in ``sigma`` is the group path, larger than the phase path, so
``G``'s tail at the phase path bounds it). It is evaluated without cancellation near the resonances in half-angle
form (:func:`_series_form`).

Angle axis. Away from grazing the colour is an analytic, slowly varying function of ``cos theta`` too: columns
with ``cos theta >= ANGLE_PANEL_COS`` are interpolated (barycentric, Chebyshev points) from the exact colours at
``K_ANGLE * Psi + N_ANGLE_MIN`` Chebyshev angles, ``Psi`` the phase change over the panel at the largest thickness
(:func:`angle_panel_nodes`; 30 angles instead of 250 columns for the default LUT, reproducing the per-column
quadrature to its own error level). Even near grazing the colour varies smoothly with the angle, because the
resonances that sharpen there are integrated over the spectrum; only the few columns below ``ANGLE_PANEL_COS``
are integrated one by one.

Limits: ``cos theta = 0`` takes ``R = 1`` (the limit of any film); ``d = 0`` is the bare interface (the Poisson
kernel at ``phi = 0``, evaluated in the full form). Absorbing films and total internal reflection make ``a, b``
complex: refused (use ``"spectral"``).
"""

from __future__ import annotations

import functools

import numpy as np

from .reference import sigma_range

# N = K_FULL * Phi / delta + N_MIN (full Airy form) or K_SERIES * M * Phi + N_MIN (truncated series), rounded up
# to NODE_LADDER so that the product weights are computed for few node counts per process. Measured on the default
# keratin LUT (benchmarks/README.md): every texel within 4e-4 dE2000 (~1e-6 in linear colour) of the 0.1 nm
# reference; K_FULL = 2.5, N_MIN = 16 errs 4e-3 and K_FULL = 2 errs 0.02.
K_FULL = 3.0
K_SERIES = 0.6
N_MIN = 20
NODE_LADDER = (8, 24, 28, 32, 40, 48, 56, 64, 80, 96, 112, 128, 160, 192, 224, 256, 320, 384, 448, 512, 640, 768,
               1024, 1280, 1536, 2048, 2560, 3072, 4096)
# Relative cost per node of the series form in the choice between the forms. Measured per node it is ~3-4x the
# full form (four float32 sines and float64 phase reduction instead of one sine), but on the default keratin LUT
# 1.6 and 4 give the same bake time (interleaved A/B: 12.0 vs 11.6 ms): only the two most grazing columns differ.
SERIES_COST = 1.6
# Columns with cos theta >= ANGLE_PANEL_COS are interpolated from K_ANGLE * Psi + N_ANGLE_MIN Chebyshev angles
# (angle_panel_nodes). Measured on keratin at 256 x 64 texels, 480-700 nm: panels from cos theta 0.1, 0.05, 0.03,
# 0.02 and 0.015 all keep every texel within 4e-4 dE2000 of the reference (the per-column quadrature's own level;
# 16 angles over 0.1-1 already reproduce it to 6e-6 in linear colour); from 0.02 the bake is a third faster than
# from 0.1 (interleaved A/B). 150-1000 nm (35 angles): 3.6e-4.
ANGLE_PANEL_COS = 0.02
K_ANGLE = 1.5
N_ANGLE_MIN = 16
# At most this many nodes per column (the 0.1 nm reference has 4201 samples): reached only by films starting at
# d = 0 (no series form) at cos theta -> 0.
MAX_NODES = 4096
# Kosloff-Tal-Ezer map parameter alpha = sech(ln(1 / MAP_EPS) / (N - 1)) (Hale & Trefethen 2008).
MAP_EPS = 1e-9
# Fourier-term tolerance for the truncated series (linear colour units): the dropped harmonics' spectral
# integrals are below this (as rockdove.lut.fourier).
DEFAULT_SERIES_TOL = 1e-5


def map_alpha(n_nodes: int) -> float:
    """Kosloff-Tal-Ezer parameter for ``n_nodes`` points (0 for ``n_nodes < 3``: plain Chebyshev points)."""
    if n_nodes < 3:
        return 0.0
    return float(1.0 / np.cosh(np.log(1.0 / MAP_EPS) / (n_nodes - 1)))


def _mapped(y, alpha):
    """x(y) of the Kosloff-Tal-Ezer map, [-1, 1] -> [-1, 1]."""
    return y if alpha == 0.0 else np.arcsin(alpha * y) / np.arcsin(alpha)


def _unmapped(x, alpha):
    return x if alpha == 0.0 else np.sin(x * np.arcsin(alpha)) / alpha


@functools.lru_cache(maxsize=64)
def product_weights(n_nodes: int, illuminant: str = "D65", colour_space: str | None = "lin_rec709"):
    """Nodes and product-integration weights for ``n_nodes`` mapped Chebyshev points in wavenumber.

    Parameters
    ----------
    n_nodes : int >= 2
    illuminant, colour_space : str
        As :func:`rockdove.lut.reference.colour_weights`.

    Returns
    -------
    wavelength_nm : ndarray, shape (n_nodes,), increasing
        ``1 / sigma_k``.
    weights : ndarray, shape (n_nodes, 3)
        ``Omega_k = sum_l W_l l_k(sigma_l)`` with ``W`` the 0.1 nm reference weights: ``R(nodes) @ weights`` is the
        reference integral of the interpolant of ``R``. Both arrays read-only (cached per process, and on disk by
        :func:`rockdove.spectral.colour_data` under the hash of the code that computes them).
    """
    from ..spectral import colour_data

    n = int(n_nodes)
    if n < 2:
        raise ValueError(f"n_nodes must be >= 2, got {n_nodes!r}")
    # film-independent: kept on disk beside colour-science's tables, keyed by the code that computes them
    keys = ("wavelength_nm", "weights")
    found = colour_data(f"product-weights-{n}-{illuminant}-{colour_space}",
                        lambda: dict(zip(keys, _product_weights(n, illuminant, colour_space))), keys)
    return found["wavelength_nm"], found["weights"]


def _product_weights(n: int, illuminant: str, colour_space: str | None):
    from .reference import colour_weights, reference_wavelengths

    s_lo, s_hi = sigma_range()
    mid, half = 0.5 * (s_hi + s_lo), 0.5 * (s_hi - s_lo)
    alpha = map_alpha(n)
    j = np.arange(n)
    y = np.cos(np.pi * j / (n - 1))  # Chebyshev points of the second kind, barycentric weights (-1)^j, ends halved
    v = (-1.0) ** j
    v[0] *= 0.5
    v[-1] *= 0.5
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
    sigma = mid + half * _mapped(y, alpha)  # decreasing in k: reverse so wavelengths increase
    wl = np.ascontiguousarray((1.0 / sigma)[::-1])
    omega = np.ascontiguousarray(omega[::-1])
    wl.setflags(write=False)
    omega.setflags(write=False)
    return wl, omega


@functools.lru_cache(maxsize=8)
def tail_table(illuminant: str = "D65", colour_space: str | None = "lin_rec709"):
    """A coarse ``G`` table (:func:`rockdove.lut.fourier.g_table_from_density`, 2 nm steps, 2^17-point FFT) for
    the series' term counts only: its envelope ``max_{x' >= x} |G(x')|`` matches the fine table's to 0.1% down to
    3e-4 of the white (conservative below), and it builds in ~20 ms instead of ~0.1-0.7 s."""
    from . import fourier
    from .reference import REFERENCE_STEP_NM, colour_weights, reference_wavelengths

    wl = reference_wavelengths()
    w = colour_weights(wl, illuminant=illuminant, colour_space=colour_space)
    return fourier.g_table_from_density(wl, w / REFERENCE_STEP_NM, step_nm=2.0, fft_size=2**17)


def _ladder(n):
    n = np.asarray(n, dtype=np.float64)
    lad = np.asarray(NODE_LADDER, dtype=np.float64)
    k = np.searchsorted(lad, n, side="left")
    # beyond the ladder: multiples of its last step
    big = k >= lad.size
    out = lad[np.minimum(k, lad.size - 1)]
    return np.where(big, np.ceil(n / 1024.0) * 1024.0, out).astype(np.int64)


def column_plan(film, cos_theta, thickness_nm, *, series_tol=DEFAULT_SERIES_TOL, table=None, illuminant="D65",
                colour_space="lin_rec709"):
    """Form and node count per angle column.

    Parameters
    ----------
    film : FilmModel with real interface coefficients
    cos_theta : ndarray, shape (A,)
    thickness_nm : ndarray, shape (T,)
    series_tol : float
        Tolerance of the truncated series (:func:`rockdove.lut.fourier.n_terms_needed`).
    table : GTable or None
        Table for the series' term counts (default :func:`tail_table` of ``illuminant`` and ``colour_space``).
    illuminant, colour_space : str

    Returns
    -------
    n_nodes : ndarray of int, shape (A,)
        Node count per column (on :data:`NODE_LADDER`).
    n_terms : ndarray of int, shape (A,)
        0 for the full Airy form, else the series' term count ``M``.
    """
    from .interfaces import interface_coefficients

    s_lo, s_hi = sigma_range()
    half = 0.5 * (s_hi - s_lo)
    sig = np.linspace(s_lo, s_hi, 17)
    coef = interface_coefficients(film, cos_theta, 1.0 / sig)
    if coef is None:
        raise _refused(film)
    d_max = float(np.max(thickness_nm))
    d_min = float(np.min(thickness_nm))
    q = coef["n_b"] * coef["cos_b"]  # (A, S): n_b cos theta_b
    # phase phi = 4 pi d sigma q(sigma); its largest slope at the largest thickness, times the half-range
    phase = 4.0 * np.pi * d_max * sig[None, :] * q
    dphi = (np.abs(np.diff(phase, axis=1)).max(axis=1) / (sig[1] - sig[0])) * half
    rho = np.maximum(np.abs(coef["a_s"] * coef["b_s"]).max(axis=1), np.abs(coef["a_p"] * coef["b_p"]).max(axis=1))
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = -np.log(rho)
        n_full = np.where(delta > 0.0, K_FULL * dphi / delta, np.inf) + N_MIN
    n_full = np.where(cos_theta == 0.0, 2.0, n_full)  # R = 1 exactly: any node count integrates it
    n_terms = np.zeros(cos_theta.shape[0], np.int64)
    n_series = np.full(cos_theta.shape[0], np.inf)
    if d_min > 0.0:
        from . import fourier

        # columns where the full form needs many nodes: try the truncated series
        # (rho = -ab >= 0, as for a film in air: the float32 closed form below has no cancellation there)
        rho_min = np.minimum((-coef["a_s"] * coef["b_s"]).min(axis=1), (-coef["a_p"] * coef["b_p"]).min(axis=1))
        cand = np.nonzero((n_full > 2.0 * N_MIN) & (cos_theta > 0.0) & (rho_min >= 0.0))[0]
        if cand.size:
            table = tail_table(illuminant, colour_space) if table is None else table
            opd_min = 2.0 * d_min * q[cand].min(axis=1)
            m = np.zeros(cand.size, np.int64)
            for pol in ("s", "p"):
                c0, c1, rho_p = fourier.airy_fourier_coefficients(coef[f"a_{pol}"][cand], coef[f"b_{pol}"][cand])
                c1m = np.abs(c1).max(axis=1)
                rm = np.abs(rho_p).max(axis=1)
                m = np.maximum(m, fourier.n_terms_needed(c1m, rm, opd_min, table, series_tol))
            n_terms[cand] = np.maximum(m, 1)  # (c_1 = 0 at cos theta -> 0: one term, the series is then c_0)
            n_series[cand] = K_SERIES * m * dphi[cand] + N_MIN
    use_series = SERIES_COST * n_series < n_full
    n_terms = np.where(use_series, n_terms, 0)
    n_nodes = _ladder(np.minimum(np.where(use_series, n_series, n_full), MAX_NODES))
    return n_nodes, n_terms


class _Layout:
    """Nodes of a set of columns laid end to end: column ``cols[i]`` owns ``n_nodes[i]`` consecutive samples;
    columns with the same node count are adjacent (``groups``: (first column, last column + 1, N, sample start))."""

    def __init__(self, cols, n_nodes, cos_theta, illuminant, colour_space):
        order = np.argsort(n_nodes, kind="stable")
        self.cols = cols[order]
        n_sorted = n_nodes[order]
        lams, omegas, self.groups = [], [], []
        start = 0
        values, first, counts = np.unique(n_sorted, return_index=True, return_counts=True)
        for n, i0, i1 in zip(values.tolist(), first.tolist(), (first + counts).tolist()):
            wl, w = product_weights(int(n), illuminant, colour_space)
            lams.append(np.tile(wl, i1 - i0))
            omegas.append(w)
            self.groups.append((int(i0), int(i1), int(n), start))
            start += (i1 - i0) * int(n)
        self.omegas = omegas
        self.lam = np.concatenate(lams)
        self.cos = np.repeat(cos_theta[self.cols], n_sorted)
        self.size = start

    def white(self):
        """Per layout column, the weights' sum (shape (n_cols, 3)): the colour of R = 1."""
        w = np.empty((self.cols.size, 3))
        for (i0, i1, n, s0), om in zip(self.groups, self.omegas):
            w[i0:i1] = om.sum(axis=0)
        return w

    def reduce(self, r, out, rows):
        """``out[rows, cols] = sum over each column's nodes of r * Omega``; ``r`` shape (len(rows), size)."""
        nr = r.shape[0]
        for (i0, i1, n, s0), w in zip(self.groups, self.omegas):
            block = r[:, s0 : s0 + (i1 - i0) * n].reshape(nr * (i1 - i0), n)
            out[rows, self.cols[i0:i1]] = (block @ (w if r.dtype == w.dtype else w.astype(r.dtype))).reshape(
                nr, i1 - i0, 3)


def _full_form(coef, layout, thickness_nm, out, chunk):
    """Unpolarised Airy reflectance at the layout's nodes, full real form.

    Per polarisation, with ``p = ab`` and ``s2 = sin^2(phi / 2)`` (Born & Wolf 7.6.1 in half-angle form, as
    :func:`.bake.sample_colour`), ``R = ((a + b)^2 - 4 p s2) / ((1 + p)^2 - 4 p s2)``, written as
    ``R = 1 - (1 - a^2)(1 - b^2) / ((1 + p)^2 - 4 p s2)``: the constant 1 integrates to the weights' sum (the
    white), so each node costs one sine and three operations per polarisation. For ``p <= 0`` (a film in air)
    the denominator is a sum of non-negative terms, so float32 is safe (phase rounding ~2e-6 rad). ``coef``: the
    layout's interface coefficients (:func:`.interfaces.interface_coefficients`, pairwise).
    """
    products = [coef[f"a_{pol}"] * coef[f"b_{pol}"] for pol in ("s", "p")]
    dtype = np.float32 if max(float(p.max(initial=-1.0)) for p in products) <= 0.0 else np.float64
    half_k = (2.0 * np.pi * coef["n_b"] * coef["cos_b"] / layout.lam).astype(dtype)
    terms = []
    degenerate = np.zeros(layout.size, bool)
    for pol, p in zip(("s", "p"), products):
        a, b = coef[f"a_{pol}"], coef[f"b_{pol}"]
        den0 = (1.0 + p) ** 2
        degenerate |= den0 == 0.0  # ab = -1 (cos theta = 0): R = 1 for any film with d > 0
        # -(1 - a^2)(1 - b^2) / 2: the mean over the two polarisations folded in
        terms.append(tuple(v.astype(dtype) for v in (-0.5 * (1.0 - a * a) * (1.0 - b * b), -4.0 * p, den0)))
    fix = np.nonzero(degenerate)[0]
    white = layout.white()
    d = thickness_nm.astype(dtype)
    for i in range(0, d.shape[0], chunk):
        rows = slice(i, min(i + chunk, d.shape[0]))
        s2 = np.sin(d[rows, None] * half_k[None, :])
        s2 *= s2
        r = None
        with np.errstate(invalid="ignore", divide="ignore"):
            for num, slope, den0 in terms:
                x = slope * s2
                x += den0
                np.divide(num, x, out=x)
                if r is None:
                    r = x
                else:
                    r += x
        if fix.size:
            r[:, fix] = 0.0
        layout.reduce(r, out, rows)
        out[rows, layout.cols] += white[None]


def _series_form(coef, layout, thickness_nm, n_terms, out, chunk):
    """The truncated Poisson series (``n_terms`` per layout column) at the layout's nodes.

    With ``s2 = sin^2(phi / 2)`` the closed form is rewritten without cancellation near the resonances
    (``cos phi - rho = (1 - rho) - 2 s2``, ``1 - 2 rho cos phi + rho^2 = (1 - rho)^2 + 4 rho s2``):

        sum_{m=1..M} rho^(m-1) cos(m phi)
            = [((1 - rho) - 2 s2)(1 - rho^M cos(M phi)) + rho^M sin(M phi) sin(phi)] / ((1 - rho)^2 + 4 rho s2),

    so float32 trigonometry suffices; the phases ``phi / 2`` and ``M phi`` are reduced modulo one period in
    float64 first (``M phi`` reaches thousands of radians).
    """
    from . import fourier

    cycles = coef["n_b"] * coef["cos_b"] / layout.lam  # phi / (4 pi d): phase cycles per nm of film, / 2
    m = np.repeat(np.asarray(n_terms, dtype=np.float64)[layout.cols],
                  [n for (i0, i1, n, _) in layout.groups for _ in range(i1 - i0)])
    pols = []
    for pol in ("s", "p"):
        c0, c1, rho = fourier.airy_fourier_coefficients(coef[f"a_{pol}"], coef[f"b_{pol}"])
        f32 = [v.astype(np.float32) for v in (c0, 2.0 * c1, 1.0 - rho, 4.0 * rho, rho**m, (1.0 - rho) ** 2)]
        pols.append(f32)
    two_pi = np.float32(2.0 * np.pi)
    for i in range(0, thickness_nm.shape[0], chunk):
        rows = slice(i, min(i + chunk, thickness_nm.shape[0]))
        half = thickness_nm[rows, None] * cycles[None, :]  # phi / (2 pi) / 2... in cycles: phi / 2 = 2 pi half
        h = (half - np.floor(half)).astype(np.float32) * two_pi  # phi / 2 modulo 2 pi
        mc = (2.0 * m) * half
        mp = (mc - np.floor(mc)).astype(np.float32) * two_pi  # M phi modulo 2 pi
        sh, ch = np.sin(h), np.cos(h)
        s2 = sh * sh
        sin_phi = 2.0 * sh * ch
        cos_m, sin_m = np.cos(mp), np.sin(mp)
        r = np.zeros(h.shape, np.float32)
        for c0, c1x2, one_m_rho, four_rho, rho_m, den0 in pols:
            num = (one_m_rho - 2.0 * s2) * (1.0 - rho_m * cos_m) + rho_m * sin_m * sin_phi
            r += c0 + c1x2 * num / (den0 + four_rho * s2)
        r *= 0.5
        layout.reduce(r, out, rows)


def _bare(film, layout, out, rows):
    """Rows of zero thickness: the bare incident | substrate interface at the layout's nodes."""
    from .. import optics

    r = optics.reflectance(layout.lam, layout.cos, 0.0, n_film=film.n_film(layout.lam),
                           n_incident=film.n_incident, n_substrate=film.n_substrate)
    layout.reduce(np.broadcast_to(r[None, :], (rows.size, layout.size)), out, rows)


# samples (thickness rows x nodes) evaluated per chunk (interleaved A/B on the default keratin LUT: 2^19 is ~10%
# faster than 2^17 and 20% faster than 2^15; the temporaries stay below ~10 MB)
_CHUNK_SAMPLES = 1 << 19


def quadrature_colour(cos_theta, thickness_nm, film, *, illuminant="D65", colour_space="lin_rec709",
                      series_tol=DEFAULT_SERIES_TOL):
    """Colour of a (thickness x angle) grid by product integration in wavenumber (module docstring).

    Parameters
    ----------
    cos_theta : ndarray, shape (A,), in [0, 1]
    thickness_nm : ndarray, shape (T,), >= 0
    film : FilmModel
        Must have real interface coefficients (no absorption, no total internal reflection).
    illuminant, colour_space : str
    series_tol : float
        Tolerance of the truncated series near grazing.

    Returns
    -------
    rgb : ndarray, shape (T, A, 3), float64
    meta : dict of str
        Node and term counts, for the LUT's metadata.

    Raises
    ------
    ValueError
        For films with complex interface coefficients (absorbing, or total internal reflection).
    """

    cos_theta = np.asarray(cos_theta, dtype=np.float64)
    thickness_nm = np.asarray(thickness_nm, dtype=np.float64)
    if not real_coefficients(film, cos_theta):
        raise _refused(film)
    out = np.empty((thickness_nm.shape[0], cos_theta.shape[0], 3))
    panel_nodes = angle_panel_nodes(film, cos_theta, thickness_nm)
    if panel_nodes is None:
        n_nodes, n_terms = _direct_columns(cos_theta, thickness_nm, film, out, illuminant, colour_space, series_tol)
        panel_meta = "none"
    else:
        # the resonant columns one by one and the panel's Chebyshev angles, in one pass
        panel = cos_theta >= ANGLE_PANEL_COS
        direct = np.nonzero(~panel)[0]
        both = np.concatenate([cos_theta[direct], panel_nodes])
        sub = np.empty((thickness_nm.shape[0], both.shape[0], 3))
        n_nodes, n_terms = _direct_columns(both, thickness_nm, film, sub, illuminant, colour_space, series_tol)
        out[:, direct] = sub[:, : direct.size]
        # (A_panel, n) @ (T, n, 3): barycentric interpolation in cos theta
        out[:, panel] = _barycentric_matrix(panel_nodes, cos_theta[panel]) @ sub[:, direct.size :]
        panel_meta = (f"{panel_nodes.shape[0]} Chebyshev angles on cos_theta {float(panel_nodes.min())!r}.."
                      f"{float(panel_nodes.max())!r} for {int(panel.sum())} columns")
    meta = {
        "quadratureNodesMean": f"{n_nodes.mean():.1f}",
        "quadratureNodesMax": str(int(n_nodes.max())),
        "quadratureSeriesColumns": str(int((n_terms > 0).sum())),
        "quadratureSeriesTermsMax": str(int(n_terms.max(initial=0))),
        "quadratureSeriesTolerance": repr(float(series_tol)),
        "quadratureAnglePanel": panel_meta,
    }
    return out, meta


def real_coefficients(film, cos_theta) -> bool:
    """True when both interfaces have real Fresnel coefficients at every angle: no absorption (``k = 0``, real
    substrate) and no total internal reflection (``n_a sin theta <= min(n_b, n_c)`` over the spectrum; ``n_b`` is
    smallest at the longest wavelength for a Cauchy film)."""
    if film.k != 0 or isinstance(film.n_substrate, complex):
        return False
    s_lo, s_hi = sigma_range()
    n_b = float(np.min(film.n_film(np.array([1.0 / s_hi, 1.0 / s_lo]))))
    cos_min = float(np.min(cos_theta)) if np.size(cos_theta) else 1.0
    return film.n_incident**2 * (1.0 - cos_min**2) <= min(n_b, float(film.n_substrate)) ** 2


def _refused(film):
    return ValueError(
        f"method 'quadrature' needs a non-absorbing film without total internal reflection (real interface "
        f"coefficients); film {film.name!r} is not (k = {film.k!r}, substrate {film.n_substrate!r}; use 'spectral')"
    )


def _direct_columns(cos_theta, thickness_nm, film, out, illuminant, colour_space, series_tol):
    """Product integration of every column of ``cos_theta`` into ``out`` (T, A, 3); returns the plan."""
    from .interfaces import interface_coefficients

    n_nodes, n_terms = column_plan(film, cos_theta, thickness_nm, series_tol=series_tol, illuminant=illuminant,
                                   colour_space=colour_space)
    bare = np.nonzero(thickness_nm == 0.0)[0]
    films_rows = np.nonzero(thickness_nm > 0.0)[0]
    d = thickness_nm[films_rows]
    layouts = []
    for series in (False, True):
        cols = np.nonzero((n_terms > 0) == series)[0]
        if cols.size:
            layouts.append((series, cols, _Layout(cols, n_nodes[cols], cos_theta, illuminant, colour_space)))
    # the interface coefficients of every node of both forms in one call
    coef_all = interface_coefficients(film, np.concatenate([lay.cos for _, _, lay in layouts]),
                                      np.concatenate([lay.lam for _, _, lay in layouts]), outer=False)
    start = 0
    for series, cols, layout in layouts:
        coef = {k: v[start : start + layout.size] for k, v in coef_all.items()}
        start += layout.size
        chunk = max(1, _CHUNK_SAMPLES // layout.size)
        if d.size:
            sub = np.empty((d.shape[0], cos_theta.shape[0], 3))
            if series:
                _series_form(coef, layout, d, n_terms, sub, chunk)
            else:
                _full_form(coef, layout, d, sub, chunk)
            out[films_rows[:, None], cols[None, :]] = sub[:, cols]
        if bare.size:
            _bare(film, layout, out, bare)
    return n_nodes, n_terms


def angle_panel_nodes(film, cos_theta, thickness_nm):
    """Chebyshev angles whose exact colours are interpolated to the columns ``cos theta >= ANGLE_PANEL_COS``.

    Away from grazing incidence the colour is an analytic, slowly varying function of ``cos theta`` (the phase
    ``4 pi d sigma q(cos theta)``, ``q = sqrt(n^2 - 1 + cos^2 theta)``, changes by ``Psi`` radians over the panel
    at the largest thickness and wavenumber, and the Fresnel coefficients are analytic there), so its polynomial
    interpolant on ``K_ANGLE * Psi + N_ANGLE_MIN`` Chebyshev angles is exact to the quadrature's own rounding
    (measured: 1e-6 in linear colour). Returns None when that would not save work (fewer columns than nodes).
    """
    panel = cos_theta >= ANGLE_PANEL_COS
    if not panel.any():
        return None
    lo, hi = float(cos_theta[panel].min()), float(cos_theta[panel].max())
    s_lo, s_hi = sigma_range()
    sig = np.array([s_lo, s_hi])
    n = np.real(film.n_film(1.0 / sig))
    n_a2 = film.n_incident**2
    q_hi = np.sqrt(n * n - n_a2 * (1.0 - hi * hi))
    q_lo = np.sqrt(n * n - n_a2 * (1.0 - lo * lo))
    psi = float(np.max(4.0 * np.pi * float(np.max(thickness_nm)) * sig * np.abs(q_hi - q_lo)))
    n_c = int(np.ceil(K_ANGLE * psi + N_ANGLE_MIN))
    if 2 * n_c > int(panel.sum()) or hi <= lo:
        return None
    y = np.cos(np.pi * np.arange(n_c) / (n_c - 1))
    return lo + (hi - lo) * 0.5 * (1.0 + y[::-1])


def _barycentric_matrix(nodes, x):
    """Matrix (len(x), len(nodes)) of the Lagrange basis on Chebyshev points of the second kind ``nodes``."""
    n = nodes.shape[0]
    v = (-1.0) ** np.arange(n)
    v[0] *= 0.5
    v[-1] *= 0.5
    diff = x[:, None] - nodes[None, :]
    hit = diff == 0.0
    diff[hit] = 1.0
    q = v[None, :] / diff
    basis = q / q.sum(axis=1)[:, None]
    on_node = hit.any(axis=1)
    basis[on_node] = hit[on_node]
    return basis

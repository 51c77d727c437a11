"""Exact colour of dispersive films by product integration in wavenumber (method ``"quadrature"`` of the baker).

A texel's colour is ``C = integral R(sigma) w(sigma) dsigma`` over ``sigma = 1 / lambda``, ``w`` the colour
weights and ``R`` the unpolarised Airy reflectance (Born & Wolf, *Principles of Optics*, 7th ed., sec. 7.6.1).
The weights carry all the fine structure (the tables kink every 1 and 5 nm); ``R`` is analytic in ``sigma`` for a
real film, even a dispersive one:

    R(sigma) = (a^2 + b^2 + 2ab cos phi) / (1 + a^2 b^2 + 2ab cos phi),
    phi(sigma) = 4 pi d sigma sqrt(n(sigma)^2 - n_a^2 sin^2 theta),   n(sigma) = A + B sigma^2 (Cauchy),

with slowly varying Fresnel coefficients ``a, b``. So, as Filon and Clenshaw-Curtis product rules split an
oscillatory integral (Filon 1928; Sloan & Smith, Numer. Math. 34, 1980), ``R`` is replaced by its interpolant on
``N`` Chebyshev points under the Kosloff-Tal-Ezer map (J. Comput. Phys. 104, 1993; Hale & Trefethen, SIAM J.
Numer. Anal. 46, 2008), integrated exactly against the weights (:func:`.weights.chebyshev_weights`): the only
error is the interpolation error of the analytic ``R``, and dispersion costs nothing.

Node count. ``R`` is a Poisson kernel in ``phi`` with poles at ``Im phi = +-delta``, ``delta = -ln |ab|``; with
``phi`` spanning ``2 Phi`` over the spectrum the error decays like ``exp(-c N delta / Phi)`` (Bernstein
ellipse), so ``N = K_FULL * Phi / delta + N_MIN`` (``K_FULL`` measured). Near grazing ``|ab| -> 1`` and ``N``
would grow like ``1 / cos theta``; there the truncated Poisson series of :mod:`.fourier` (``rho = -ab``) is
interpolated instead, ``R(phi) = c_0 + 2 c_1 sum_{m=1..M} rho^(m-1) cos(m phi)``, a trigonometric polynomial
of degree ``M`` (``N = K_SERIES * M * Phi + N_MIN``, summed in closed form by :func:`_series_form`), ``M`` from
:func:`rockdove.lut.fourier.n_terms_needed` at the film's smallest optical path difference (with dispersion the
local frequency of ``cos(m phi)`` is the group path, larger than the phase path: ``G``'s tail there bounds it).

Angle axis. Away from grazing the colour is analytic in ``cos theta`` too: the columns with ``cos theta >=
ANGLE_PANEL_COS`` are interpolated from the exact colours at a few Chebyshev angles (:func:`angle_panel_nodes`;
30 instead of 250 columns for the default LUT).

Limits: ``cos theta = 0`` takes ``R = 1``; ``d = 0`` is the bare interface. Absorbing films and total internal
reflection make ``a, b`` complex: refused (use ``"spectral"``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import optics
from ..errors import UsageError
from . import fourier
from .interfaces import interface_coefficients
from .weights import chebyshev, chebyshev_weights, sigma_range

# Node counts, rounded up to NODE_LADDER. On the default keratin LUT every texel is within 4e-4 dE2000 of the
# 0.1 nm reference (K_FULL = 2.5 with N_MIN = 16 errs 4e-3, K_FULL = 2 errs 0.02; benchmarks/README.md).
K_FULL = 3.0
K_SERIES = 0.6
N_MIN = 20
NODE_LADDER = (8, 24, 28, 32, 40, 48, 56, 64, 80, 96, 112, 128, 160, 192, 224, 256, 320, 384, 448, 512, 640, 768,
               1024, 1280, 1536, 2048, 2560, 3072, 4096)
# Relative cost per node of the series form (1.6 and 4 bake the default keratin LUT in the same time).
SERIES_COST = 1.6
# The angle panel (angle_panel_nodes). Measured on keratin at 256 x 64 texels, 480-700 nm: panels from cos theta
# 0.1 down to 0.015 all keep every texel within 4e-4 dE2000 of the reference (150-1000 nm, 35 angles: 3.6e-4);
# from 0.02 the bake is a third faster than from 0.1.
ANGLE_PANEL_COS = 0.02
K_ANGLE = 1.5
N_ANGLE_MIN = 16
# At most this many nodes per column (the 0.1 nm reference has 4201 samples), reached only at d = 0, cos -> 0.
MAX_NODES = 4096
# Tolerance of the truncated series (linear colour units), as rockdove.lut.fourier.
DEFAULT_SERIES_TOL = 1e-5


def column_plan(film, cos_theta, thickness_nm, *, series_tol=DEFAULT_SERIES_TOL, illuminant="D65",
                colour_space="lin_rec709"):
    """``(n_nodes, n_terms)`` per angle column, each (A,) int: the node count on :data:`NODE_LADDER`, and 0 for
    the full Airy form, else the series' ``M``, counted on a coarse ``G`` table (2 nm, a 2^17-point FFT: its
    envelope is the fine one's to 0.1% down to 3e-4 of the white, conservative below, in ~20 ms, not 0.1-0.7 s)."""
    s_lo, s_hi = sigma_range()
    half = 0.5 * (s_hi - s_lo)
    sig = np.linspace(s_lo, s_hi, 17)
    coef = interface_coefficients(film, cos_theta, 1.0 / sig)
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
        # columns where the full form needs many nodes and rho = -ab >= 0 (no cancellation in float32): the series
        rho_min = np.minimum((-coef["a_s"] * coef["b_s"]).min(axis=1), (-coef["a_p"] * coef["b_p"]).min(axis=1))
        cand = np.nonzero((n_full > 2.0 * N_MIN) & (cos_theta > 0.0) & (rho_min >= 0.0))[0]
        if cand.size:
            table = fourier.g_table(illuminant, colour_space, 2.0, 2**17)
            opd_min = 2.0 * d_min * q[cand].min(axis=1)
            m = np.zeros(cand.size, np.int64)
            for pol in ("s", "p"):
                _, c1, rho_p = fourier.airy_fourier_coefficients(coef[f"a_{pol}"][cand], coef[f"b_{pol}"][cand])
                m = np.maximum(m, fourier.n_terms_needed(np.abs(c1).max(axis=1), np.abs(rho_p).max(axis=1), opd_min,
                                                         table, series_tol))
            n_terms[cand] = np.maximum(m, 1)  # (c_1 = 0 at cos theta -> 0: one term, the series is then c_0)
            n_series[cand] = K_SERIES * m * dphi[cand] + N_MIN
    use_series = SERIES_COST * n_series < n_full
    n_terms = np.where(use_series, n_terms, 0)
    n = np.minimum(np.where(use_series, n_series, n_full), MAX_NODES)  # NODE_LADDER ends at MAX_NODES
    return np.asarray(NODE_LADDER, np.int64)[np.searchsorted(NODE_LADDER, n, side="left")], n_terms


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
            wl, w = chebyshev_weights(int(n), illuminant, colour_space)
            lams.append(np.tile(wl, i1 - i0))
            omegas.append(w)
            self.groups.append((int(i0), int(i1), int(n), start))
            start += (i1 - i0) * int(n)
        self.omegas = omegas
        self.lam = np.concatenate(lams)
        self.cos = np.repeat(cos_theta[self.cols], n_sorted)
        self.size = start

    def white(self):
        """Per layout column, the weights' sum (n_cols, 3): the colour of R = 1."""
        w = np.empty((self.cols.size, 3))
        for (i0, i1, _, _), om in zip(self.groups, self.omegas):
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
    """The full Airy form at the layout's nodes (``coef``: their interface coefficients): with ``p = ab``, ``s2 =
    sin^2(phi / 2)`` (Born & Wolf 7.6.1, half-angle form as :func:`.bake.sample_colour`), ``R = 1 - (1 - a^2)(1 -
    b^2) / ((1 + p)^2 - 4 p s2)``, the 1 integrating to the white: one sine and three operations per polarisation,
    in float32 for ``p <= 0`` (a film in air), where the denominator has no cancellation."""
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
        r: Any = None
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
    """The truncated Poisson series (``n_terms`` per layout column) at the layout's nodes, its geometric sum in
    half-angle form (``s2 = sin^2(phi / 2)``), without cancellation near the resonances:

        sum_{m=1..M} rho^(m-1) cos(m phi)
            = [((1 - rho) - 2 s2)(1 - rho^M cos(M phi)) + rho^M sin(M phi) sin(phi)] / ((1 - rho)^2 + 4 rho s2),

    so float32 trigonometry suffices once ``phi / 2`` and ``M phi`` (thousands of radians) are reduced modulo one
    period in float64."""
    cycles = coef["n_b"] * coef["cos_b"] / layout.lam  # phi / (4 pi d): phase cycles per nm of film, / 2
    m = np.repeat(np.asarray(n_terms, dtype=np.float64)[layout.cols],
                  [n for (i0, i1, n, _) in layout.groups for _ in range(i1 - i0)])
    pols = []
    for pol in ("s", "p"):
        c0, c1, rho = fourier.airy_fourier_coefficients(coef[f"a_{pol}"], coef[f"b_{pol}"])
        pols.append([v.astype(np.float32) for v in (c0, 2.0 * c1, 1.0 - rho, 4.0 * rho, rho**m, (1.0 - rho) ** 2)])
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


# samples (thickness rows x nodes) per chunk: 2^19 is ~10% faster than 2^17 (default keratin LUT), temporaries < 10 MB
_CHUNK_SAMPLES = 1 << 19


def quadrature_colour(cos_theta, thickness_nm, film, *, illuminant="D65", colour_space="lin_rec709",
                      series_tol=DEFAULT_SERIES_TOL):
    """``(rgb, meta)``: the (T, A, 3) colour of the grid of ``cos_theta`` (A,) and ``thickness_nm`` (T,) by
    product integration in wavenumber (module docstring), and its node and term counts for the LUT's metadata.
    ValueError for a film with complex interface coefficients (absorbing, or total internal reflection)."""
    cos_theta = np.asarray(cos_theta, dtype=np.float64)
    thickness_nm = np.asarray(thickness_nm, dtype=np.float64)
    if not real_coefficients(film, cos_theta):
        raise UsageError(f"method 'quadrature' needs a non-absorbing film without total internal reflection (real "
                         f"interface coefficients); film {film.name!r} is not (k = {film.k!r}, substrate "
                         f"{film.n_substrate!r}; use 'spectral')")
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
    return out, {"quadratureNodesMean": f"{n_nodes.mean():.1f}", "quadratureNodesMax": str(int(n_nodes.max())),
                 "quadratureSeriesColumns": str(int((n_terms > 0).sum())),
                 "quadratureSeriesTermsMax": str(int(n_terms.max(initial=0))),
                 "quadratureSeriesTolerance": repr(float(series_tol)), "quadratureAnglePanel": panel_meta}


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


def _direct_columns(cos_theta, thickness_nm, film, out, illuminant, colour_space, series_tol):
    """Product integration of every column of ``cos_theta`` into ``out`` (T, A, 3); returns the plan."""
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
        if bare.size:  # rows of zero thickness: the bare incident | substrate interface at the layout's nodes
            r = optics.reflectance(layout.lam, layout.cos, 0.0, n_film=film.n_film(layout.lam),
                                   n_incident=film.n_incident, n_substrate=film.n_substrate)
            layout.reduce(np.broadcast_to(r[None, :], (bare.size, layout.size)), out, bare)
    return n_nodes, n_terms


def angle_panel_nodes(film, cos_theta, thickness_nm):
    """Chebyshev angles whose exact colours are interpolated to the columns ``cos theta >= ANGLE_PANEL_COS``
    (module docstring): the phase ``4 pi d sigma q``, ``q = sqrt(n^2 - n_a^2 sin^2 theta)``, changes by ``Psi``
    over the panel at the largest thickness and wavenumber; ``K_ANGLE * Psi + N_ANGLE_MIN`` angles reproduce the
    per-column quadrature to 1e-6 in linear colour (measured). None when that would not save work."""
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
    saves = 2 * n_c <= int(panel.sum()) and hi > lo
    return lo + (hi - lo) * 0.5 * (1.0 + chebyshev(n_c)[0][::-1]) if saves else None


def _barycentric_matrix(nodes, x):
    """Matrix (len(x), len(nodes)) of the Lagrange basis on Chebyshev points of the second kind ``nodes``."""
    v = chebyshev(nodes.shape[0])[1]
    diff = x[:, None] - nodes[None, :]
    hit = diff == 0.0
    diff[hit] = 1.0
    q = v[None, :] / diff
    basis = q / q.sum(axis=1)[:, None]
    on_node = hit.any(axis=1)
    basis[on_node] = hit[on_node]
    return basis

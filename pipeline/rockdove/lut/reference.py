"""The exact reference colour of a thin film, and the error of a LUT against it, as users see it.

Reference: the unpolarised Airy spectrum (:func:`rockdove.optics.reflectance`; Born and Wolf, Principles of
Optics, 7th ed., sec. 7.6.1, eq. 58) on a uniform wavelength grid over 360-780 nm, integrated with the colour
weights of :mod:`.weights`, compared in CIELAB by CIEDE2000 (Sharma, Wu & Dalal 2005). :func:`reference_colour`
is the project's one definition of "the exact colour of a film at (cos theta, thickness)": the LUT error,
``rockdove bench lut``, the preview atlas and the verification's images (:mod:`rockdove.verify.reference_image`).

Wavelength steps (:data:`REFERENCE_STEPS_NM`). Near grazing both Fresnel coefficients tend to -1 and the film is a
high-finesse resonator whose spectrum is a comb of lines a fraction of a nm wide. Measured (keratin 200-900 nm, 60
random points per band, max dE2000 against a 0.002-0.01 nm integration): 0.1 nm errs <= 3.3e-5 for cos theta >=
0.003 but 0.0061 at 0.001-0.003 and 0.014 at 0.0005-0.001; 0.05 nm <= 1.8e-4 at 0.001-0.003; 0.01 nm <= 1e-7
below. So the bands are 0.1 / 0.05 / 0.01 nm, each within 2e-4 dE2000, under the LUT tests' tolerance (2e-3).

Coarser steps (``steps_nm``, as the verification images') integrate the spectrum's piecewise-cubic interpolant
against the 0.1 nm weights (:func:`.weights.product_weights`). Measured (keratin 450-720 nm, 300 points per band,
against 0.02 nm): 4 nm errs 0.0010 at cos theta 0.12-0.2 and 0.0006 above (the trapezoid rule's 2 nm: 0.0045), but
0.011 at 0.08-0.12, where the fringes sharpen: those bands take finer steps. The spectrum of a thicker film
is the same comb compressed in wavelength, so with ``calibrated_thickness_nm`` a thicker point's step is scaled
by ``calibrated_thickness_nm / d`` and snapped down to :data:`STEP_LADDER_NM` (the images' steps, scaled from
720 nm: <= 0.0017 dE2000 up to 5000 nm, where unscaled they erred 2.3).

Wavenumber interpolation (``interpolation=(cos_theta_lo, kappa, max_step_rad)``, real films only): points from
``cos_theta_lo`` up sample the spectrum on a grid uniform in ``sigma = 1 / lambda``, where the fringes are
uniform, and integrate its ``order``-point Lagrange interpolant (:func:`.weights.interpolant_weights`; centred
stencils past both ends: one-sided ones erred 0.0047-0.24). The Airy reflectance is a Poisson kernel in ``phi``
with poles at ``Im phi = +-delta``, ``delta = -ln max|r_ab r_bc|``, so one interval spans at most ``min(kappa *
delta, max_step_rad)`` radians at the steepest (blue) end (:func:`interval_count`). Measured with the images'
``(0.01, 0.35, 0.6)`` and 16 points (max dE2000 against 0.02-0.05 nm; keratin 450-720, 1500-2000, 4000-5000 nm
and the paper film, 60-150 points per cos theta band): <= 0.0008 in every band (12 points: 0.0014; 24: 0.0004;
a 0.8 rad cap: 0.0015). Below cos theta 0.01 (thousands of nodes) the points keep ``steps_nm``.

The real-film kernel (:func:`_real_colour`). With admittances ``x, y, z`` of the incident medium, film and
substrate (s: ``n cos``, p: ``cos / n``; :mod:`rockdove.optics` eq. 4) one polarisation's Airy reflectance is
exactly ``1 - R = 4 x z y^2 / (y^2 (x + z)^2 + (y^2 - x^2)(y^2 - z^2) sin^2(phi / 2))``: for a film at least as
dense as both media a sum of non-negative terms, so float32 loses nothing to cancellation. Float32 rounds the
phase (280 rad at 5000 nm) to ~3e-5 rad, which resonances amplify (2.1e-3 dE2000 at cos theta 0.001-0.01; <=
3.5e-4 from 0.05), so points below :data:`FLOAT32_MIN_COS` and on wavelength steps run in float64 (equal to
:func:`rockdove.optics.reflectance` to 1e-14, 2.7x faster)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import optics, spectral
from ..errors import UsageError
from ..films import as_film
from ..spectral import WAVELENGTH_RANGE_NM
from .weights import (
    INTERPOLANT_ORDER,
    REFERENCE_STEP_NM,
    check_illuminant,
    colour_weights,
    interpolant_weights,
    product_weights,
    reference_wavelengths,
    sigma_range,
    wavenumber_nodes,
)

#: Wavelength step per cos theta band ``(cos_theta_lo, step_nm)``: each within 2e-4 dE2000 (module docstring).
REFERENCE_STEPS_NM = ((0.0, 0.01), (0.001, 0.05), (0.003, REFERENCE_STEP_NM))
#: Points x wavelengths per chunk of the spectral evaluation (bounds memory near 1.7 M complex samples).
_CHUNK_SAMPLES = 4096 * 421
#: The wavelength steps (nm) a thickness-scaled step is snapped down to; each divides the 420 nm range, so every
#: grid ends exactly on both ends of :data:`rockdove.spectral.WAVELENGTH_RANGE_NM`.
STEP_LADDER_NM = (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0)


def reference_step_nm(cos_theta, steps_nm=REFERENCE_STEPS_NM) -> np.ndarray:
    """Wavelength step (nm) of each ``cos_theta`` under the band table ``steps_nm``, same shape."""
    c = np.asarray(cos_theta, np.float64)
    step = np.full(c.shape, float(steps_nm[0][1]))
    for lo, s in steps_nm[1:]:
        step = np.where(c >= lo, float(s), step)
    return step


#: Interval counts of the wavenumber grids (about 9% apart), so that a process builds few sets of weights.
NODE_LADDER = tuple(sorted({int(round(16 * 1.09**k)) for k in range(80)}))


def interval_count(cos_theta, thickness_nm, film, kappa, max_step_rad) -> np.ndarray:
    """Intervals of the wavenumber grid per point (real films; module docstring): one interval's phase step at the
    steep (blue) end at most ``min(kappa * delta, max_step_rad)``, ``delta = -ln max|r_ab r_bc|`` (the larger, s,
    coefficients at both ends of the spectrum), rounded up to :data:`NODE_LADDER`."""
    c = np.asarray(cos_theta, np.float64)
    d = np.asarray(thickness_nm, np.float64)
    s_lo, s_hi = sigma_range()
    eps = 1e-4 * (s_hi - s_lo)
    n_a, n_c = float(film.n_incident), float(np.real(film.n_substrate))
    x = n_a * c
    x2 = x * x
    z = x if n_c == n_a else np.sqrt((n_c - n_a) * (n_c + n_a) + x2)
    rho = np.zeros(c.shape)
    q = []
    for sigma in (s_hi, s_hi - eps, s_lo):
        n_b = float(np.real(film.n_film(1.0 / sigma)))
        y = np.sqrt((n_b - n_a) * (n_b + n_a) + x2)  # n_b cos theta_b
        q.append(y)
        with np.errstate(invalid="ignore", divide="ignore"):
            ab = np.abs((x - y) * (y - z) / ((x + y) * (y + z)))
        np.fmax(rho, ab, out=rho)  # 0/0 (grazing, n_c = n_a): rho stays as it is, those points take R = 1
    slope = (4.0 * np.pi / eps) * d * (q[0] * s_hi - q[1] * (s_hi - eps))  # d phi / d sigma, rad nm
    with np.errstate(divide="ignore"):  # rho = 1 (grazing): step 0, no grid
        step = np.minimum(-kappa * np.log(rho), max_step_rad)
        need = slope * ((s_hi - s_lo) / step)
    ladder = np.asarray(NODE_LADDER)
    i = np.searchsorted(ladder, need, side="left")
    return np.where(i < ladder.size, ladder[np.minimum(i, ladder.size - 1)], 0)


#: Elements (points x wavelengths) per chunk of the real kernel: its float32 temporaries stay in the L2 cache.
_KERNEL_CHUNK = 1 << 15
#: Points with cos theta below this are evaluated in float64 (module docstring, "The real-film kernel").
FLOAT32_MIN_COS = 0.05


def real_film(film) -> bool:
    """True when :func:`_real_colour` applies: real indices (no absorption) and a film index at least the
    incident medium's at every wavelength (so no total internal reflection in the film for any angle) and a
    substrate index at least the incident medium's."""
    if film.k != 0 or isinstance(film.n_substrate, complex):
        return False
    n_b = np.real(film.n_film(np.asarray(WAVELENGTH_RANGE_NM, np.float64)))
    return bool(n_b.min() >= film.n_incident and film.n_substrate >= film.n_incident)


def _real_colour(wavelength_nm, weights, cos_theta, thickness_nm, film, dtype=np.float32):
    """``R @ weights`` (points, 3), ``R`` the unpolarised Airy reflectance of a real film (:func:`real_film`) at each
    point and wavelength in the transmission form (module docstring) in ``dtype``; ``cos_theta = 0`` gives R = 1."""
    lam = np.asarray(wavelength_nm, np.float64)
    n_a, n_c = float(film.n_incident), float(film.n_substrate)
    n_b = np.real(film.n_film(lam)).astype(np.float64)
    u = (n_b - n_a) * (n_b + n_a)  # q_b^2 = u + (n_a cos)^2
    inv_nb4 = 1.0 / n_b**4
    kk = 2.0 * np.pi / lam  # phi / 2 = kk d q_b
    white = weights.sum(axis=0)
    c = np.asarray(cos_theta, np.float64)
    ca2 = (n_a * c) ** 2
    q_c = n_a * c if n_c == n_a else np.sqrt((n_c - n_a) * (n_c + n_a) + ca2)
    # per polarisation and point: P = 4 x z, S = (x + z)^2, M = x^2 + z^2, Q = x^2 z^2 with x, z the admittances
    # of the incident medium and the substrate (s: n cos, p: cos / n)
    consts: list[list[Any]] = []
    symmetric = n_c == n_a  # then x = z and the terms reduce to P = S = 4 x^2 and x^2 (passed as Q)
    for x, z in ((n_a * c, q_c), (c / n_a, q_c / (n_c * n_c))):
        if symmetric:
            terms: tuple[Any, ...] = (4.0 * x * x, None, None, x * x)
        else:
            terms = (4.0 * x * z, (x + z) ** 2, x * x + z * z, (x * z) ** 2)
        consts.append([None if v is None else v.astype(dtype)[:, None] for v in terms])
    grazing = c == 0.0  # R = 1 (the limit of any film; the form below is 0/0 there when n_c = n_a)
    u32, inv32, kk32 = (v.astype(dtype)[None, :] for v in (u, inv_nb4, kk))
    ca32, d32 = ca2.astype(dtype)[:, None], np.asarray(thickness_nm, np.float64).astype(dtype)[:, None]
    w32 = weights.astype(dtype)
    out = np.empty((c.size, 3))
    rows_per = max(1, _KERNEL_CHUNK // lam.size)
    for i in range(0, c.size, rows_per):
        r = slice(i, i + rows_per)
        y = u32 + ca32[r]  # q_b^2
        s2 = np.sqrt(y)
        s2 *= kk32
        s2 *= d32[r]
        np.sin(s2, out=s2)
        s2 *= s2  # sin^2(phi / 2)
        t = None
        for pol, (p, s, m, q) in enumerate(consts):
            yp = y if pol == 0 else y * inv32  # the film's admittance squared
            if symmetric:  # x = z: S = P, (y^2 - x^2)(y^2 - z^2) = (y^2 - x^2)^2
                den = yp - q[r]
                den *= den
                den *= s2
                num = yp * p[r]
                den += num
            else:
                den = yp - m[r]
                den *= yp
                den += q[r]
                den *= s2
                num = yp * s[r]
                den += num
                np.multiply(yp, p[r], out=num)
            num /= den
            if t is None:
                t = num
            else:
                t += num
        # 1 - R = T = (T_s + T_p) / 2
        out[r] = white - 0.5 * (t @ w32)
    out[grazing] = white
    return out


def reference_colour(cos_theta, thickness_nm, film, *, illuminant="D65", colour_space="lin_rec709",
                     steps_nm=REFERENCE_STEPS_NM, calibrated_thickness_nm: float | None = None,
                     interpolation=None, order: int = INTERPOLANT_ORDER) -> np.ndarray:
    """The exact colour (linear, unclipped; CIE XYZ for ``colour_space=None``) of ``film`` at the broadcast points
    ``(cos_theta, thickness_nm)``: shape broadcast + (3,), float64.

    ``steps_nm`` is the wavelength step per cos theta band (:func:`reference_step_nm`), ``calibrated_thickness_nm``
    the thickness it was validated to, ``interpolation = (cos_theta_lo, kappa, max_step_rad)`` with ``order`` the
    wavenumber interpolant of real films (module docstring: steps, coarser steps, wavenumber interpolation).

    >>> [round(float(c), 3) for c in reference_colour(1.0, 650.0, "paper")]  # the seed paper's film, head-on
    [0.072, 0.107, 0.085]
    """
    film = as_film(film)
    c, d = np.broadcast_arrays(np.asarray(cos_theta, dtype=np.float64), np.asarray(thickness_nm, dtype=np.float64))
    shape = c.shape
    c, d = c.ravel(), d.ravel()
    out = np.empty((c.shape[0], 3))
    illuminant = check_illuminant(illuminant)
    direct = np.ones(c.shape[0], bool)
    if interpolation is not None and real_film(film):
        cos_lo, kappa, max_step_rad = (float(v) for v in interpolation)
        interp = np.nonzero(c >= cos_lo)[0]
        counts = interval_count(c[interp], d[interp], film, kappa, max_step_rad)
        interp, counts = interp[counts > 0], counts[counts > 0]
        direct[interp] = False
        # float32 where the kernel's terms cannot cancel, a film at least as dense as the substrate (module docstring)
        densest = np.real(film.n_film(np.asarray(WAVELENGTH_RANGE_NM, np.float64))).min() >= np.real(film.n_substrate)
        cos32 = FLOAT32_MIN_COS if densest else np.inf
        for n in np.unique(counts):
            rows = interp[counts == n]
            wl = wavenumber_nodes(int(n), order)
            w = interpolant_weights(int(n), order, illuminant=illuminant, colour_space=colour_space)
            for dtype, sel in ((np.float32, c[rows] >= cos32), (np.float64, c[rows] < cos32)):
                if sel.any():
                    out[rows[sel]] = _real_colour(wl, w, c[rows[sel]], d[rows[sel]], film, dtype)
    rest = np.nonzero(direct)[0]
    steps = reference_step_nm(c[rest], steps_nm)
    if calibrated_thickness_nm is not None:
        thick = d[rest] > float(calibrated_thickness_nm)
        # scaled, then snapped down to the largest STEP_LADDER_NM value not above it (the smallest below)
        ladder = np.asarray(STEP_LADDER_NM)
        i = np.searchsorted(ladder, steps[thick] * (float(calibrated_thickness_nm) / d[rest][thick]), side="right")
        steps[thick] = ladder[np.clip(i - 1, 0, ladder.size - 1)]
    # a real film's points off grazing take the real-film kernel in float64: optics.reflectance to 1e-14 (module
    # docstring, "The real-film kernel"); grazing ones (R = 1, but 0 for no film between equal media) optics itself
    kernel = (c[rest] > 0.0) & real_film(film)
    for step in np.unique(steps):
        sel = steps == step
        wl = reference_wavelengths(float(step))
        if step > REFERENCE_STEP_NM:
            w = product_weights(float(step), illuminant=illuminant, colour_space=colour_space)
        else:
            w = colour_weights(wl, illuminant=illuminant, colour_space=colour_space)
        rows = rest[sel & kernel]
        if rows.size:
            out[rows] = _real_colour(wl, w, c[rows], d[rows], film, np.float64)
        rows = rest[sel & ~kernel]
        if rows.size:
            out[rows] = sampled_colour(wl, w, c[rows], d[rows], film)
    return out.reshape(shape + (3,))


def sampled_colour(wl, w, c, d, film) -> np.ndarray:
    """``R @ w`` with ``R`` from :func:`rockdove.optics.reflectance` at the wavelengths ``wl`` (any film), chunked."""
    out = np.empty((c.shape[0], 3))
    n_film = film.n_film(wl)[None, :]
    chunk = max(1, _CHUNK_SAMPLES // wl.shape[0])
    for i in range(0, c.size, chunk):
        r = optics.reflectance(wl[None, :], c[i : i + chunk, None], d[i : i + chunk, None], n_film=n_film,
                               n_incident=film.n_incident, n_substrate=film.n_substrate)
        out[i : i + chunk] = r @ w
    return out


def delta_E(rgb_a, rgb_b, colour_space="lin_rec709", illuminant="D65") -> np.ndarray:
    """CIEDE2000 between two linear colours (shape (..., 3)) of the same colour space (working RGB, or XYZ when
    ``colour_space`` is None), in CIELAB with the white at Y = 1.

    >>> float(delta_E([0.2, 0.5, 0.3], [0.2, 0.5, 0.3]))
    0.0
    """
    xyz = [c if colour_space is None else spectral.RGB_to_XYZ(c, colour_space=colour_space) for c in (rgb_a, rgb_b)]
    check_illuminant(illuminant)  # spectral.XYZ_to_Lab uses the D65 reference white (Y = 1)
    return spectral.delta_E_2000(*map(spectral.XYZ_to_Lab, xyz))


def error_points(lut, n_points: int, seed: int, *, grazing_fraction: float = 0.1, grazing_cos: float = 0.05):
    """Random points ``(cos_theta, thickness_nm)`` of a LUT's domain, each (n_points,): cos theta uniform in [0, 1]
    but a ``grazing_fraction`` in ``[0, grazing_cos)`` (where colour changes fastest), 0 and 1 always included;
    thickness uniform over the LUT's range."""
    rng = np.random.default_rng(seed)
    n_graze = int(round(n_points * grazing_fraction))
    cos = np.concatenate([rng.uniform(0.0, grazing_cos, n_graze), rng.uniform(0.0, 1.0, n_points - n_graze)])
    if n_points >= 2:
        cos[0], cos[-1] = 0.0, 1.0
    lo, hi = lut.thickness_range_nm
    d = rng.uniform(lo, hi, n_points) if hi > lo else np.full(n_points, lo)
    return cos, d


def lut_error(lut, film, n_points: int = 2000, seed: int = 0, *, grazing_fraction: float = 0.1,
              grazing_cos: float = 0.05) -> dict:
    """CIEDE2000 of ``lut.sample`` against :func:`reference_colour` of ``film`` (the film it was baked for) at
    :func:`error_points`: a dict of ``max``, ``p99``, ``median``, ``mean``, ``worst_cos_theta``,
    ``worst_thickness_nm`` and the sampling's ``n_points``, ``seed``, ``grazing_fraction``, ``grazing_cos``."""
    if isinstance(n_points, bool) or not isinstance(n_points, (int, np.integer)) or n_points < 1:
        raise UsageError(f"n_points must be an integer >= 1, got {n_points!r}")
    if not 0.0 <= grazing_fraction <= 1.0:
        raise UsageError(f"grazing_fraction must be in [0, 1], got {grazing_fraction!r}")
    illuminant = lut.metadata.get("illuminant", "D65")
    cos, d = error_points(lut, int(n_points), seed, grazing_fraction=grazing_fraction, grazing_cos=grazing_cos)
    ref = reference_colour(cos, d, film, illuminant=illuminant, colour_space=lut.colour_space)
    de = delta_E(lut.sample(cos, d), ref, lut.colour_space, illuminant)
    k = int(np.argmax(de))
    return {"max": float(de.max()), "p99": float(np.percentile(de, 99)), "median": float(np.median(de)),
            "mean": float(de.mean()), "worst_cos_theta": float(cos[k]), "worst_thickness_nm": float(d[k]),
            "n_points": int(n_points), "seed": int(seed), "grazing_fraction": float(grazing_fraction),
            "grazing_cos": float(grazing_cos)}

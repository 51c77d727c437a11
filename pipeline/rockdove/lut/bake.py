"""Bakers of the thin-film colour LUT over (cos theta, film thickness) (registry :data:`BAKE_METHODS`).

``"spectral"``: :func:`rockdove.optics.reflectance` on a uniform wavelength grid (``spectral_step_nm``), then
``R @ W``: the baseline, for any film (absorbing, total internal reflection). ``"spectral_fast"``: the same for
real interface coefficients, the Fresnel coefficients once per (angle, wavelength) and the phase per texel (the
real Airy form, Born & Wolf, *Principles of Optics*, 7th ed., sec. 7.6.1), finer steps below ``grazing_cos``.
``"fourier"``: the exact Fourier route (:mod:`.fourier`) for non-dispersive real films (texels needing
more than ``max_terms`` terms, and d = 0, are integrated like the reference). ``"quadrature"``: product
integration in wavenumber (:mod:`.quadrature`), exact for any real-coefficient film. ``"auto"``: ``"fourier"``
where it applies, else ``"quadrature"`` (faster than ``"spectral_fast"`` and exact, ``rockdove bench lut``), else
``"spectral"``. Unpolarised light is the mean of s and p; the table layout is :mod:`.table`'s."""

from __future__ import annotations

import dataclasses
import numbers
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import optics
from ..config import Config, defaults
from ..errors import UsageError
from ..films import as_film
from ..spectral import DEFAULT_OBSERVER, WAVELENGTH_RANGE_NM, check_colour_space
from . import fourier
from .interfaces import interface_coefficients
from .quadrature import quadrature_colour, real_coefficients
from .reference import lut_error, real_film, reference_colour
from .table import ThinFilmLUT
from .weights import REFERENCE_STEP_NM, check_illuminant, colour_weights

# The table's defaults are the configuration schema's (its one source; tests/test_lut_bake.py pins bake() to it).
# On the gamma, ``rockdove bench lut`` (benchmarks/README.md): at 256 angles every gamma in 1-3 errs the same (max
# dE2000 ~0.05, set by the thickness axis' 3.5 nm spacing), and gamma > 1 only costs time.
_SCHEMA = Config(defaults())
DEFAULT_ANGLES, DEFAULT_THICKNESSES = _SCHEMA.lut.angles, _SCHEMA.lut.thicknesses
DEFAULT_ANGLE_WARP_GAMMA = _SCHEMA.lut.angle_warp_gamma
# bake() has no default range (a build bakes the mesh's): this is the standalone table's of ``rockdove lut`` and
# ``rockdove bench lut``, the measured preset's span (Yoshioka et al. 2007: 480-580 nm at the base, 600-700 at the top).
DEFAULT_THICKNESS_RANGE_NM = (480.0, 700.0)
# Terms dropped below 1e-4 (linear colour, white = 1): 9.3 terms per texel and a texel error <= 8e-4 dE2000 on the
# default grid (1e-3: 6.2 terms, 0.02; 1e-5: 13.9, 2e-4), under the LUT's interpolation error (~0.05).
DEFAULT_FOURIER_TOL = 1e-4
DEFAULT_MAX_TERMS = 512
DEFAULT_SPECTRAL_STEP_NM = 1.0
# spectral_fast: step outside / inside cos theta < DEFAULT_GRAZING_COS. On the default keratin LUT 2 / 0.25 nm errs
# as 1 / 0.1 nm (max 0.047, p99 0.037) in half the time; 1 nm in the band errs p99 0.10 (~1 nm wide resonances).
DEFAULT_FAST_STEP_NM = 2.0
DEFAULT_GRAZING_STEP_NM = 0.25
DEFAULT_GRAZING_COS = 0.05
# Below this the resonances are narrower than 0.25 nm (dE2000 0.2 at cos theta ~ 1e-3): sampled at 0.1 nm.
EXTREME_GRAZING_COS = 0.005

# Memory bound for the sampled methods: (texels x wavelengths) evaluated per chunk.
_CHUNK_ELEMENTS = 2_000_000
# The largest LUT (the schema's ranges): a 4096 x 4096 bake, its error check, EXR and preview stay within the 4 GiB
# budget (``rockdove bench memory``) and every GPU's texture limit.
MAX_ANGLES = MAX_THICKNESSES = 4096


def _check_count(name, value, minimum, maximum=None):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not (
            minimum <= value <= (maximum if maximum is not None else value)):
        within = f"in [{minimum}, {maximum}]" if maximum is not None else f">= {minimum}"
        raise UsageError(f"{name} must be an integer {within}, got {value!r}")
    return int(value)


def _check_positive(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a positive number, got {value!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise UsageError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def _check_range(thickness_range):
    try:
        lo, hi = (float(v) for v in thickness_range)
    except (TypeError, ValueError):
        raise UsageError(f"thickness_range must be a (lo, hi) pair of numbers in nm, got {thickness_range!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo < 0 or hi < lo:
        raise UsageError(f"thickness_range must satisfy 0 <= lo <= hi (nm, finite), got {thickness_range!r}")
    return lo, hi


def wavelength_grid(step_nm: float) -> np.ndarray:
    """Uniform wavelengths over 360-780 nm with the given step (nm), end points included when they fall on it."""
    lo, hi = WAVELENGTH_RANGE_NM
    return lo + step_nm * np.arange(int(np.floor((hi - lo) / step_nm + 1e-9)) + 1)


def _bake_spectral(cos_theta, thickness_nm, film, *, illuminant, colour_space, spectral_step_nm, **_):
    """Straightforward per-wavelength bake with :func:`rockdove.optics.reflectance`; shape (T, A, 3). Rows of
    texels at a time, so the Fresnel terms are computed per (angle, wavelength), not per texel."""
    wl = wavelength_grid(spectral_step_nm)
    w = colour_weights(wl, illuminant=illuminant, colour_space=colour_space)
    out = np.empty((thickness_nm.shape[0], cos_theta.shape[0], 3))
    rows = max(1, _CHUNK_ELEMENTS // max(1, cos_theta.shape[0] * wl.shape[0]))
    for i in range(0, thickness_nm.shape[0], rows):
        r = optics.reflectance(wl[None, None, :], cos_theta[None, :, None], thickness_nm[i : i + rows, None, None],
                               n_film=film.n_film(wl), n_incident=film.n_incident, n_substrate=film.n_substrate)
        out[i : i + rows] = r @ w
    return out, {"spectralStepNm": repr(float(spectral_step_nm))}


def sample_colour(cos_theta, thickness_nm, film, wavelength_nm, weights):
    """Colour (T, A, 3) of the texels ``thickness_nm`` (T,) x ``cos_theta`` (A,) of a film with real coefficients,
    ``R @ weights`` with the spectrum sampled at ``wavelength_nm`` (L,) in the real Airy form."""
    coef = interface_coefficients(film, cos_theta, wavelength_nm)
    if coef is None:
        raise UsageError(f"film {film.name!r} has complex interface coefficients; use method='spectral'")
    # Airy form in half-angle variables, stable near grazing (p = a b, s2 = sin^2(phi / 2), phi / 2 = 2 pi n_b
    # cos_b d / lambda): R = ((a + b)^2 - 4 p s2) / ((1 + p)^2 - 4 p s2). For p <= 0 (a film in air) the
    # denominator has no cancellation, so float32 (phase rounding ~2e-6 rad, R ~1e-7) halves memory traffic.
    products = [coef[f"a_{pol}"] * coef[f"b_{pol}"] for pol in ("s", "p")]
    dtype = np.float32 if max(float(p.max()) for p in products) <= 0.0 else np.float64
    half_k = (2.0 * np.pi * coef["n_b"] * coef["cos_b"] / wavelength_nm[None, :]).astype(dtype)
    terms = []
    degenerate = np.zeros(half_k.shape, bool)
    for pol, p in zip(("s", "p"), products):
        a, b = coef[f"a_{pol}"], coef[f"b_{pol}"]
        terms.append(tuple(v.astype(dtype) for v in ((a + b) ** 2, -4.0 * p, (1.0 + p) ** 2)))
        degenerate |= (1.0 + p) ** 2 == 0.0  # a b = -1 (cos theta = 0): R = 1 for any film with d > 0
    any_degenerate = bool(degenerate.any())
    w = np.asarray(weights, dtype=dtype)
    out = np.empty((thickness_nm.shape[0], cos_theta.shape[0], 3))
    rows = max(1, _CHUNK_ELEMENTS // max(1, cos_theta.shape[0] * wavelength_nm.shape[0]))
    for i in range(0, thickness_nm.shape[0], rows):
        s2 = np.sin(thickness_nm[i : i + rows, None, None].astype(dtype) * half_k[None])
        s2 *= s2
        r = np.zeros_like(s2)
        with np.errstate(invalid="ignore", divide="ignore"):
            for num0, slope, den0 in terms:
                x = slope * s2
                x_num = num0 + x
                x += den0
                x_num /= x
                r += x_num
        if any_degenerate:
            r[:, degenerate] = 2.0  # R = 1 for both polarisations
        out[i : i + rows] = (r @ w) * 0.5
    bare = thickness_nm == 0.0
    if np.any(bare):
        # no film: the bare incident | substrate interface (the Airy form's d -> 0 limit is ambiguous at grazing)
        r = optics.reflectance(wavelength_nm[None, :], cos_theta[:, None], 0.0, n_film=film.n_film(wavelength_nm),
                               n_incident=film.n_incident, n_substrate=film.n_substrate)
        out[bare] = (r @ weights)[None]
    return out


def _bake_spectral_fast(cos_theta, thickness_nm, film, *, illuminant, colour_space, fast_step_nm,
                        grazing_step_nm, grazing_cos, **_):
    out = np.empty((thickness_nm.shape[0], cos_theta.shape[0], 3))
    graze = cos_theta < grazing_cos
    # below cos theta ~ 5e-3 the resonances get narrower than any fixed step: sample like the reference there
    extreme = cos_theta < EXTREME_GRAZING_COS
    extreme_step = min(grazing_step_nm, REFERENCE_STEP_NM)
    bands = ((~graze, fast_step_nm), (graze & ~extreme, grazing_step_nm), (extreme, extreme_step))
    for mask, step in bands:
        if np.any(mask):
            wl = wavelength_grid(step)
            w = colour_weights(wl, illuminant=illuminant, colour_space=colour_space)
            out[:, mask] = sample_colour(cos_theta[mask], thickness_nm, film, wl, w)
    return out, {"spectralStepNm": repr(float(fast_step_nm)), "grazingStepNm": repr(float(grazing_step_nm)),
                 "grazingCosTheta": repr(float(grazing_cos)),
                 "extremeGrazing": f"cos_theta < {EXTREME_GRAZING_COS!r} at {extreme_step!r} nm"}


def fourier_supported(film) -> bool:
    """True when the exact Fourier form applies: non-dispersive, non-absorbing, real coefficients (no TIR)."""
    return not film.is_dispersive and real_film(film)


def _bake_fourier(cos_theta, thickness_nm, film, *, illuminant, colour_space, fourier_tol, max_terms, **_):
    if not fourier_supported(film):
        raise UsageError(f"method 'fourier' needs a non-dispersive, non-absorbing film without total internal "
                         f"reflection; film {film.name!r} is not (use 'spectral_fast', 'spectral' or 'auto')")
    table = fourier.g_table(illuminant, colour_space)
    coef = interface_coefficients(film, cos_theta, np.array([550.0]))  # any wavelength: no dispersion
    opd = 2.0 * float(coef["n_b"][0, 0]) * thickness_nm[:, None] * coef["cos_b"][None, :, 0]  # (T, A) nm
    cs = [fourier.airy_fourier_coefficients(coef[f"a_{pol}"][:, 0], coef[f"b_{pol}"][:, 0]) for pol in ("s", "p")]
    c0, c1, rho = (np.stack([c[i] for c in cs], axis=1) for i in range(3))  # (A, 2) each
    m = np.max([fourier.n_terms_needed(c1[None, :, p], rho[None, :, p], opd, table, fourier_tol) for p in (0, 1)],
               axis=0)
    fallback = (m > max_terms) | (opd <= 0.0)  # slow series, or no film (d = 0: the bare interface)
    m = np.where(fallback, 0, m)
    rgb = fourier.fourier_colour_grid(c0, c1, rho, opd, m, table)
    n_terms_total = np.broadcast_to(m.max(axis=0)[None, :], opd.shape)
    if np.any(fallback):
        # series too slow (OPD -> 0 with |rho| -> 1) or no film: the exact Airy spectrum at the reference step
        ti, aj = np.nonzero(fallback)
        rgb[ti, aj] = reference_colour(cos_theta[aj], thickness_nm[ti], film, illuminant=illuminant,
                                       colour_space=colour_space, steps_nm=((0.0, REFERENCE_STEP_NM),))
    return rgb, {"fourierTolerance": repr(float(fourier_tol)), "fourierMaxTerms": str(int(max_terms)),
                 "fourierTermsMean": f"{n_terms_total.mean():.2f}", "fourierTermsMax": str(int(n_terms_total.max())),
                 "fourierSampledTexels": f"{int(fallback.sum())} (at {REFERENCE_STEP_NM} nm)"}


def _bake_quadrature(cos_theta, thickness_nm, film, *, illuminant, colour_space, **_):
    return quadrature_colour(cos_theta, thickness_nm, film, illuminant=illuminant, colour_space=colour_space)


def _bake_auto(cos_theta, thickness_nm, film, **kw):
    if fourier_supported(film):
        return "fourier", _bake_fourier(cos_theta, thickness_nm, film, **kw)
    if real_coefficients(film, cos_theta):  # dispersive: product integration beats sampling (rockdove bench lut)
        return "quadrature", _bake_quadrature(cos_theta, thickness_nm, film, **kw)
    # absorbing film or substrate, or total internal reflection: the general path (accuracy not benchmarked)
    return "spectral", _bake_spectral(cos_theta, thickness_nm, film, **kw)


#: Supported bake methods: name -> implementation (``"auto"`` picks among the others).
BAKE_METHODS: dict[str, Callable[..., Any]] = {"auto": _bake_auto, "fourier": _bake_fourier,
                                               "spectral_fast": _bake_spectral_fast, "quadrature": _bake_quadrature,
                                               "spectral": _bake_spectral}


def bake(*, thickness_range, angles: int = DEFAULT_ANGLES, thicknesses: int = DEFAULT_THICKNESSES,
         film=_SCHEMA.film.model, method: str = _SCHEMA.lut.method, angle_warp_gamma: float = DEFAULT_ANGLE_WARP_GAMMA,
         colour_space: str = _SCHEMA.lut.colour_space, illuminant: str = "D65",
         spectral_step_nm: float = DEFAULT_SPECTRAL_STEP_NM, fast_step_nm: float = DEFAULT_FAST_STEP_NM,
         grazing_step_nm: float = DEFAULT_GRAZING_STEP_NM, grazing_cos: float = DEFAULT_GRAZING_COS,
         fourier_tol: float = DEFAULT_FOURIER_TOL, max_terms: int = DEFAULT_MAX_TERMS, error_points: int = 0,
         error_seed: int = 0) -> ThinFilmLUT:
    """Bake structural colour over (cos theta, thickness) into a :class:`ThinFilmLUT` (rgb (n_thickness, angles, 3)
    float32; the metadata record the film, illuminant, observer, colour space, method and its parameters). The
    arguments a build configures default to the schema's ``lut.*`` and ``film.model``; ``thickness_range`` has none.

    ``angles >= 2`` nodes ``cos_theta_j = (j / (angles - 1)) ** angle_warp_gamma`` (``gamma > 1`` puts texels near
    grazing); ``thicknesses >= 1`` nodes uniform over ``thickness_range = (lo, hi)`` nm, ``0 <= lo <= hi`` (1, or
    ``lo == hi``, gives the paper's one-texel-high LUT at the mid-point). ``film``: ``"paper"`` (n = 1.5),
    ``"keratin"`` (dispersive) or any :class:`rockdove.films.FilmModel`; ``method`` one of :data:`BAKE_METHODS`;
    ``colour_space`` ``lin_rec709`` or ``acescg``. Method parameters: ``spectral_step_nm`` (``"spectral"``);
    ``fast_step_nm`` / ``grazing_step_nm`` outside / inside ``cos theta < grazing_cos`` (``"spectral_fast"``);
    ``fourier_tol`` (linear colour) below which Fourier terms are dropped, and ``max_terms``, beyond which a
    texel is integrated at 0.1 nm instead (``"fourier"``). ``error_points > 0`` measures the LUT against the exact
    reference at that many random points (seed ``error_seed``; :func:`rockdove.lut.reference.lut_error`) and
    records max / p99 / median dE2000 in the metadata.

    >>> lut = bake(angles=8, thicknesses=4, thickness_range=(500.0, 700.0), film="paper")
    >>> lut.rgb.shape, lut.thickness_range_nm
    ((4, 8, 3), (500.0, 700.0))
    """
    angles = _check_count("angles", angles, 2, MAX_ANGLES)
    thicknesses = _check_count("thicknesses", thicknesses, 1, MAX_THICKNESSES)
    lo, hi = _check_range(thickness_range)
    film_model = as_film(film)
    if not isinstance(method, str) or method not in BAKE_METHODS:
        raise UsageError(f"method must be one of {sorted(BAKE_METHODS)}, got {method!r}")
    gamma = _check_positive("angle_warp_gamma", angle_warp_gamma)
    colour_space = check_colour_space(colour_space)
    illuminant = check_illuminant(illuminant)
    kw = dict(illuminant=illuminant, colour_space=colour_space,
              spectral_step_nm=_check_positive("spectral_step_nm", spectral_step_nm),
              fast_step_nm=_check_positive("fast_step_nm", fast_step_nm),
              grazing_step_nm=_check_positive("grazing_step_nm", grazing_step_nm),
              grazing_cos=_check_positive("grazing_cos", grazing_cos),
              fourier_tol=_check_positive("fourier_tol", fourier_tol),
              max_terms=_check_count("max_terms", max_terms, 0))
    error_points = _check_count("error_points", error_points, 0)

    if thicknesses == 1 or lo == hi:
        lo = hi = 0.5 * (lo + hi)
        thicknesses = 1
    cos_theta = np.linspace(0.0, 1.0, angles) ** gamma
    thickness_nm = np.linspace(lo, hi, thicknesses)

    result = BAKE_METHODS[method](cos_theta, thickness_nm, film_model, **kw)
    used, (rgb, meta) = result if method == "auto" else (method, result)  # "auto" says which method it used
    metadata = {f"film:{k}": v for k, v in film_model.describe().items()}
    metadata.update({"film": film_model.name, "illuminant": illuminant, "observer": DEFAULT_OBSERVER,
                     "wavelengthRangeNm": f"{WAVELENGTH_RANGE_NM[0]!r} {WAVELENGTH_RANGE_NM[1]!r}",
                     "polarization": "unpolarized (mean of s and p)", "method": used, "methodRequested": method,
                     "estimatedError": "not measured at bake time (bake(error_points=0))"})
    metadata.update({f"method:{k}": v for k, v in meta.items()})
    lut = ThinFilmLUT(rgb.astype(np.float32), (lo, hi), angle_warp_gamma=gamma, colour_space=colour_space,
                      metadata=metadata)
    if error_points:
        err = lut_error(lut, film_model, n_points=error_points, seed=error_seed)
        lut = dataclasses.replace(lut, metadata={**metadata, **error_metadata(err)})
    return lut


def as_shipped(lut: ThinFilmLUT, film, precision: str, error_points: int) -> ThinFilmLUT:
    """``lut`` as its EXR holds it (``precision`` ``"half"``: rounded to half floats, as :mod:`rockdove.lut.exr`
    writes HALF channels for metadata precision "half"), its header carrying its error against the exact
    reference at ``error_points`` random points (:func:`rockdove.lut.reference.lut_error`)."""
    rgb, metadata = lut.rgb, dict(lut.metadata)
    if precision == "half":
        rgb = lut.rgb.astype(np.float16).astype(np.float32)
        metadata["precision"] = "half"
    lut = dataclasses.replace(lut, rgb=rgb, metadata=metadata)
    return dataclasses.replace(lut, metadata={**metadata, **error_metadata(lut_error(lut, film, n_points=error_points))})


def error_metadata(err: dict) -> dict[str, str]:
    """Header strings of a :func:`rockdove.lut.reference.lut_error` result."""
    return {
        "estimatedError": f"max dE2000 {err['max']:.4g}, p99 {err['p99']:.4g} against the exact Airy reference",
        "estimatedMaxDeltaE2000": f"{err['max']:.4g}",
        "estimatedP99DeltaE2000": f"{err['p99']:.4g}",
        "estimatedMedianDeltaE2000": f"{err['median']:.4g}",
        "estimatedErrorSample": f"{err['n_points']} random points, seed {err['seed']}, "
        f"{err['grazing_fraction']:.0%} with cos_theta < {err['grazing_cos']}",
    }

"""Airy reflectance and transmittance of one thin film (s, p and unpolarised light).

Light arrives from a transparent incident medium a (``n_incident``, real) at ``cos_theta = cos(theta_a)`` onto a
film b (``n_film``, thickness d) on a semi-infinite substrate c (``n_substrate``); complex indices are ``n + i k``,
``k >= 0`` absorbing (the convention of ``tmm`` and ``colour.phenomena``, :mod:`rockdove.films`).

Normal wave-vector components (in units of k0 = 2 pi / lambda), by Snell's law n_j sin(theta_j) = n_a sin(theta_a):

    q_j = n_j cos(theta_j) = sqrt(n_j**2 - n_a**2 sin(theta_a)**2)
        = sqrt((n_j - n_a)(n_j + n_a) + (n_a cos_theta)**2)                                   (1)

evaluated in the second form so that n_j == n_a gives q_j = n_a cos_theta exactly, on the branch Im(q_j) >= 0:
beyond the critical angle q_j = +i |q_j|, an evanescent wave decaying away from the interface.

Fresnel amplitude coefficients (Born & Wolf, Principles of Optics, 7th ed., sec. 1.5.2; ``tmm``'s convention):

    r_s = (n1 cos1 - n2 cos2) / (n1 cos1 + n2 cos2),    r_p = (n2 cos1 - n1 cos2) / (n2 cos1 + n1 cos2)  (2)

i.e. r = (eta_1 - eta_2) / (eta_1 + eta_2) with the (tilted) admittances eta_s = q, eta_p = q / n**2.

Airy summation of the waves reflected in the film (Born & Wolf sec. 1.6.4 and 7.6.1; Heavens, Optical Properties
of Thin Solid Films, 1955):

    r = (r_ab + r_bc e^{i phi}) / (1 + r_ab r_bc e^{i phi}),    phi = 4 pi n_b d cos(theta_b) / lambda  (3)

``phi`` is :func:`film_phase`. Eq. (3) is 0/0 where q_b -> 0 (a film at its own critical angle) and overflows for
thick evanescent films, so it is evaluated in the identical characteristic-matrix form (Born & Wolf sec. 1.6.2;
Macleod, Thin-Film Optical Filters, ch. 2, for n + ik), with delta = phi / 2 = k0 q_b d:

    B = cos(delta) - i eta_c sin(delta) / eta_b,    C = eta_c cos(delta) - i eta_b sin(delta)
    r = (eta_a B - C) / (eta_a B + C),               t-power  T = 4 eta_a Re(eta_c) / |eta_a B + C|**2    (4)

where sin(delta) / eta_b = k0 d (q_b / eta_b) sinc(delta) has no 0/0. The complex path multiplies B and C
by e^{i delta} (|e^{i delta}| <= 1) and uses expm1: no overflow (films of millimetres, deep TIR), no loss of
precision far below 1 nm. T is the ratio of the normal power fluxes. For real indices without TIR, eq. (4) is a
sum of squares in real arithmetic (the fast path, an order of magnitude cheaper):

    R = [(eta_a - eta_c)**2 cos**2 + (eta_a eta_c S - eta_b sin)**2] / Den,   T = 4 eta_a eta_c / Den,
    Den = (eta_a + eta_c)**2 cos**2 + (eta_a eta_c S + eta_b sin)**2,   S = sin(delta) / eta_b.

Limits: at grazing incidence (eta_a = 0) R = 1 and T = 0 for any stack; at d = 0, the bare a|c Fresnel value;
where every interface vanishes (equal indices at grazing, the only 0/0 left in eq. 4) R = 0, T = 1."""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import UsageError

POLARIZATIONS = ("s", "p", "unpolarized")

_TWO_PI = 2.0 * np.pi


# --------------------------------------------------------------------------- validation helpers
def _as_real(name: str, value, *, lo: float, lo_open: bool = False, hi: float | None = None) -> np.ndarray:
    """float64 array of ``value`` checked to be finite and within [lo, hi] (or (lo, hi])."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be real numbers, got {value!r}") from None
    bad = ~np.isfinite(a) | ((a <= lo) if lo_open else (a < lo))
    if hi is not None:
        bad |= a > hi
    if bad.any():
        first = a[bad].flat[0].item()
        allowed = f"{'(' if lo_open else '['}{lo:g}, {'inf)' if hi is None else f'{hi:g}]'}"
        raise UsageError(f"{name} must be finite and in {allowed}, got {first!r}")
    return a


def _as_index(name: str, value, wavelength_nm: np.ndarray | None = None, *, real_only: bool = False):
    """A refractive index as a float64 or complex128 array (float64 when its imaginary part is 0). ``value`` is a
    number, an array broadcastable with the wavelengths, or a callable n(wavelength_nm). Allowed: finite, Re(n) > 0,
    Im(n) >= 0 (n + ik convention); ``real_only`` additionally Im(n) == 0."""
    if callable(value):
        if wavelength_nm is None:
            raise UsageError(f"{name} is a callable but no wavelength_nm was given to evaluate it")
        value = value(wavelength_nm)
    try:
        a = np.asarray(value)
        if a.dtype.kind not in "iufc":
            raise TypeError
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number, an array or a callable n(wavelength_nm), got {value!r}") from None
    orig = a
    if a.dtype.kind == "c":
        re, im = a.real, a.imag
        if a.size and not np.any(im):
            a = np.ascontiguousarray(re, dtype=np.float64)
        else:
            a = a.astype(np.complex128, copy=False)
    else:
        a = a.astype(np.float64, copy=False)
        re, im = a, None
    if a.size == 0:
        return a
    bad = ~np.isfinite(re) | (re <= 0)
    if im is not None:
        bad |= ~np.isfinite(im) | (im < 0)
        if real_only:
            bad |= im != 0
    if bad.any():
        first = orig[bad].flat[0].item()
        allowed = "a finite real number > 0 (the incident medium must be transparent)" if real_only \
            else "finite with real part > 0 and imaginary part >= 0 (n + ik, k >= 0 absorbs)"
        raise UsageError(f"{name} must be {allowed}, got {first!r}")
    return a


# --------------------------------------------------------------------------- public helpers
def _q_squared(n_j, n_a, cos_a):
    """(n_j cos theta_j)**2 = (n_j - n_a)(n_j + n_a) + (n_a cos_a)**2, eq. (1)."""
    nc = n_a * cos_a
    return (n_j - n_a) * (n_j + n_a) + nc * nc


def _q(q2, n_j, n_a, cos_a, real: bool | None = None):
    """q_j = n_j cos(theta_j) from q_j**2 (eq. 1): the real root if ``real`` (q2 >= 0; None: wherever possible),
    else the decaying branch. Where n_j == n_a, q_j = n_a cos_a exactly (no underflow of cos_a**2 at grazing)."""
    if real is None:
        real = q2.dtype.kind != "c" and (q2.size == 0 or q2.min() >= 0)
    q = np.sqrt(q2 if real else np.asarray(q2, dtype=np.complex128))
    if not real:  # the root with Im >= 0 (decaying evanescent / absorbed wave), eq. (1)
        q = np.where(q.imag < 0, -q, q)
    same = np.asarray(n_j == n_a)
    if same.any():
        q = np.where(same, n_a * cos_a, q)
    return q


def snell_cos(n1, n2, cos1):
    """Cosine of the refraction angle into medium ``n2`` (n + ik) from the real ``n1`` at ``cos1`` in [0, 1]
    (Snell's law): ``q2 / n2`` on the branch Im(q2) >= 0 of eq. (1); float64 when every result is real, else
    complex128 (purely imaginary beyond the critical angle).

    >>> float(snell_cos(1.0, 1.5, 1.0))  # normal incidence stays normal
    1.0
    """
    n1 = _as_index("n1", n1, real_only=True)
    n2 = _as_index("n2", n2)
    cos1 = _as_real("cos1", cos1, lo=0.0, hi=1.0)
    return _q(_q_squared(n2, n1, cos1), n2, n1, cos1) / n2


def fresnel_r(n1, n2, cos1, cos2, polarization):
    """Fresnel amplitude reflection coefficient of the interface 1|2 for ``polarization`` "s" or "p" (eq. 2, the
    Born & Wolf and ``tmm`` convention, with which eq. 3 holds for both), ``cos2`` from :func:`snell_cos`; float64
    if every input is real. Where both media are the same at grazing incidence (0/0), r = 0 (no interface).

    >>> round(float(fresnel_r(1.0, 1.5, 1.0, 1.0, "s")), 4)  # air | glass at normal incidence: (1 - n) / (1 + n)
    -0.2
    """
    if polarization not in ("s", "p"):
        raise UsageError(f"polarization must be 's' or 'p', got {polarization!r}")
    n1, n2, cos1, cos2 = (np.asarray(x) for x in (n1, n2, cos1, cos2))
    if polarization == "s":
        num, den = n1 * cos1 - n2 * cos2, n1 * cos1 + n2 * cos2
    else:
        num, den = n2 * cos1 - n1 * cos2, n2 * cos1 + n1 * cos2
    zero = den == 0
    den = np.where(zero, 1.0, den)
    if den.dtype.kind == "c":  # scale first: complex division of subnormal values returns NaN
        m = np.maximum(np.abs(den.real), np.abs(den.imag))
        num = num.real / m + 1j * (num.imag / m)
        den = den.real / m + 1j * (den.imag / m)
    return np.where(zero, 0.0, num / den)


def film_phase(wavelength_nm, cos_theta, thickness_nm, n_film, n_incident=1.0):
    """Round-trip phase difference of the film, ``phi = 4 pi n_b d cos(theta_b) / lambda`` (eq. 3), radians, with
    ``cos_theta`` in the incident medium: float64 for a transparent film short of its critical angle, else
    complex128 (Im(phi) >= 0: ``e^{i phi}`` is the attenuation of one round trip).

    >>> round(float(film_phase(600.0, 1.0, 100.0, 1.5)), 4)  # n d = lambda / 4: half a wave there and back
    3.1416
    """
    lam = _as_real("wavelength_nm", wavelength_nm, lo=0.0, lo_open=True)
    cos_theta = _as_real("cos_theta", cos_theta, lo=0.0, hi=1.0)
    d = _as_real("thickness_nm", thickness_nm, lo=0.0)
    n_b = _as_index("n_film", n_film, lam)
    n_a = _as_index("n_incident", n_incident, lam, real_only=True)
    return (2.0 * _TWO_PI) * d * _q(_q_squared(n_b, n_a, cos_theta), n_b, n_a, cos_theta) / lam


# --------------------------------------------------------------------------- the solver
def _fast_real(k0d, cos_a, n_a, n_b, n_c, qb, qc, pols, want_t):
    """Eq. (4) in real arithmetic (real indices, q_b > 0, q_c >= 0): ``({pol: (R, T or None)}, degenerate)``; if
    ``degenerate``, NaN elements (0/0) are for the complex path. With u = sin(delta)**2, R = (a0 + a1 u) / (b0 + b1 u)
    with coefficients of (wavelength, angle) only: a0 = (eta_a - eta_c)**2, a1 = (eta_a eta_c / eta_b - eta_b)**2 - a0,
    b0 = (eta_a + eta_c)**2, b1 = (eta_a eta_c / eta_b + eta_b)**2 - b0: one sine and a division per sample."""
    u = np.square(np.sin(np.asarray(k0d * qb, dtype=np.float64)))  # sin(delta)**2
    out = {}
    degenerate = False
    for pol in pols:
        if pol == "s":
            ea, eb, ec = n_a * cos_a, qb, qc
        else:
            ea, eb, ec = cos_a / n_a, qb / (n_b * n_b), qc / (n_c * n_c)
        eaec = ea * ec
        a0 = (ea - ec) ** 2
        b0 = (ea + ec) ** 2
        a1 = (eaec / eb - eb) ** 2 - a0
        b1 = (eaec / eb + eb) ** 2 - b0
        den = b1 * u  # in place from here: the arrays have the output's size
        den += b0
        num = a1 * u
        num += a0
        # den == 0 only where eta_a = eta_c = 0 (grazing, substrate of the incident index) and u = 0:
        # the result is NaN there and _solve hands those elements to the complex path (as it would any
        # overflow of a1, b1, which the range of q_b**2 > 0 rules out in practice).
        with np.errstate(invalid="ignore", divide="ignore"):
            num /= den
            out[pol] = (num, np.divide(4.0 * eaec, den) if want_t else None)
        degenerate = degenerate or bool(np.any(b0 == 0)) or not (np.all(np.isfinite(a1)) and np.all(np.isfinite(b1)))
    return out, degenerate


def _general_complex(k0d, cos_a, n_a, n_b, n_c, qb, qc, pols, want_t=True):
    """Eq. (4) in complex arithmetic (absorption, TIR), scaled by e^{i delta}. Returns {pol: (R, T)}."""
    delta = k0d * qb
    two_i_delta = 2j * delta
    em = np.expm1(two_i_delta)  # e^{2 i delta} - 1, precise for tiny delta, bounded for Im(delta) > 0
    c_e = 1.0 + 0.5 * em  # cos(delta) e^{i delta}
    s_e = em / 2j  # sin(delta) e^{i delta}
    # sin(delta) e^{i delta} / delta = expm1(z) / z with z = 2 i delta; a Taylor series for |z| < 1e-4
    # (truncation < 1e-18) avoids 0/0 at delta = 0 and complex-division overflow for subnormal delta.
    z = np.asarray(two_i_delta)
    sinc_e = np.array(1.0 + z * (0.5 + z * (1.0 / 6.0 + z * (1.0 / 24.0))), dtype=np.complex128)
    big = np.abs(z) >= 1e-4
    np.divide(em, z, out=sinc_e, where=big)
    atten = np.exp(-2.0 * delta.imag)  # |e^{i delta}|**2
    out = {}
    for pol in pols:
        if pol == "s":
            ea, eb, ec = n_a * cos_a, qb, qc
            ratio = 1.0  # q_b / eta_b
        else:
            ea, eb, ec = cos_a / n_a, qb / (n_b * n_b), qc / (n_c * n_c)
            ratio = n_b * n_b
        big_l = k0d * ratio * sinc_e  # sin(delta) e^{i delta} / eta_b
        b = c_e - 1j * ec * big_l
        c = ec * c_e - 1j * eb * s_e
        num = ea * b - c
        den = ea * b + c
        # |num|^2 / |den|^2 scaled by m = max(|Re den|, |Im den|) so that tiny (subnormal) terms near
        # grazing incidence do not underflow to 0/0.
        m = np.maximum(np.abs(den.real), np.abs(den.imag))
        zero = m == 0
        m = np.where(zero, 1.0, m)
        den2 = (den.real / m) ** 2 + (den.imag / m) ** 2
        den2 = np.where(zero, 1.0, den2)  # where every interface vanishes: R = 0, T = 1
        r_pow = np.where(zero, 0.0, ((num.real / m) ** 2 + (num.imag / m) ** 2) / den2)
        t_pow = np.where(zero, 1.0, 4.0 * (ea / m) * (np.real(ec) / m) * atten / den2) if want_t else None
        out[pol] = (r_pow, t_pow)
    return out


def _solve(wavelength_nm, cos_theta, thickness_nm, n_film, n_incident, n_substrate, polarization, want_t):
    """Validate, pick the fast or complex path per element, return R (T with ``want_t``) as a float64 array."""
    if polarization not in POLARIZATIONS:
        raise UsageError(f"polarization must be one of {POLARIZATIONS}, got {polarization!r}")
    lam = _as_real("wavelength_nm", wavelength_nm, lo=0.0, lo_open=True)
    cos_a = _as_real("cos_theta", cos_theta, lo=0.0, hi=1.0)
    d = _as_real("thickness_nm", thickness_nm, lo=0.0)
    n_b = _as_index("n_film", n_film, lam)
    n_a = _as_index("n_incident", n_incident, lam, real_only=True)
    n_c = _as_index("n_substrate", n_substrate, lam)
    try:
        shape = np.broadcast_shapes(lam.shape, cos_a.shape, d.shape, n_a.shape, n_b.shape, n_c.shape)
    except ValueError:
        raise UsageError("wavelength_nm, cos_theta, thickness_nm, n_film, n_incident, n_substrate must broadcast "
                         f"together, got shapes {lam.shape}, {cos_a.shape}, {d.shape}, {n_b.shape}, {n_a.shape}, "
                         f"{n_c.shape}") from None
    pols = ("s", "p") if polarization == "unpolarized" else (polarization,)

    k0d = (_TWO_PI * d) / lam
    qb2 = _q_squared(n_b, n_a, cos_a)
    qc2 = _q_squared(n_c, n_a, cos_a)
    real = qb2.dtype.kind != "c" and qc2.dtype.kind != "c"
    fast: Any = (qb2 > 0) & (qc2 >= 0) if real else None
    all_fast = real and bool(np.all(fast))

    if real and (all_fast or np.any(fast)):
        # Real arithmetic wherever it is valid; the complex path on the rest (TIR, q_b = 0, and the 0/0
        # elements the fast path flags).
        with np.errstate(invalid="ignore", divide="ignore"):
            res, degenerate = _fast_real(k0d, cos_a, n_a, n_b, n_c, _q(np.maximum(qb2, 0), n_b, n_a, cos_a, True),
                                         _q(np.maximum(qc2, 0), n_c, n_a, cos_a, True), pols, want_t)
        slow = ~np.broadcast_to(fast, shape)
        for pol in pols if degenerate else ():
            slow = slow | np.isnan(res[pol][0])
        if slow.any():
            k0d_s, cos_s, na_s, nb_s, nc_s, qb2_s, qc2_s = (np.broadcast_to(x, shape)[slow]
                                                            for x in (k0d, cos_a, n_a, n_b, n_c, qb2, qc2))
            res_slow = _general_complex(k0d_s, cos_s, na_s, nb_s, nc_s, _q(qb2_s + 0j, nb_s, na_s, cos_s, False),
                                        _q(qc2_s + 0j, nc_s, na_s, cos_s, False), pols, want_t)
            for pol in pols:
                fixed = []
                for full, part in zip(res[pol], res_slow[pol]):
                    if full is not None:
                        full = np.array(np.broadcast_to(full, shape), dtype=np.float64)
                        full[slow] = part
                    fixed.append(full)
                res[pol] = tuple(fixed)
    else:
        res = _general_complex(k0d, cos_a, n_a, n_b, n_c, _q(qb2, n_b, n_a, cos_a, False),
                               _q(qc2, n_c, n_a, cos_a, False), pols, want_t)

    k = 1 if want_t else 0
    if polarization == "unpolarized":
        v = res["s"][k] + res["p"][k]
        v *= 0.5
    else:
        v = res[polarization][k]
    return np.clip(np.broadcast_to(np.asarray(v, dtype=np.float64), shape), 0.0, 1.0)  # rounding: 1e-16


def reflectance(wavelength_nm, cos_theta, thickness_nm, *, n_film, n_incident=1.0, n_substrate=1.0,
                polarization="unpolarized"):
    """Reflectance R = |r|**2 of one film (Airy summation, eqs. 3-4 of the module docstring), float64 in [0, 1],
    the broadcast shape of all array arguments.

    ``wavelength_nm`` (vacuum, > 0) and ``thickness_nm`` (>= 0; 0: the bare incident|substrate interface) in nm;
    ``cos_theta`` in [0, 1] in the incident medium. ``n_film`` and ``n_substrate``: a number, an array broadcast
    against the other arguments (give it the wavelengths' shape) or a callable n(wavelength_nm), n + ik with k >= 0;
    ``n_incident`` real. "unpolarized" is the mean of s and p. A ValueError names the offending argument and value.
    Real indices without TIR take the real fast path (one sine per sample), the rest the complex path, both exact
    to rounding; memory is a few float64 arrays of the output shape (chunk calls above ~1e7 samples).

    >>> round(float(reflectance(600.0, 1.0, 100.0, n_film=1.5)), 4)  # a quarter-wave film in air: the maximum
    0.1479
    >>> float(reflectance(550.0, 1.0, 0.0, n_film=1.5))  # no film, air on both sides: no interface
    0.0
    """
    return _solve(wavelength_nm, cos_theta, thickness_nm, n_film, n_incident, n_substrate, polarization, False)


def transmittance(wavelength_nm, cos_theta, thickness_nm, *, n_film, n_incident=1.0, n_substrate=1.0,
                  polarization="unpolarized"):
    """Transmittance T in [0, 1] into the substrate, the ratio of normal power fluxes (eq. 4); the arguments of
    :func:`reflectance`. R + T = 1 to rounding without absorption, < 1 with it; T = 0 beyond the substrate's
    critical angle.

    >>> args = (550.0, 0.8, 100.0)
    >>> round(float(reflectance(*args, n_film=1.5) + transmittance(*args, n_film=1.5)), 12)  # R + T = 1
    1.0
    """
    return _solve(wavelength_nm, cos_theta, thickness_nm, n_film, n_incident, n_substrate, polarization, True)

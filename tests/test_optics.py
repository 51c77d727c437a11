"""Laws of thin-film optics checked on rockdove.optics, and agreement with two independent oracles.

Oracles and their limits (measured here, see each test):
- ``tmm.coh_tmm`` (Byrnes): n + ik convention like ours, angle in radians, handles complex indices and TIR.
  It computes cos(theta_j) as cos(arcsin(...)), which loses ~1e-9 in R within cos_theta < 1e-2 of
  grazing incidence, and at exactly 90 degrees it returns nonsense (T = 25 for an absorbing substrate);
  near grazing the test uses an extended-precision (np.clongdouble) Airy sum instead.
- ``colour.phenomena.thin_film_tmm``: angle in degrees; it refracts with the REAL part of the indices and
  a real arcsin, so it is only exact for transparent media without total internal reflection (NaN
  beyond the critical angle) and for complex indices only at normal incidence.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rockdove import optics
from rockdove.optics import film_phase, fresnel_r, reflectance, snell_cos, transmittance

TOL = 1e-10
PROPS = settings(max_examples=150, deadline=None)

indices = st.floats(1.0, 3.0)
cosines = st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1.0]))
wavelengths = st.floats(360.0, 780.0)
thicknesses = st.one_of(st.floats(0.0, 3000.0), st.sampled_from([0.0, 1e-6, 0.5, 1e4, 1e6]))
extinctions = st.one_of(st.just(0.0), st.floats(0.0, 3.0))
pols = st.sampled_from(["s", "p"])


def _both(lam, c, d, nb, na=1.0, nc=1.0, pol="unpolarized"):
    kw = dict(n_film=nb, n_incident=na, n_substrate=nc, polarization=pol)
    return reflectance(lam, c, d, **kw), transmittance(lam, c, d, **kw)


def _random_stacks(rng, n):
    """n random (lam, cos, d, n_a, n_b, n_c) with complex films/substrates and TIR cases."""
    cases = []
    for i in range(n):
        kind = i % 5
        lam = rng.uniform(360, 780)
        c = 1.0 if i % 17 == 0 else rng.uniform(0.01, 1.0)
        na, nb, nc = rng.uniform(1.0, 2.0), rng.uniform(1.0, 2.5), rng.uniform(1.0, 2.5)
        if kind == 1:  # absorbing film
            nb = nb + 1j * rng.uniform(0.0, 2.0)
        elif kind == 2:  # absorbing (metal-like) substrate
            nc = nc + 1j * rng.uniform(0.0, 4.0)
        elif kind == 3:  # dense incident medium: TIR in the film and/or the substrate
            na, nb, nc = rng.uniform(1.6, 2.5), rng.uniform(1.0, 1.5), rng.uniform(1.0, 2.5)
        d = 0.0 if i % 23 == 0 else rng.uniform(0.0, 3000.0)
        cases.append((lam, c, d, na, nb, nc))
    return cases


def test_agrees_with_tmm_coh_tmm_including_complex_indices_and_tir():
    import tmm  # a declared test dependency: the oracle must not vanish with the environment
    rng = np.random.default_rng(20261122)
    cases = _random_stacks(rng, 300)
    n_tir = sum(1 for lam, c, d, na, nb, nc in cases if na**2 * (1 - c * c) > min(nb.real, nc.real) ** 2)
    assert n_tir > 20  # the sample really contains total internal reflection
    worst = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # tmm's "almost opaque layer" notice
        for lam, c, d, na, nb, nc in cases:
            for pol in "sp":
                ref = tmm.coh_tmm(pol, [na, nb, nc], [np.inf, d, np.inf], np.arccos(c), lam)
                r, t = _both(lam, c, d, nb, na, nc, pol)
                worst = max(worst, abs(r - ref["R"]), abs(t - ref["T"]))
    assert worst <= TOL, worst


def _airy_longdouble(lam, c, d, na, nb, nc, pol):
    """Eq. (3) of rockdove.optics in extended precision (x87 80-bit): an oracle near grazing incidence."""
    L, C = np.longdouble, np.clongdouble
    lam, c, d, na, nb, nc = L(lam), L(c), L(d), L(na), C(nb), C(nc)

    def q(n):
        s = np.sqrt((n - na) * (n + na) + (na * c) ** 2)
        return -s if s.imag < 0 else s

    qa, qb, qc = C(na * c), q(nb), q(nc)
    ea, eb, ec = (qa, qb, qc) if pol == "s" else (qa / na**2, qb / nb**2, qc / nc**2)
    r1, r2 = (ea - eb) / (ea + eb), (eb - ec) / (eb + ec)
    e = np.exp(C(4j) * C(np.pi) * d * qb / lam)
    return float(abs((r1 + r2 * e) / (1 + r1 * r2 * e)) ** 2)


def test_near_grazing_agrees_with_extended_precision_airy_sum():
    if np.finfo(np.longdouble).eps > 1e-18:
        pytest.skip("np.longdouble is not extended precision on this platform")
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(150):
        lam, c, d = rng.uniform(360, 780), 10 ** rng.uniform(-8, -2), rng.uniform(0, 3000)
        na, nb, nc = rng.uniform(1, 2), rng.uniform(1, 2.5) + 1j * rng.choice([0, rng.uniform(0, 1)]), rng.uniform(1, 2.5)
        for pol in "sp":
            worst = max(worst, abs(reflectance(lam, c, d, n_film=nb, n_incident=na, n_substrate=nc, polarization=pol)
                                   - _airy_longdouble(lam, c, d, na, nb, nc, pol)))
    assert worst <= 1e-12, worst


def test_agrees_with_colour_thin_film_tmm_where_colour_is_exact():
    from colour.phenomena import thin_film_tmm

    rng = np.random.default_rng(11)
    worst = 0.0
    for i in range(200):
        lam, d = rng.uniform(360, 780), (0.0 if i % 19 == 0 else rng.uniform(0, 3000))
        if i % 4 == 0:  # complex indices: colour is exact at normal incidence only
            c = 1.0
            na, nb, nc = rng.uniform(1, 2), rng.uniform(1, 2.5) + 1j * rng.uniform(0, 2), rng.uniform(1, 2.5) + 1j * rng.uniform(0, 4)
        else:  # transparent, no TIR: n_b, n_c >= n_a
            c = 1.0 if i % 13 == 0 else rng.uniform(0.01, 1.0)
            na = rng.uniform(1, 1.8)
            nb, nc = na + rng.uniform(0, 1), na + rng.uniform(0, 1)
        r_ref, t_ref = thin_film_tmm([na, nb, nc], d, lam, np.degrees(np.arccos(c)))
        for j, pol in enumerate("sp"):
            r, t = _both(lam, c, d, nb, na, nc, pol)
            worst = max(worst, abs(r - r_ref[0, 0, 0, j]))
            if np.isreal(nc):  # colour's T uses Re-less n_c cos_t / n_a cos_i: exact for a real substrate
                worst = max(worst, abs(t - t_ref[0, 0, 0, j]))
    assert worst <= TOL, worst


# --------------------------------------------------------------------------- properties (hypothesis)
@PROPS
@given(wavelengths, cosines, thicknesses, indices, indices, indices, extinctions, extinctions, pols)
def test_reflectance_and_transmittance_are_within_0_1_and_r_plus_t_le_1(lam, c, d, na, nb, nc, kb, kc, pol):
    r, t = _both(lam, c, d, nb + 1j * kb, na, nc + 1j * kc, pol)
    assert np.isfinite(r) and np.isfinite(t)
    assert 0.0 <= r <= 1.0 and 0.0 <= t <= 1.0
    assert r + t <= 1.0 + 1e-12


@PROPS
@given(wavelengths, cosines, thicknesses, indices, indices, indices, pols)
def test_energy_conservation_r_plus_t_is_1_without_absorption(lam, c, d, na, nb, nc, pol):
    r, t = _both(lam, c, d, nb, na, nc, pol)
    assert abs(r + t - 1.0) <= 1e-12


@PROPS
@given(wavelengths, cosines, indices, indices, indices, extinctions, pols)
def test_zero_thickness_gives_the_bare_interface_fresnel_reflectance(lam, c, na, nb, nc, kc, pol):
    nc = nc + 1j * kc
    bare = abs(fresnel_r(na, nc, c, snell_cos(na, nc, c), pol)) ** 2
    if c == 0 and nc == na:  # no interface at all
        bare = 0.0
    assert reflectance(lam, c, 0.0, n_film=nb, n_incident=na, n_substrate=nc, polarization=pol) == pytest.approx(bare, abs=1e-12)


@PROPS
@given(wavelengths, thicknesses, indices, indices, indices, extinctions)
def test_s_equals_p_at_normal_incidence(lam, d, na, nb, nc, kb):
    kw = dict(n_film=nb + 1j * kb, n_incident=na, n_substrate=nc)
    assert reflectance(lam, 1.0, d, polarization="s", **kw) == pytest.approx(
        reflectance(lam, 1.0, d, polarization="p", **kw), abs=1e-13)


@PROPS
@given(wavelengths, st.floats(0.05, 1.0), st.floats(0.0, 2000.0), indices, st.floats(1.0, 3.0), indices, pols,
       st.integers(1, 5))
def test_reflectance_is_periodic_in_thickness_with_period_lambda_over_2_nb_cos_theta_b(lam, c, d, na, dn, nc, pol, m):
    nb = na + dn  # no TIR in the film, so the phase is real
    cos_b = snell_cos(na, nb, c)
    period = lam / (2.0 * nb * cos_b)
    kw = dict(n_film=nb, n_incident=na, n_substrate=nc, polarization=pol)
    assert reflectance(lam, c, d + m * period, **kw) == pytest.approx(reflectance(lam, c, d, **kw), abs=1e-10)
    assert film_phase(lam, c, period, nb, na) == pytest.approx(2.0 * np.pi, rel=1e-12)


@PROPS
@given(wavelengths, st.floats(1.0, 2.0), st.floats(0.05, 1.5), st.floats(0.0, 1.0), st.integers(0, 3))
def test_quarter_wave_film_is_an_extremum_with_the_textbook_value(lam, na, dn, frac, m):
    """Normal incidence, d = (2m + 1) lambda / (4 n_b): R = ((n_a n_c - n_b^2) / (n_a n_c + n_b^2))^2, a
    maximum when n_b exceeds both neighbours, a minimum when n_a < n_b < n_c (antireflection)."""
    nb = na + dn
    nc = na + frac * dn if frac < 0.5 else nb + dn  # below or above the film
    d = (2 * m + 1) * lam / (4.0 * nb)
    kw = dict(n_film=nb, n_incident=na, n_substrate=nc)
    r0 = reflectance(lam, 1.0, d, **kw)
    assert r0 == pytest.approx(((na * nc - nb**2) / (na * nc + nb**2)) ** 2, abs=1e-12)
    eps = d * 1e-3
    neighbours = reflectance(lam, 1.0, np.array([d - eps, d + eps]), **kw)
    if nc < nb:
        assert np.all(neighbours <= r0 + 1e-15)
    else:
        assert np.all(neighbours >= r0 - 1e-15)


def test_no_nan_or_inf_on_a_dense_grid_including_exactly_0_and_90_degrees():
    lam = np.linspace(360.0, 780.0, 15)[:, None, None]
    c = np.concatenate([[0.0, 1e-300, 1e-12], np.linspace(0.0, 1.0, 41), [1.0]])[None, :, None]
    d = np.array([0.0, 1e-9, 1e-3, 0.5, 1.0, 650.0, 1e4, 1e5, 1e7])[None, None, :]
    stacks = [(1.0, 1.5, 1.0), (1.0, 1.0, 1.0), (1.5, 1.0, 1.5), (1.5, 1.5, 1.0), (2.0, 1.0, 1.3), (1.0, 1.5 + 0.2j, 1.0),
              (1.0, 1.5, 0.2 + 3.0j), (1.33, 1.33, 1.33), (1.0, 1.56, 1.0 + 0j), (1.5, 1.2 + 1e-3j, 1.0)]
    for na, nb, nc in stacks:
        for pol in optics.POLARIZATIONS:
            r, t = _both(lam, c, d, nb, na, nc, pol)
            assert r.shape == t.shape == (15, c.size, d.size)
            assert np.all(np.isfinite(r)) and np.all(np.isfinite(t)), (na, nb, nc, pol)
            assert np.all((r >= 0) & (r <= 1) & (t >= 0) & (t <= 1) & (r + t <= 1 + 1e-12))


def test_grazing_incidence_reflects_everything_for_a_dielectric_stack():
    for nb, nc in [(1.5, 1.0), (1.0, 1.5), (1.2, 2.0), (1.0, 1.0 + 0j)]:
        for pol in optics.POLARIZATIONS:
            r, t = _both(np.linspace(360, 780, 9), 0.0, np.array([0.0, 1.0, 650.0, 1e5])[:, None], nb, 1.0, nc, pol)
            if nb == nc == 1.0:  # nothing but air: no interface
                np.testing.assert_array_equal(r[1:], 0.0)
                continue
            np.testing.assert_array_equal(r[1:], 1.0)
            np.testing.assert_array_equal(t[1:], 0.0)


def test_a_film_much_thinner_than_1_nm_converges_to_the_bare_interface():
    d = np.array([1e-9, 1e-6, 1e-3, 1e-1])
    for c in (1.0, 0.5, 1e-3):
        r = reflectance(550.0, c, d, n_film=1.5, n_incident=1.0, n_substrate=1.3)
        r0 = reflectance(550.0, c, 0.0, n_film=1.5, n_incident=1.0, n_substrate=1.3)
        err = np.abs(r - r0)
        assert np.all(err <= 0.1 * d + 1e-15)  # |dR/dd| is O(k0) ~ 0.01 / nm here: linear convergence
        assert err[0] < 1e-12


def test_thick_films_stay_exact_and_frustrated_tir_dies_out():
    import tmm  # a declared test dependency: the oracle must not vanish with the environment
    for d in (1e4, 5e4):
        for pol in "sp":
            ref = tmm.coh_tmm(pol, [1.0, 1.5, 1.2], [np.inf, d, np.inf], 0.7, 612.3)["R"]
            assert abs(reflectance(612.3, np.cos(0.7), d, n_film=1.5, n_substrate=1.2, polarization=pol) - ref) <= TOL
    # a low-index gap between two dense media beyond the critical angle: transmission ~ exp(-2 k0 kappa d)
    r, t = _both(550.0, 0.3, np.array([10.0, 100.0, 1e4, 1e7]), 1.0, 1.5, 1.5, "s")
    assert t[0] > t[1] > 0 and t[2] < 1e-30 and t[3] == 0.0 and r[3] == 1.0


def test_broadcasting_over_every_argument_and_callable_indices():
    lam = np.linspace(400, 700, 5)[:, None, None]
    c = np.linspace(0, 1, 4)[None, :, None]
    d = np.array([0.0, 300.0, 650.0])
    n_of_lam = lambda w: 1.532 + 5.89e3 / w**2
    r = reflectance(lam, c, d, n_film=n_of_lam)
    assert r.shape == (5, 4, 3) and r.dtype == np.float64
    r_arr = reflectance(lam, c, d, n_film=n_of_lam(lam))
    np.testing.assert_array_equal(r, r_arr)
    for i in range(5):
        for j in range(4):
            for k in range(3):
                assert r[i, j, k] == pytest.approx(
                    float(reflectance(float(lam[i, 0, 0]), float(c[0, j, 0]), d[k], n_film=n_of_lam(float(lam[i, 0, 0])))),
                    abs=1e-14)
    assert reflectance(500.0, 1.0, 100.0, n_film=1.5).shape == ()


def test_mixed_arrays_use_the_right_path_per_element():
    """One call whose elements need the real fast path and the complex (TIR) path equals
    element-by-element calls (to rounding: in-place and out-of-place arithmetic may differ by an ulp)."""
    c = np.array([1.0, 0.9, 0.6, 0.5, 0.2, 0.0])  # n_a = 1.5 over n_b = 1.2: TIR from cos < 0.8
    d = np.array([0.0, 10.0, 650.0])[:, None]
    r = reflectance(550.0, c, d, n_film=1.2, n_incident=1.5, n_substrate=1.6, polarization="p")
    for i in range(3):
        for j in range(6):
            assert r[i, j] == pytest.approx(reflectance(550.0, c[j], d[i, 0], n_film=1.2, n_incident=1.5,
                                                        n_substrate=1.6, polarization="p"), abs=1e-15)


def test_film_exactly_at_its_critical_angle_has_a_finite_well_defined_limit():
    """q_b = 0 exactly (n_b == n_a at grazing): the Airy sum is 0/0 there; the characteristic-matrix
    form gives the limit, which continuity from slightly thinner incidence confirms."""
    r = reflectance(500.0, 0.0, 200.0, n_film=1.0, n_incident=1.0, n_substrate=1.5)
    assert r == 1.0
    # q_b -> 0 from a dense film approaching the incident index: R(n_b) is continuous
    nbs = 1.0 + np.array([1e-12, 1e-9, 1e-6])
    rs = reflectance(500.0, 1e-3, 200.0, n_film=nbs, n_incident=1.0, n_substrate=1.5)
    r_lim = reflectance(500.0, 1e-3, 200.0, n_film=1.0, n_incident=1.0, n_substrate=1.5)
    assert np.all(np.abs(rs - r_lim) <= 1e-5)


# --------------------------------------------------------------------------- helpers the Fourier baker uses
def test_helpers_rebuild_the_airy_sum_of_eq_3():
    rng = np.random.default_rng(3)
    lam, c, d = rng.uniform(360, 780, 50), rng.uniform(0.01, 1, 50), rng.uniform(0, 2000, 50)
    na, nb, nc = 1.0, 1.56, 1.0
    for pol in "sp":
        cb, cc = snell_cos(na, nb, c), snell_cos(na, nc, c)
        a, b = fresnel_r(na, nb, c, cb, pol), fresnel_r(nb, nc, cb, cc, pol)
        e = np.exp(1j * film_phase(lam, c, d, nb, na))
        airy = np.abs((a + b * e) / (1 + a * b * e)) ** 2
        np.testing.assert_allclose(reflectance(lam, c, d, n_film=nb, polarization=pol), airy, rtol=0, atol=1e-13)


def test_snell_cos_is_real_below_and_decaying_imaginary_beyond_the_critical_angle():
    assert snell_cos(1.0, 1.5, 1.0) == 1.0
    assert snell_cos(1.0, 1.5, 0.6).dtype == np.float64
    np.testing.assert_allclose(1.5 * np.sqrt(1 - snell_cos(1.0, 1.5, 0.6) ** 2), 1.0 * 0.8, rtol=1e-14)
    beyond = snell_cos(1.5, 1.0, 0.3)
    assert beyond.real == 0 and beyond.imag > 0
    absorbing = snell_cos(1.0, 0.2 + 3.0j, np.array([0.0, 0.5, 1.0]))
    assert np.all((absorbing * (0.2 + 3.0j)).imag > 0)


def test_fresnel_r_normal_incidence_values_and_sign_convention():
    assert fresnel_r(1.0, 1.5, 1.0, 1.0, "s") == pytest.approx(-0.2)
    assert fresnel_r(1.0, 1.5, 1.0, 1.0, "p") == pytest.approx(0.2)  # Born & Wolf / tmm: r_p = -r_s
    assert fresnel_r(1.0, 1.0, 0.0, 0.0, "s") == 0.0  # same medium at grazing: no interface, not 0/0
    # Brewster angle: r_p = 0 at tan(theta) = n2 / n1
    c = np.cos(np.arctan(1.5))
    assert abs(fresnel_r(1.0, 1.5, c, snell_cos(1.0, 1.5, c), "p")) < 1e-15


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(wavelength_nm=np.nan), "wavelength_nm"),
        (dict(wavelength_nm=0.0), "wavelength_nm"),
        (dict(wavelength_nm=[500.0, -1.0]), "wavelength_nm"),
        (dict(cos_theta=1.5), "cos_theta"),
        (dict(cos_theta=-0.1), "cos_theta"),
        (dict(cos_theta=[0.5, np.nan]), "cos_theta"),
        (dict(thickness_nm=-3.0), "thickness_nm"),
        (dict(thickness_nm=np.inf), "thickness_nm"),
        (dict(n_film=0.0), "n_film"),
        (dict(n_film=-1.5), "n_film"),
        (dict(n_film=1.5 - 0.1j), "n_film"),
        (dict(n_film=np.nan), "n_film"),
        (dict(n_film="glass"), "n_film"),
        (dict(n_film=lambda w: w * 0 - 1), "n_film"),
        (dict(n_incident=1.0 + 0.1j), "n_incident"),
        (dict(n_incident=0.0), "n_incident"),
        (dict(n_substrate=-2.0), "n_substrate"),
        (dict(polarization="circular"), "polarization"),
        (dict(wavelength_nm=[500.0, 600.0], cos_theta=[0.1, 0.2, 0.3]), "broadcast"),
    ],
)
def test_bad_input_raises_value_error_naming_the_argument(kwargs, name):
    args = dict(wavelength_nm=550.0, cos_theta=0.5, thickness_nm=650.0, n_film=1.5)
    args.update(kwargs)
    pos = [args.pop(k) for k in ("wavelength_nm", "cos_theta", "thickness_nm")]
    for fn in (reflectance, transmittance):
        with pytest.raises(ValueError, match=name):
            fn(*pos, **args)


def test_error_message_gives_the_value_and_what_is_allowed():
    with pytest.raises(ValueError, match=r"thickness_nm must be finite and in \[0, inf\), got -3\.0"):
        reflectance(550.0, 0.5, [1.0, -3.0], n_film=1.5)
    with pytest.raises(ValueError, match=r"polarization must be one of .*'unpolarized'.*got 'x'"):
        reflectance(550.0, 0.5, 1.0, n_film=1.5, polarization="x")


def test_real_fast_path_and_complex_path_agree_on_transparent_stacks():
    """The two evaluations of eq. (4) agree to rounding where both apply (real indices, no TIR)."""
    rng = np.random.default_rng(9)
    n = 2000
    lam, c, d = rng.uniform(360, 780, n), rng.uniform(0, 1, n), rng.uniform(0, 5000, n)
    na = rng.uniform(1, 1.5, n)
    nb, nc = na + rng.uniform(1e-3, 1, n), na + rng.uniform(0, 1, n)
    k0d = 2 * np.pi * d / lam
    qb, qc = np.sqrt(nb**2 - na**2 * (1 - c * c)), np.sqrt(nc**2 - na**2 * (1 - c * c))
    fast, degenerate = optics._fast_real(k0d, c, na, nb, nc, qb, qc, ("s", "p"), True)
    slow = optics._general_complex(k0d, c, na, nb, nc, qb + 0j, qc + 0j, ("s", "p"), True)
    assert not degenerate
    for pol in "sp":
        for k in (0, 1):
            np.testing.assert_allclose(fast[pol][k], slow[pol][k], rtol=0, atol=1e-13)

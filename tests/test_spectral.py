"""Spectral colour: normalisation, agreement with colour-science, colour spaces, Lab/dE2000, previews."""

from __future__ import annotations

import numpy as np
import pytest

from rockdove import optics, spectral, srgb
from rockdove.spectral import (
    COLOUR_SPACES,
    RGB_to_Lab,
    RGB_to_preview8,
    RGB_to_XYZ,
    XYZ_to_Lab,
    XYZ_to_RGB,
    cmfs_illuminant,
    delta_E_2000,
    spectral_weights,
)

GRID_1NM = np.arange(360.0, 781.0, 1.0)
OBSERVER = "CIE 1931 2 Degree Standard Observer"


def _grids():
    rng = np.random.default_rng(1)
    irregular = np.unique(np.concatenate([[360.0, 780.0], rng.uniform(360, 780, 200)]))
    return [GRID_1NM, np.arange(360.0, 781.0, 5.0), np.linspace(400.0, 700.0, 31), irregular]


@pytest.mark.parametrize("grid", _grids(), ids=["1nm", "5nm", "400-700", "irregular"])
def test_perfect_reflector_has_y_equal_1_on_any_grid(grid):
    xyz = np.ones(grid.size) @ spectral_weights(grid)
    assert xyz[1] == pytest.approx(1.0, abs=1e-14)


def test_perfect_reflector_under_d65_is_white_1_1_1_in_lin_rec709_and_acescg():
    for cs in COLOUR_SPACES:
        np.testing.assert_allclose(np.ones(GRID_1NM.size) @ spectral_weights(GRID_1NM, colour_space=cs), 1.0,
                                   rtol=0, atol=1e-12)
    # on a 5 nm grid the trapezoid rule moves the white by its own quadrature error only (measured 1.4e-4)
    g5 = np.arange(360.0, 781.0, 5.0)
    np.testing.assert_allclose(XYZ_to_RGB(np.ones(g5.size) @ spectral_weights(g5)), 1.0, rtol=0, atol=3e-4)
    np.testing.assert_allclose(XYZ_to_Lab(np.ones(GRID_1NM.size) @ spectral_weights(GRID_1NM)), [100, 0, 0],
                               atol=1e-10)


def test_weights_on_1nm_grid_agree_with_colour_sd_to_xyz_under_d65():
    """Against colour.sd_to_XYZ(sd, cmfs, illuminant=D65) with the CMFS trimmed to 360-780 nm (otherwise
    colour extrapolates D65 and the spectrum to 830 nm), methods ASTM E308 and Integration. The only
    differences are the methods' own (endpoint weights, colour's alignment of the 5 nm D65 table to
    1 nm). Measured: max |dXYZ| 1.26e-6 for both methods, dE2000 <= 1.2e-4; asserted 3e-6 and 1e-3."""
    import warnings

    import colour

    cmfs = colour.MSDS_CMFS[OBSERVER].copy().trim(colour.SpectralShape(360, 780, 1))
    d65 = colour.SDS_ILLUMINANTS["D65"]
    w = spectral_weights(GRID_1NM)
    rng = np.random.default_rng(5)
    spectra = [optics.reflectance(GRID_1NM, rng.uniform(0, 1), rng.uniform(100, 1500), n_film=1.5) for _ in range(8)]
    spectra += [0.5 + 0.4 * np.sin(GRID_1NM / rng.uniform(5, 60)) for _ in range(4)]
    for r in spectra:
        ours = r @ w
        sd = colour.SpectralDistribution(r, GRID_1NM)
        for method in ("ASTM E308", "Integration"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # colour's notes about aligning D65 to the 1 nm shape
                ref = colour.sd_to_XYZ(sd, cmfs, illuminant=d65, method=method) / 100.0
            np.testing.assert_allclose(ours, ref, rtol=0, atol=3e-6)
            assert delta_E_2000(XYZ_to_Lab(ours), XYZ_to_Lab(ref)) < 1e-3


def test_cmfs_illuminant_interpolates_colour_tables_linearly():
    import colour

    cmfs_t, d65_t = colour.MSDS_CMFS[OBSERVER], colour.SDS_ILLUMINANTS["D65"]
    cmfs, s = cmfs_illuminant(np.array([360.0, 555.0, 780.0]))
    np.testing.assert_allclose(cmfs, cmfs_t[[360.0, 555.0, 780.0]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(s, d65_t[[360.0, 555.0, 780.0]], rtol=0, atol=1e-12)
    _, s_mid = cmfs_illuminant([557.5])  # halfway between two 5 nm D65 nodes: their mean
    assert s_mid[0] == pytest.approx(0.5 * (d65_t[555.0] + d65_t[560.0]), abs=1e-12)
    assert cmfs.shape == (3, 3) and s.shape == (3,)


def test_weights_are_the_trapezoid_rule_on_an_irregular_grid():
    """X = trapz(R S xbar) / trapz(S ybar) on the given nodes, as documented (numpy's trapezoid as oracle)."""
    grid = _grids()[3]
    cmfs, s = cmfs_illuminant(grid)
    r = 0.2 + 0.6 * (grid - 360) / 420
    expected = np.array([np.trapezoid(r * s * cmfs[:, k], grid) for k in range(3)]) / np.trapezoid(s * cmfs[:, 1], grid)
    np.testing.assert_allclose(r @ spectral_weights(grid), expected, rtol=1e-13)


def test_acescg_round_trip_and_matrix_matches_materialx_lin_rec709_to_acescg():
    rng = np.random.default_rng(3)
    xyz = rng.uniform(-0.2, 1.2, (100, 3))
    for cs in COLOUR_SPACES:
        np.testing.assert_allclose(RGB_to_XYZ(XYZ_to_RGB(xyz, cs), cs), xyz, rtol=0, atol=1e-13)
    # MaterialX's lin_rec709 -> acescg (Bradford): columns of the rec709 primaries in AP1
    ap1 = XYZ_to_RGB(RGB_to_XYZ(np.eye(3), "lin_rec709"), "acescg")
    np.testing.assert_allclose(ap1[0], [0.6131, 0.0702, 0.0206], atol=2e-4)
    np.testing.assert_allclose(ap1[1], [0.3395, 0.9164, 0.1096], atol=2e-4)
    np.testing.assert_allclose(ap1[2], [0.0474, 0.0134, 0.8698], atol=2e-4)


def test_out_of_gamut_thin_film_colours_stay_unclipped():
    lam = np.arange(480.0, 701.0, 5.0)
    r = optics.reflectance(lam[None, :], np.linspace(0, 1, 64)[:, None], 650.0, n_film=1.5)
    rgb = r @ spectral_weights(lam, colour_space="lin_rec709")
    assert (rgb < 0).any()  # thin-film colours leave Rec.709; they are kept as negative floats


def test_lab_and_delta_e_2000_against_sharma_2005_test_pair():
    """Sharma, Wu & Dalal (2005), Table 1, pair 1: dE00 = 2.0425."""
    assert float(delta_E_2000([50.0, 2.6772, -79.7751], [50.0, 0.0, -82.7485])) == pytest.approx(2.0425, abs=1e-4)
    assert float(delta_E_2000([40.0, 10.0, -5.0], [40.0, 10.0, -5.0])) == 0.0
    lab = RGB_to_Lab([0.18, 0.18, 0.18])
    assert lab[0] == pytest.approx(116 * 0.18 ** (1 / 3) - 16, abs=1e-9) and abs(lab[1]) < 1e-9 and abs(lab[2]) < 1e-9


def test_preview8_keeps_in_gamut_colours_and_desaturates_out_of_gamut_toward_luminance():
    import colour

    inside = np.array([[0.2, 0.5, 0.1], [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]])
    expected = np.round(np.asarray(colour.cctf_encoding(inside, function="sRGB")) * 255).astype(np.uint8)
    np.testing.assert_array_equal(RGB_to_preview8(inside), expected)
    out = np.array([0.5, -0.1, 0.2])
    px = RGB_to_preview8(out)
    assert px.dtype == np.uint8 and px[1] == 0 and px[0] > px[2] > 0  # hue order kept, negative lifted to 0
    lin = np.asarray(colour.cctf_decoding(px / 255.0, function="sRGB"))
    lum = np.array([0.2126, 0.7152, 0.0722])
    assert lin @ lum == pytest.approx(out @ lum, abs=2e-3)  # luminance preserved
    np.testing.assert_array_equal(RGB_to_preview8([[2.0, 0.5, -1.0], [-1, -1, -1]])[1], [0, 0, 0])
    assert RGB_to_preview8([2.0, 3.0, 4.0]).tolist() == [255, 255, 255]
    assert RGB_to_preview8(np.ones((2, 2, 3)), colour_space="acescg").tolist() == [[[255] * 3] * 2] * 2


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: cmfs_illuminant([350.0, 500.0]), "wavelength_nm"),
        (lambda: cmfs_illuminant([500.0, 800.0]), "wavelength_nm"),
        (lambda: spectral_weights([500.0]), "wavelength_nm"),
        (lambda: spectral_weights([500.0, 400.0]), "wavelength_nm"),
        (lambda: spectral_weights(GRID_1NM, colour_space="srgb"), "colour_space"),
        (lambda: spectral_weights(GRID_1NM, illuminant="D99"), "illuminant"),
        (lambda: cmfs_illuminant(GRID_1NM, observer="martian"), "observer"),
        (lambda: XYZ_to_RGB([0.5, 0.5, 0.5], "rec2020"), "colour_space"),
        (lambda: RGB_to_preview8([np.nan, 0, 0]), "rgb"),
        (lambda: RGB_to_preview8([0.1, 0.2]), "rgb"),
    ],
)
def test_bad_input_raises_value_error_naming_the_argument(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_spectral_module_imports_colour_lazily():
    import subprocess
    import sys

    code = "import sys, rockdove.spectral, rockdove.optics, rockdove.films; print('colour' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=str(__import__('pathlib').Path(spectral.__file__).parents[1]))
    assert out.stdout.strip() == "False"


def test_colour_is_imported_without_matplotlib_and_its_plotting_still_imports_on_request():
    """rockdove._compat.import_colour keeps colour-science's plotting (matplotlib, pyplot) off the build's path;
    a fresh interpreter, because this one may have colour imported already."""
    import subprocess
    import sys

    code = ("import sys; from rockdove._compat import import_colour; import_colour(); "
            "assert 'matplotlib' not in sys.modules, 'matplotlib imported'; "
            "assert 'colour.plotting' not in sys.modules; "
            "import colour.plotting; assert callable(colour.plotting.plot_single_sd); print('ok')")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr


def test_lab_delta_e_2000_and_srgb_formulas_agree_with_colour_science():
    """The numpy CIELAB (CIE 15:2004), CIEDE2000 (Sharma et al. 2005) and sRGB (IEC 61966-2-1) of
    rockdove.spectral against colour-science's own, over random colours and the formula's edge cases: neutral
    colours (a = b = 0, where h' is defined as 0), hue differences either side of 180 degrees, negative a."""
    from rockdove._compat import import_colour

    colour = import_colour()
    rng = np.random.default_rng(7)
    lab_a = np.column_stack([rng.uniform(0, 100, 4000), rng.uniform(-120, 120, 4000), rng.uniform(-120, 120, 4000)])
    lab_b = lab_a + rng.normal(0, 8, lab_a.shape)
    edge_a = np.array([[50, 0, 0], [50, 0, 0], [60, 10, 0.001], [60, -10, 0.001], [30, -5, -40], [70, 1e-9, 0]])
    edge_b = np.array([[55, 0, 0], [50, 10, 10], [60, -10, -0.001], [60, 10, -0.001], [31, 5, 40], [70, 0, 1e-9]])
    for a, b in ((lab_a, lab_b), (edge_a, edge_b)):
        ours = delta_E_2000(a, b)
        theirs = np.asarray(colour.delta_E(a, b, method="CIE 2000"))
        np.testing.assert_allclose(ours, theirs, rtol=1e-10, atol=1e-10)
    xyz = rng.uniform(-0.05, 1.2, (3000, 3))
    np.testing.assert_allclose(spectral.XYZ_to_Lab(xyz),
                               colour.XYZ_to_Lab(xyz, illuminant=spectral.reference_white_xy()), rtol=0, atol=1e-10)
    np.testing.assert_allclose(spectral.Lab_to_XYZ(lab_a),
                               colour.Lab_to_XYZ(lab_a, illuminant=spectral.reference_white_xy()), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(spectral.Lab_to_XYZ(spectral.XYZ_to_Lab(xyz)), xyz, rtol=1e-10, atol=1e-12)
    v = np.concatenate([np.linspace(-0.1, 1.1, 2001), [0.0031308, 0.04045]])
    np.testing.assert_allclose(srgb.srgb_encode(v), colour.cctf_encoding(v, function="sRGB"), rtol=0, atol=1e-14)
    np.testing.assert_allclose(srgb.srgb_decode(v), colour.cctf_decoding(v, function="sRGB"), rtol=0, atol=1e-14)


def test_colour_data_is_read_from_colour_science_once_and_a_warm_process_never_imports_it(tmp_path):
    """The CMF / illuminant tables and RGB matrices are colour-science's, cached per colour-science version: a
    second process bakes, measures and encodes a LUT without importing colour-science, with the same bytes; a
    torn cache file is recomputed."""
    import os
    import subprocess
    import sys

    code = ("import sys, hashlib; from rockdove.lut.bake import bake; from rockdove.lut.reference import lut_error; "
            "from rockdove.srgb import linear_to_srgb8; "
            "lut = bake(angles=32, thicknesses=8, thickness_range=(500.0, 700.0), film='keratin'); "
            "err = lut_error(lut, 'keratin', n_points=50); "
            "h = hashlib.sha256(lut.rgb.tobytes() + linear_to_srgb8(lut.rgb).tobytes()).hexdigest(); "
            "print(h, repr(err['max']), 'colour' in sys.modules)")
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path)}

    def run() -> list[str]:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
        assert r.returncode == 0, r.stderr
        return r.stdout.split()

    cold, warm = run(), run()
    assert cold[2] == "True" and warm[2] == "False"  # read from colour-science once, then from the cache
    assert warm[:2] == cold[:2]
    files = sorted(tmp_path.glob("rockdove/colour-science-*/*.npz"))
    assert files, "nothing cached"
    for f in files:
        f.write_bytes(b"torn")
    assert run() == cold  # unreadable files are recomputed from colour-science
    for f in files:
        with open(f, "wb") as fh:
            np.savez(fh, other=np.zeros(1))
    assert run() == cold  # so are readable files that lack the arrays asked for


def test_cached_tables_are_colour_sciences_tables():
    from rockdove._compat import import_colour

    colour = import_colour()
    cw, cv, sw, sv = spectral._tables("D65", spectral.DEFAULT_OBSERVER)
    cmfs = colour.MSDS_CMFS[spectral.DEFAULT_OBSERVER]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    assert np.array_equal(cw, cmfs.wavelengths) and np.array_equal(cv, cmfs.values)
    assert np.array_equal(sw, d65.wavelengths) and np.array_equal(sv, d65.values)


def test_linear_to_srgb8_gives_the_rounded_srgb_curve_exactly_even_at_each_step():
    """linear_to_srgb8 looks values up among precomputed steps; it must give exactly round(255 encode(v)) for
    every value, including the floats on either side of each step (found here by inverting the curve)."""
    rng = np.random.default_rng(3)
    near = srgb.srgb_decode((np.arange(1, 256) - 0.5) / 255.0)
    around = np.concatenate([near + d for d in np.linspace(-4e-12, 4e-12, 41)])
    for _ in range(3):  # walk a few ulps either side of each approximate step
        around = np.concatenate([around, np.nextafter(around, -1.0), np.nextafter(around, 2.0)])
    v = np.concatenate([around, rng.uniform(-0.1, 1.1, 300000), rng.uniform(0.0, 0.01, 100000),
                        [0.0, -0.0, 1.0, 0.0031308, 1e-300, -1e-300]])
    expected = np.round(np.clip(srgb.srgb_encode(np.clip(v, 0.0, 1.0)), 0.0, 1.0) * 255.0).astype(np.uint8)
    assert np.array_equal(srgb.linear_to_srgb8(v), expected)
    even = 2 * (v.size // 2)  # any array shape, not only 1-D
    assert np.array_equal(srgb.linear_to_srgb8(v[:even].reshape(-1, 1, 2)), expected[:even].reshape(-1, 1, 2))
    assert srgb.linear_to_srgb8([np.nan, np.inf, -np.inf, 2.0, -1.0]).tolist() == [0, 255, 0, 255, 0]


def test_linear_to_srgb8_cell_tables_match_the_formula_on_every_step_neighbour_sweep_and_float32():
    """linear_to_srgb8 reads a code and at most one step per cell of [0, 1]; it must equal the formula
    (``_srgb8_code``) exactly: at every step and the float64s either side, at every cell edge, on random
    values, on a log sweep down to 1e-12, for float32 input (the float32 just below / at / above each step),
    and for NaN / +-inf, in blocks of any size and any array shape."""
    rng = np.random.default_rng(11)
    steps = srgb._srgb8_steps()
    edges = np.arange(srgb._SRGB8_CELLS + 1) / srgb._SRGB8_CELLS
    special = np.concatenate([steps, edges])
    near = np.concatenate([special, np.nextafter(special, -np.inf), np.nextafter(special, np.inf)])
    sweep = np.geomspace(1e-12, 1.0, 200001)
    v64 = np.concatenate([near, rng.uniform(-0.1, 1.1, 2_000_003), sweep, -sweep,
                          [0.0, -0.0, 1.0, 5e-324, -5e-324, 1e300, -1e300, np.finfo(np.float64).max]])

    def code(v):
        return srgb._srgb8_code(np.asarray(v, np.float64)).astype(np.uint8)

    got = srgb.linear_to_srgb8(v64)
    assert got.dtype == np.uint8 and got.shape == v64.shape
    wrong = np.flatnonzero(got != code(v64))
    assert wrong.size == 0, f"{wrong.size} float64 values differ, e.g. {v64[wrong[:3]].tolist()}"

    s32 = steps.astype(np.float32)
    near32 = np.concatenate([s32, np.nextafter(s32, np.float32(-1)), np.nextafter(s32, np.float32(2)),
                             edges.astype(np.float32)])
    v32 = np.concatenate([near32, rng.uniform(-0.1, 1.1, 1_000_001).astype(np.float32), sweep.astype(np.float32),
                          np.array([0.0, -0.0, 1.0, 1e-45, 3e38], np.float32)])
    assert v32.dtype == np.float32
    got32 = srgb.linear_to_srgb8(v32)
    wrong = np.flatnonzero(got32 != code(v32))
    assert wrong.size == 0, f"{wrong.size} float32 values differ, e.g. {v32[wrong[:3]].tolist()}"

    odd = np.array([np.nan, -np.nan, np.inf, -np.inf, 0.5])
    assert srgb.linear_to_srgb8(odd).tolist() == [0, 0, 255, 0, 188]
    assert srgb.linear_to_srgb8(odd.astype(np.float32)).tolist() == [0, 0, 255, 0, 188]
    image = v64[:3 * 700 * 500].reshape(700, 500, 3)[:, ::2]  # not contiguous, not a whole number of blocks
    assert np.array_equal(srgb.linear_to_srgb8(image), code(image))
    assert srgb.linear_to_srgb8(np.empty((0, 3))).shape == (0, 3)

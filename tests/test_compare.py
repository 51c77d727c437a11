"""Tests of rockdove.verify.compare: dE2000 maps and statistics, the pixel mask, hue classes and the
green/purple boundary straightness measure."""

import numpy as np
import pytest

from rockdove.verify import boundary, compare
from rockdove.verify.records import read

FEATHER = 2  # part id of the feathers in these synthetic images (0 = background, 1 = body)


def _lab_oracle(rgb_linear):
    """CIELAB of linear sRGB/Rec.709 with the D65 white at Y = 1, straight from colour-science."""
    import colour

    cs = colour.RGB_COLOURSPACES["sRGB"]
    xyz = colour.RGB_to_XYZ(rgb_linear, cs, apply_cctf_decoding=False)
    return colour.XYZ_to_Lab(xyz, cs.whitepoint)


def _images(h=24, w=32, seed=0):
    rng = np.random.default_rng(seed)
    rgb = rng.uniform(0.02, 0.9, (h, w, 3))
    part = np.zeros((h, w), np.int32)
    part[4:20, 4:28] = FEATHER
    part[:, :3] = 1
    return rgb, part


def test_identical_renders_give_zero_delta_e():
    rgb, part = _images()
    m = compare.compare_arrays("v", rgb, rgb.copy(), part, part, [FEATHER])
    assert m.n_pixels == (16 - 2) * (24 - 2)  # the feather rectangle eroded by one pixel
    assert m.de_max == 0.0 and m.de_median == 0.0
    assert m.passed and m.finite and not m.failures


def test_known_colour_shift_gives_the_colour_science_delta_e():
    import colour

    rgb, part = _images()
    shifted = rgb * np.array([1.06, 0.97, 1.0])
    shifted[5:8, 5:8] = [-0.05, 0.3, 0.1]  # out of gamut: compared as is, not clipped
    m = compare.compare_arrays("v", shifted, rgb, part, part, [FEATHER])
    mask = np.isfinite(m.de_map)
    expected = colour.delta_E(_lab_oracle(shifted[mask]), _lab_oracle(rgb[mask]), method="CIE 2000")
    # rockdove.spectral uses the D65 white integrated from the CIE tables, colour-science's sRGB the rounded
    # chromaticity (0.3127, 0.3290): they agree to ~5e-4 relative
    np.testing.assert_allclose(m.de_map[mask], expected, rtol=2e-3, atol=1e-6)
    assert m.de_median == pytest.approx(np.median(expected), rel=2e-3)
    assert m.de_p95 == pytest.approx(np.percentile(expected, 95), rel=2e-3)
    assert m.de_median > 0.5  # the shift is visible, so the statistics are not trivially zero


def test_a_large_shift_fails_the_goals_and_says_why():
    rgb, part = _images()
    m = compare.compare_arrays("sweep_060", rgb * np.array([1.5, 0.7, 1.0]), rgb, part, part, [FEATHER])
    assert not m.passed
    assert any("median dE2000" in f for f in m.failures)
    assert any("p95 dE2000" in f for f in m.failures)


def test_mask_excludes_silhouette_edges_and_part_disagreement():
    _, part = _images()
    other = part.copy()
    other[10, 10] = 1  # the reference sees the body here
    mask = compare.comparison_mask(part, other, [FEATHER], erode_px=1)
    assert not mask[4, 10] and mask[5, 10]  # first feather row is an edge
    # the disagreeing pixel and its 8 neighbours are out (eroded in one render, different part in the other)
    assert not mask[9:12, 9:12].any()
    assert mask[8, 10] and mask[12, 10]
    assert not compare.comparison_mask(part, part, [FEATHER], erode_px=2)[5, 10]


def test_a_view_without_feather_pixels_has_nan_statistics_and_nothing_to_fail():
    rgb, part = _images()
    body_only = np.where(part == FEATHER, 1, part)
    m = compare.compare_arrays("turntable_210", rgb, rgb, body_only, body_only, [FEATHER])
    assert m.n_pixels == 0 and np.isnan(m.de_median) and np.isnan(m.de_fraction_over_p95_goal)
    assert m.passed and m.hue.green == m.hue.purple == 0


def test_nan_and_black_holes_are_reported():
    rgb, part = _images()
    gl = rgb.copy()
    gl[1, 1] = np.nan  # on the body: reported as non-finite, not counted among feather pixels
    gl[10:12, 10:20] = 0.0  # 20 black pixels in lit feathers
    n_dot_l = np.full(part.shape, 0.8)
    m = compare.compare_arrays("v", gl, rgb, part, part, [FEATHER], ref_n_dot_l=n_dot_l)
    assert not m.finite
    assert m.n_black == 20 and m.n_lit == m.n_pixels
    assert not m.passed
    assert any("NaN" in f for f in m.failures) and any("black" in f for f in m.failures)
    # unlit black pixels are not holes
    m2 = compare.compare_arrays("v", np.where(np.isnan(gl), 0, gl), rgb, part, part, [FEATHER],
                                ref_n_dot_l=np.zeros(part.shape))
    assert m2.n_lit == 0 and m2.n_black == 0


def test_hue_classes_green_purple_grey():
    green = np.array([0.02, 0.15, 0.04])  # Airy colour of a 650 nm film at cos theta 0.8 (h_ab ~ 165 deg)
    purple = np.array([0.29, 0.056, 0.24])  # ... at cos theta 0.5 (h_ab ~ 333 deg)
    grey = np.array([0.1, 0.1, 0.1])
    h, c, cls = compare.hue_classes(np.stack([green, purple, grey]))
    assert cls.tolist() == [1, 2, 0]
    hist = compare.hue_histogram(np.stack([green] * 3 + [purple] * 2 + [grey]))
    assert (hist.green, hist.purple, hist.grey) == (3, 2, 1)
    assert sum(hist.counts) == 5 == (hist + hist).chromatic / 2


def _class_image(boundary_row, h=80, w=120):
    """Green above the curve ``row = boundary_row(col)``, purple below."""
    rows = np.arange(h)[:, None]
    cols = np.arange(w)[None, :]
    return np.where(rows < boundary_row(cols), 1, 2).astype(np.int8)


def test_boundary_straightness_straight_line_is_near_zero():
    straight = _class_image(lambda x: 20 + 0.4 * x)
    s = boundary.boundary_straightness(straight)
    assert s.n_points > 100 and s.n_centreline > 40
    assert s.rms_px < 0.5  # pixel quantisation only
    assert s.rms_fraction < 0.005


def test_boundary_straightness_curved_boundary_is_clearly_larger():
    straight = boundary.boundary_straightness(_class_image(lambda x: 20 + 0.4 * x))
    curved = boundary.boundary_straightness(_class_image(lambda x: 15 + 40 * ((x - 60) / 60.0) ** 2))
    # a parabola of sagitta 40 px over 120 px: the TLS residual is several pixels
    assert curved.rms_px > 5.0
    assert curved.rms_fraction > 10 * straight.rms_fraction


def test_boundary_needs_enough_points_and_bridges_narrow_gaps():
    cls = np.zeros((20, 20), np.int8)
    cls[5, 5], cls[5, 6] = 1, 2
    s = boundary.boundary_straightness(cls)
    assert 0 < s.n_centreline < 8 and np.isnan(s.rms_px)
    # a gap of grey (class 0) or blue (class 3) up to 2 * reach pixels wide still gives a boundary
    gap = _class_image(lambda x: 20 + 0.4 * x)
    edge = np.diff(gap.astype(int), axis=0, prepend=1) != 0
    gap[edge] = 3
    gap[np.roll(edge, 1, axis=0)] = 0
    s = boundary.boundary_straightness(gap)
    assert s.rms_px < 0.5 and s.n_centreline > 40


def test_bad_shapes_raise_value_error_naming_the_argument():
    rgb, part = _images()
    with pytest.raises(ValueError, match="gl_rgb"):
        compare.compare_arrays("v", rgb[..., :2], rgb, part, part, [FEATHER])
    with pytest.raises(ValueError, match="gl_part"):
        compare.comparison_mask(part[None], part, [FEATHER])
    with pytest.raises(ValueError, match="pixels"):
        compare.erode(part > 0, -1)


def test_erode_is_the_whole_image_erosion():
    """erode works inside the mask's bounding box: the same pixels as scipy's erosion of the whole image, masks
    touching the image border and an empty mask included."""
    from scipy import ndimage

    rng = np.random.default_rng(3)
    masks = [rng.uniform(size=(30, 40)) < 0.8, np.zeros((12, 9), bool), np.ones((7, 11), bool)]
    blob = np.zeros((50, 60), bool)
    blob[10:31, 22:47] = True
    blob[25:29, 5:23] = True  # a bar reaching left of the blob
    masks += [blob, blob & (rng.uniform(size=blob.shape) < 0.95)]
    for mask in masks:
        for px in (1, 2, 3):
            expected = ndimage.binary_erosion(mask, structure=np.ones((3, 3), bool), iterations=px, border_value=0)
            np.testing.assert_array_equal(compare.erode(mask, px), expected)


def test_compare_arrays_gives_the_numbers_of_the_whole_image_formulation():
    """The comparison converts only the compared pixels; its dE map, black holes, hue histogram and class images
    are those computed over whole images (non-finite values read as 0, as the statistics do)."""
    rng = np.random.default_rng(7)
    h, w = 40, 48
    ref = rng.uniform(0.0, 0.6, (h, w, 3)).astype(np.float32)
    gl = (ref * rng.uniform(0.9, 1.1, (h, w, 3))).astype(np.float32)
    gl[12:15, 10:30] = 0.0  # black holes
    gl[20, 20] = np.nan
    gl[21, 22] = np.inf
    part = np.zeros((h, w), np.int32)
    part[5:35, 6:44] = FEATHER
    part[18:22, 30:34] = 1
    ref_part = part.copy()
    ref_part[30, 8] = 1  # the renders disagree here
    n_dot_l = rng.uniform(0.0, 1.0, (h, w))
    ref_mask = rng.uniform(0.0, 1.0, (h, w))
    m = compare.compare_arrays("v", gl, ref, part, ref_part, [FEATHER], ref_n_dot_l=n_dot_l, ref_mask=ref_mask)

    mask = compare.comparison_mask(part, ref_part, [FEATHER])
    safe_gl = np.where(np.isfinite(gl), gl, 0.0).astype(np.float64)
    de = np.full(mask.shape, np.nan)
    de[mask] = compare.pixel_de(safe_gl[mask], ref.astype(np.float64)[mask])[0]
    np.testing.assert_array_equal(m.de_map, de)
    vals = de[mask]
    assert (m.n_pixels, m.de_median, m.de_p95, m.de_max) == (vals.size, np.median(vals), np.percentile(vals, 95),
                                                             vals.max())
    lit = mask & (n_dot_l >= compare.LIT_N_DOT_L)
    black = lit & (np.abs(safe_gl).max(axis=2) < compare.BLACK_RADIANCE)
    assert (m.n_lit, m.n_black) == (lit.sum(), black.sum()) and m.n_black > 10
    hue_mask = mask & (ref_mask >= compare.STRUCTURAL_MASK)
    assert m.hue == compare.hue_histogram(safe_gl[hue_mask])
    for img, sides in ((m.cls, True), (m.strict, False)):
        expected = np.full((h, w), -1, np.int8)
        expected[hue_mask] = compare.hue_classes(safe_gl[hue_mask], sides=sides)[2]
        np.testing.assert_array_equal(img, expected)
    assert not m.finite and "de_map" not in m.to_json() and "strict" not in m.to_json()
    assert read(compare.ViewMetrics, m.to_json()).hue == m.hue and m.to_json()["failures"] is not m.failures

"""rockdove.verify.boundary: coherence of the hue classes and curvature of the green/purple boundary (issue 12).

Synthetic class images: a straight boundary, a curved one, and speckle (a mosaic of independently coloured
'feathers', the pattern of the old per-card uniform thickness draw).
"""

import numpy as np
import pytest

from rockdove.verify import boundary


def _two_regions(boundary_row, h=80, w=120):
    """Green above the curve ``row = boundary_row(col)``, purple below."""
    rows = np.arange(h)[:, None]
    cols = np.arange(w)[None, :]
    return np.where(rows < boundary_row(cols), 1, 2).astype(np.int8)


def _speckle(tiles=20, tile_px=6, seed=0):
    """A mosaic of tile_px squares, each green or purple with probability 1/2."""
    c = np.random.default_rng(seed).integers(1, 3, (tiles, tiles)).astype(np.int8)
    return np.kron(c, np.ones((tile_px, tile_px), np.int8))


def test_two_regions_are_coherent_speckle_is_not():
    straight = boundary.class_coherence(_two_regions(lambda x: 20 + 0.4 * x))
    assert straight.green.largest_share == 1.0 and straight.purple.largest_share == 1.0
    assert straight.other.pixels == 0 and np.isnan(straight.other.largest_share)
    speckle = boundary.class_coherence(_speckle())
    assert speckle.green.regions > 10 and speckle.purple.regions > 10
    assert max(speckle.green.largest_share, speckle.purple.largest_share) < boundary.COHERENT_SHARE


def test_coherence_bridges_narrow_gaps_only():
    cls = np.full((40, 40), -1, np.int8)
    cls[5:15, 5:15] = 1
    cls[5:15, 19:29] = 1  # 4 px gap: bridged at reach 2
    cls[30:35, 30:35] = 1  # far away
    c = boundary.class_coherence(cls, reach_px=2).green
    assert c.regions == 2 and c.largest_share == pytest.approx(200 / 225)
    c0 = boundary.class_coherence(cls, reach_px=0).green
    assert c0.regions == 3 and c0.largest_share == pytest.approx(100 / 225)


def test_straight_boundary_line_fits_as_well_as_the_curve():
    c = boundary.boundary_curvature(_two_regions(lambda x: 20 + 0.4 * x))
    assert c.n_centreline > 40
    assert c.line_rms_px < 0.5 and c.ratio < 1.5


def test_curved_boundary_line_residual_is_several_times_the_curve_residual():
    c = boundary.boundary_curvature(_two_regions(lambda x: 15 + 40 * ((x - 60) / 60.0) ** 2))
    assert c.line_rms_px > 5.0
    assert c.ratio >= boundary.CURVED_RATIO * 3


def test_too_few_points_give_nan_not_a_number():
    cls = np.zeros((20, 20), np.int8)
    cls[5, 5], cls[5, 6] = 1, 2
    c = boundary.boundary_curvature(cls)
    assert np.isnan(c.ratio) and np.isnan(c.line_rms_px)


def test_boundary_shape_classifies_rendered_colours():
    green = np.array([0.02, 0.15, 0.04])  # Airy colour of a 650 nm film at cos theta 0.8 (h_ab ~ 165 deg)
    purple = np.array([0.29, 0.056, 0.24])  # ... at cos theta 0.5 (h_ab ~ 333 deg)
    cls = _two_regions(lambda x: 15 + 40 * ((x - 60) / 60.0) ** 2)
    rgb = np.where((cls == 1)[..., None], green, purple)
    region = np.ones(cls.shape, bool)
    region[:, :3] = False
    s = boundary.boundary_shape(rgb, region)
    assert s.coherent and s.curved
    assert s.coherence.green.pixels == int(((cls == 1) & region).sum())
    speckle = _speckle()
    s = boundary.boundary_shape(np.where((speckle == 1)[..., None], green, purple), np.ones(speckle.shape, bool))
    assert not s.coherent
    note = boundary.boundary_note("sweep_090", s)
    assert "sweep_090" in note and "not coherent" in note and "irregular" in note
    with pytest.raises(ValueError, match="rgb_linear"):
        boundary.boundary_shape(rgb[:10], region)


def test_class_shape_of_a_comparison_is_the_boundary_shape_of_its_colours():
    """The verification measures the shape from the classes the comparison made (ViewMetrics.strict and .cls):
    the same result as classifying the render's colours again."""
    from rockdove.verify import compare

    green = np.array([0.02, 0.15, 0.04])
    purple = np.array([0.29, 0.056, 0.24])
    cls = _two_regions(lambda x: 15 + 40 * ((x - 60) / 60.0) ** 2)
    rgb = np.where((cls == 1)[..., None], green, purple) * np.random.default_rng(1).uniform(0.5, 1.0, (*cls.shape, 1))
    part = np.ones(cls.shape, np.int32)
    m = compare.compare_arrays("sweep_090", rgb, rgb, part, part, [1])
    assert (m.cls >= 0).sum() > 5000
    np.testing.assert_equal(boundary.class_shape(m.strict, m.cls).to_json(),
                            boundary.boundary_shape(rgb, m.cls >= 0).to_json())

"""The ThinFilmLUT layout contract shared by the EXR file, the shaders and the verifier."""

import numpy as np
import pytest

from rockdove.lut import ThinFilmLUT


def _gradient_lut(n_thickness=5, n_angle=9, gamma=2.0, rng=(480.0, 700.0)):
    # rgb[i, j] = (x_j, y_i, 0): a table whose lookup reveals the node coordinates it used
    x = np.linspace(0, 1, n_angle)
    y = np.linspace(0, 1, n_thickness) if n_thickness > 1 else np.zeros(1)
    rgb = np.zeros((n_thickness, n_angle, 3), np.float32)
    rgb[..., 0] = x[None, :]
    rgb[..., 1] = y[:, None]
    return ThinFilmLUT(rgb, rng if n_thickness > 1 else (rng[0], rng[0]), angle_warp_gamma=gamma)


def test_sample_at_nodes_returns_node_values():
    lut = _gradient_lut()
    c, d = np.meshgrid(lut.cos_theta, lut.thickness_nm)
    np.testing.assert_allclose(lut.sample(c, d), lut.rgb, atol=1e-6)


def test_sample_is_linear_in_warped_coordinates_between_nodes():
    lut = _gradient_lut(gamma=2.0)
    cos = np.array([0.01, 0.2, 0.5, 0.9])
    d = np.array([480.0, 530.0, 610.0, 700.0])
    out = lut.sample(cos, d)
    np.testing.assert_allclose(out[:, 0], np.sqrt(cos), atol=1e-6)
    np.testing.assert_allclose(out[:, 1], (d - 480.0) / 220.0, atol=1e-6)


def test_sample_clamps_outside_the_domain():
    lut = _gradient_lut()
    np.testing.assert_allclose(lut.sample(-0.5, 100.0), lut.rgb[0, 0], atol=1e-7)
    np.testing.assert_allclose(lut.sample(2.0, 1e4), lut.rgb[-1, -1], atol=1e-7)


def test_texcoords_put_nodes_on_texel_centres():
    lut = _gradient_lut(n_thickness=4, n_angle=8)
    u, v = lut.texcoords(lut.cos_theta, lut.thickness_nm[2])
    np.testing.assert_allclose(u, (np.arange(8) + 0.5) / 8)
    np.testing.assert_allclose(v, (2 + 0.5) / 4)


def test_one_texel_high_table_ignores_thickness():
    lut = _gradient_lut(n_thickness=1)
    np.testing.assert_allclose(lut.sample(0.3, [100.0, 480.0, 900.0])[:, 0], np.sqrt(0.3), atol=1e-6)
    assert lut.texcoords(0.3, 480.0)[1] == 0.5


def test_rgb_is_read_only_float32():
    lut = _gradient_lut()
    assert lut.rgb.dtype == np.float32 and not lut.rgb.flags.writeable


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(rgb=np.zeros((2, 1, 3)), thickness_range_nm=(1, 2)), "rgb"),
        (dict(rgb=np.zeros((2, 4, 2)), thickness_range_nm=(1, 2)), "rgb"),
        (dict(rgb=np.full((2, 4, 3), np.nan), thickness_range_nm=(1, 2)), "finite"),
        (dict(rgb=np.zeros((2, 4, 3)), thickness_range_nm=(2, 1)), "thickness_range_nm"),
        (dict(rgb=np.zeros((2, 4, 3)), thickness_range_nm=(-1, 1)), "thickness_range_nm"),
        (dict(rgb=np.zeros((1, 4, 3)), thickness_range_nm=(1, 2)), "one-texel"),
        (dict(rgb=np.zeros((2, 4, 3)), thickness_range_nm=(1, 2), angle_warp_gamma=0), "angle_warp_gamma"),
    ],
)
def test_bad_tables_are_refused_by_name(kwargs, word):
    with pytest.raises(ValueError, match=word):
        ThinFilmLUT(**kwargs)

"""Procedural textures: feather base colour + alpha silhouette, feather mask, body base colour in the UVs."""

import numpy as np
import pytest

from rockdove import textures
from rockdove.geometry import BirdParams, build_body
from rockdove.geometry import sdf


@pytest.fixture(scope="module")
def feather():
    return textures.feather_textures(128)


@pytest.fixture(scope="module")
def coarse_body():
    return build_body(BirdParams(body_voxel_m=0.004))  # one subdivision level: st interpolated by subdivision


def _luma(rgb):
    return rgb[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])


def test_feather_textures_shapes_and_resolution_sources():
    t = textures.feather_textures(BirdParams(feather_texture_resolution=32))
    assert set(t) == {"base", "mask"}
    assert t["base"].shape == (32, 32, 4) and t["base"].dtype == np.uint8
    assert t["mask"].shape == (32, 32) and t["mask"].dtype == np.uint8
    assert textures.feather_textures(48)["base"].shape == (48, 48, 4)


@pytest.mark.parametrize("bad", [8, 0, -4, 2.5, "big"])
def test_bad_resolution_raises_value_error_naming_it(bad):
    with pytest.raises(ValueError, match="resolution"):
        textures.feather_textures(bad)


def test_alpha_is_a_feather_silhouette_not_a_rectangle(feather):
    a = feather["base"][..., 3]
    r = a.shape[0]
    assert a[0, 0] == a[0, -1] == a[-1, 0] == a[-1, -1] == 0  # transparent outside
    centre = a[int(0.05 * r):int(0.93 * r), r // 2]
    assert np.all(centre == 255)  # the rachis runs root to tip
    covered = (a >= 128).mean()
    assert 0.35 < covered < 0.85
    widths = (a >= 128).sum(axis=1)  # per row; row 0 is the tip
    mid = widths[int(0.35 * r)]
    assert widths[int(0.03 * r)] < mid and widths[int(0.9 * r)] < mid  # rounded tip, narrow quill


def test_feather_has_a_pale_rachis_and_barbs(feather):
    base = feather["base"]
    r = base.shape[0]
    row = int(0.4 * r)
    luma = _luma(base[row])
    assert luma[r // 2] > luma[int(0.35 * r)] + 20  # rachis lighter than the vane beside it
    column = _luma(base[int(0.1 * r):int(0.6 * r), int(0.3 * r)])
    assert np.std(column) > 3.0  # barbs alternate light and dark along the vane


def test_mask_is_white_at_the_tip_black_at_the_root_and_outside(feather):
    m, a = feather["mask"], feather["base"][..., 3]
    r = m.shape[0]
    assert np.all(m[a == 0] == 0)
    assert m[int(0.2 * r), r // 2] == 255  # v = 0.8: tip
    assert m[int(0.8 * r), r // 2] == 0  # v = 0.2: root
    inside = a[:, r // 2] > 0
    col = m[inside, r // 2].astype(int)
    assert np.all(np.diff(col) <= 0)  # inside the feather: decreasing from tip (row 0) to root


def test_body_texture_matches_the_3d_colour_at_the_vertices(coarse_body):
    res = 256
    img = textures.body_base_colour(res, coarse_body)
    assert img.shape == (res, res, 3) and img.dtype == np.uint8
    for part in (coarse_body.part, coarse_body.wings):  # the wings share the body's atlas and texture
        st = part.st.astype(np.float64)
        col = np.clip((st[:, 0] * res).astype(int), 0, res - 1)
        row = np.clip(((1.0 - st[:, 1]) * res).astype(int), 0, res - 1)
        looked_up = img[row, col].astype(int)
        expected = textures._encode(textures.body_colour_at(part.points_m.astype(np.float64))).astype(int)
        err = np.abs(looked_up - expected).max(axis=1)
        assert np.median(err) <= 3 and np.percentile(err, 90) <= 20, part.name
    wing_luma = _luma(textures._encode(textures.body_colour_at(coarse_body.wings.points_m.astype(np.float64))))
    assert np.mean(wing_luma < 0.4 * np.median(wing_luma)) > 0.02  # the dark bars and primaries are on the Wings
    assert not np.any(np.all(img == 0, axis=-1))  # every texel filled (seams padded)


def test_body_texture_accepts_params_bird_or_part_and_is_deterministic(coarse_body):
    from rockdove.geometry import Bird

    p = BirdParams(body_texture_resolution=64)
    a = textures.body_base_colour(p, Bird((coarse_body.part,)))
    b = textures.body_base_colour(64, coarse_body.part)
    assert a.shape == (64, 64, 3) and np.array_equal(a, b)
    with pytest.raises(ValueError, match="bird"):
        textures.body_base_colour(64, object())


def test_body_palette_blue_grey_body_dark_neck_wing_bars_tail_band():
    side = np.array([[0.0, 0.05, 0.0]]) + sdf.BELLY.centre_m  # a point toward the belly
    side = side - sdf.body_sdf(side)[:, None] * sdf.sdf_gradient(sdf.body_sdf, side)
    neck_pt = np.array([[0.0, 0.175, 0.056 + 0.024]])  # throat, in front of the neck
    tail_tip = np.array([sdf.TAIL.centre_m]) + sdf.TAIL.rotation @ np.array([0.0, 0.0, -0.066])
    lin = textures.body_colour_at(np.concatenate([side, neck_pt, tail_tip]))
    body_c, neck_c, tail_c = lin
    assert body_c[2] > body_c[0]  # blue-grey
    assert neck_c.sum() < 0.7 * body_c.sum()  # darker neck
    assert tail_c.sum() < 0.3 * body_c.sum()  # dark tail band
    # the folded wing has black bars: sample its outer surface along its length
    z = np.linspace(-0.9, 0.9, 400)
    local = np.stack([np.full_like(z, 1.0), np.full_like(z, 0.0), z], 1) * np.asarray(sdf.WING_L.radii_m)
    local[:, 0] *= np.sqrt(1 - z**2)
    pts = local @ sdf.WING_L.rotation.T + np.asarray(sdf.WING_L.centre_m)
    luma = textures.body_colour_at(pts) @ np.array([0.2126, 0.7152, 0.0722])
    dark = luma < 0.4 * np.median(luma)
    assert dark.any() and np.count_nonzero(np.diff(dark.astype(int)) == 1) == 2  # two separate bars

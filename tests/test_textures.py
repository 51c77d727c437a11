"""Procedural textures: feather base colour + alpha silhouette, feather mask, body base colour in the UVs."""

import numpy as np
import pytest

from rockdove import textures
from rockdove.geometry import BirdParams, build_body, plumage, sdf


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


def test_mask_is_white_at_the_tip_black_at_the_root_and_padded_past_the_silhouette(feather):
    m, a = feather["mask"], feather["base"][..., 3]
    r = m.shape[0]
    assert np.all(m == m[:, :1]) and m[a == 0].max() == 255  # a row's value outside the card too (mip levels)
    assert m[int(0.2 * r), r // 2] == 255  # v = 0.8: tip
    assert m[int(0.8 * r), r // 2] == 0  # v = 0.2: root
    inside = a[:, r // 2] > 0
    col = m[inside, r // 2].astype(int)
    assert np.all(np.diff(col) <= 0)  # inside the feather: decreasing from tip (row 0) to root


def test_body_texture_matches_the_3d_colour_at_the_vertices(coarse_body):
    res = 256
    img = textures.body_base_colour(res, coarse_body)
    assert img.shape == (res, res, 3) and img.dtype == np.uint8
    part = coarse_body.part
    st = part.st.astype(np.float64)
    assert st[:, 1].min() >= plumage.ATLAS_START - 1e-6  # the body's charts leave the palette strip free
    col = np.clip((st[:, 0] * res).astype(int), 0, res - 1)
    row = np.clip(((1.0 - st[:, 1]) * res).astype(int), 0, res - 1)
    looked_up = img[row, col].astype(int)
    expected = textures._encode(textures.body_colour_at(part.points_m.astype(np.float64))).astype(int)
    err = np.abs(looked_up - expected).max(axis=1)
    assert np.median(err) <= 3 and np.percentile(err, 90) <= 20
    strip = img[res - int(res * plumage.PALETTE_STRIP):]
    assert np.array_equal(strip, textures.palette_strip(res))  # the feather tiles, as painted
    guard = img[res - int(res * (plumage.PALETTE_STRIP + plumage.ATLAS_START) / 2):res - len(strip)]
    assert len(guard) > 0 and np.all(guard == strip[:1])  # above them, their top row: no chart bleeds in
    assert not np.any(np.all(img == 0, axis=-1))  # every texel filled (seams padded)


def test_palette_tiles_bar_band_and_ramp():
    res = 512
    strip = textures.palette_strip(res).astype(float) @ np.array([0.2126, 0.7152, 0.0722])
    rows, tile_w = strip.shape[0], res // plumage.TILES

    def along(tile):  # luminance along the rachis of a tile, from the quill (v = 0) to the tip (v = 1)
        return strip[::-1, int((tile + 0.5) * tile_w) + 2]

    ramp = [along(t)[rows // 2] for t in range(plumage.RAMP)]
    assert np.all(np.diff(ramp) > 0)  # the coat's greys from the dark neck to the pale coverts
    for tile, lo, hi in ((plumage.T_BAR, 0.6, 0.78), (plumage.T_RECTRIX, 0.88, 0.99)):
        a = along(tile)
        band = a[int(lo * rows):int(hi * rows)].mean()
        assert band < 0.4 * a[int(0.2 * rows):int(0.45 * rows)].mean(), tile  # the black band
    assert along(plumage.T_WHITE)[rows // 2] > along(plumage.RAMP - 1)[rows // 2]  # the white rump


def test_body_texture_accepts_params_bird_or_part_and_is_deterministic(coarse_body):
    from rockdove.geometry import Bird

    p = BirdParams(body_texture_resolution=64)
    a = textures.body_base_colour(p, Bird((coarse_body.part,)))
    b = textures.body_base_colour(64, coarse_body.part)
    assert a.shape == (64, 64, 3) and np.array_equal(a, b)
    with pytest.raises(ValueError, match="bird"):
        textures.body_base_colour(64, object())


def test_body_palette_blue_grey_body_dark_neck_white_rump():
    side = np.array([[0.0, 0.05, 0.0]]) + sdf.BELLY.centre_m  # a point toward the belly
    side = side - sdf.body_sdf(side)[:, None] * sdf.sdf_gradient(sdf.body_sdf, side)
    neck_pt = np.array([[0.0, 0.175, 0.056 + 0.024]])  # throat, in front of the neck
    rump = np.array([[0.0, 0.088, -0.062]])
    body_c, neck_c, rump_c = textures.body_colour_at(np.concatenate([side, neck_pt, rump]))
    assert body_c[2] > body_c[0]  # blue-grey
    assert neck_c.sum() < 0.7 * body_c.sum()  # darker neck
    assert rump_c.sum() > 1.5 * body_c.sum()  # white rump patch
    tiles = textures.coat_tiles(np.concatenate([side, neck_pt, rump]))
    assert tiles[2] == plumage.T_WHITE and tiles[1] < tiles[0] < plumage.RAMP  # darker tiles on the neck


"""Procedural textures: feather base colour + alpha silhouette, feather mask, the plumage atlas (colour with a soft
alpha, normal map with roughness), body base colour in the UVs."""

import numpy as np
import pytest

from rockdove import textures
from rockdove.geometry import BirdParams, build_body, colours, sdf


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
    assert set(t) == {"base", "mask", "plumage_base", "plumage_normal"}
    assert t["base"].shape == (32, 32, 4) and t["base"].dtype == np.uint8
    assert t["mask"].shape == (32, 32) and t["mask"].dtype == np.uint8
    atlas = (colours.ATLAS_ROWS * 128, colours.ATLAS_COLUMNS * 64, 4)  # tiles H / 2 x H, H at least 128
    assert t["plumage_base"].shape == t["plumage_normal"].shape == atlas and t["plumage_base"].dtype == np.uint8
    assert textures.feather_textures(48)["base"].shape == (48, 48, 4)


@pytest.mark.parametrize("bad", [8, 0, -4, 2.5, "big"])
def test_bad_resolution_raises_value_error_naming_it(bad):
    with pytest.raises(ValueError, match="resolution"):
        textures.feather_textures(bad)


def test_alpha_is_a_feather_silhouette_not_a_rectangle(feather):
    a = feather["base"][..., 3]
    r = a.shape[0]
    assert a[0, 0] == a[0, -1] == a[-1, 0] == a[-1, -1] == 0  # transparent outside
    centre = a[int(0.05 * r):int(0.9 * r), r // 2]
    assert np.all(centre >= 128)  # the rachis runs root to tip
    covered = (a >= 128).mean()
    assert 0.35 < covered < 0.85
    widths = (a >= 128).sum(axis=1)  # per row; row 0 is the tip
    mid = widths[int(0.35 * r)]
    assert widths[int(0.03 * r)] < mid and widths[int(0.9 * r)] < mid  # rounded tip, narrow quill
    row = a[int(0.4 * r)]
    assert ((row > 10) & (row < 245)).sum() >= 6  # a soft edge: several partly transparent texels each side


def test_feather_has_a_pale_rachis_and_barbs(feather):
    base = feather["base"]
    r = base.shape[0]
    row = int(0.4 * r)
    luma = _luma(base[row])
    assert luma[r // 2] > luma[int(0.35 * r)] + 5  # rachis lighter than the vane beside it
    column = _luma(base[int(0.1 * r):int(0.6 * r), int(0.3 * r)])
    # barbs alternate light and dark along the vane: faintly, as the neck's feathers carry no normal map (their
    # relief shows only here; the plumage cards have theirs in plumage_normal.png)
    assert np.std(column) > 1.0


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
    col = np.clip((st[:, 0] * res).astype(int), 0, res - 1)
    row = np.clip(((1.0 - st[:, 1]) * res).astype(int), 0, res - 1)
    looked_up = img[row, col].astype(int)
    expected = textures._encode(textures.body_colour_at(part.points_m.astype(np.float64))).astype(int)
    err = np.abs(looked_up - expected).max(axis=1)
    assert np.median(err) <= 3 and np.percentile(err, 90) <= 20
    assert not np.any(np.all(img == 0, axis=-1))  # every texel filled (seams padded)


def _tile(img, index):
    r = img.shape[0] // colours.ATLAS_ROWS
    row, col = divmod(index, colours.ATLAS_COLUMNS)
    return img[row * r:(row + 1) * r, col * r // 2:(col + 1) * r // 2]


def test_plumage_atlas_feathers_soft_edged_with_relief_patterns_and_no_repeats(feather):
    base, normal = feather["plumage_base"], feather["plumage_normal"]
    tiles = sum(n for *_, n in colours.ATLAS)
    start = {k: colours.TILE_START[k][0] for k in colours.TILE_START}
    for i in range(tiles - 1):  # every feather tile: transparent round it, a soft edge, one per variant
        a = _tile(base, i)[..., 3].astype(int)
        assert a[0].max() == a[:, 0].max() == a[:, -1].max() == 0 and a.max() == 255, i
        edge = (a > 0) & (a < 255)
        assert 0.05 < edge.sum() / (a > 127).sum() < 0.8, i
    assert len({_tile(base, i).tobytes() for i in range(tiles)}) == tiles  # variants differ
    n = _tile(normal, start["contour", colours.COAT_SRGB[3]]).astype(float)
    r, w = n.shape[:2]
    nx, nz = n[..., 0] / 127.5 - 1, n[..., 2] / 127.5 - 1
    ridge = nx[r // 2, w // 2 - 4:w // 2 + 4]
    assert nz.min() > 0.3 and ridge[:4].min() < -0.05 < 0.05 < ridge[4:].max()  # the rachis's ridge
    assert np.std(nx[int(0.4 * r):int(0.6 * r), int(0.15 * w):int(0.3 * w)]) > 0.01  # barbs
    assert np.ptp(n[int(0.2 * r):int(0.8 * r), int(0.1 * w):int(0.45 * w), 3]) > 20  # roughness varies

    for key, band in ((("greater", colours.WING_SRGB), (0.6, 0.8)), (("rectrix", colours.TAIL_SRGB), (0.9, 0.96))):
        lum = _luma(_tile(base, start[key]))[:, int(0.35 * w)]  # down the vane, tip (row 0) to root
        dark = lum[int((1 - band[1]) * r):int((1 - band[0]) * r)].mean()
        assert dark < 0.4 * lum[int(0.6 * r):int(0.75 * r)].mean(), key  # wing bar, terminal band
    eye = _luma(_tile(base, start["eye", colours.ATLAS[-1][1]]))
    assert eye[:int(0.08 * r)].max() < 20 < 60 < eye[int(0.2 * r):int(0.3 * r)].mean()  # pupil (v = 1) in the iris


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
    tiles = colours.coat_tiles(np.concatenate([side, neck_pt, rump]), np.random.default_rng(0))
    white = colours.TILE_START["contour", colours.RUMP_SRGB][0]
    assert white <= tiles[2] < white + 4 and tiles[1] < tiles[0] < white  # darker tones on the neck


"""Reading a written asset back (rockdove.render.scene) and the views (rockdove.render.views)."""

import json

import numpy as np
import pytest
from conftest import built_value, copy_asset

from rockdove.render import scene as sc
from rockdove.render import texture, triangulate
from rockdove.render.views import View, default_views, hero_view, light_sweep_views, look_at, turntable_views


@pytest.fixture(scope="module")
def asset(small_asset):
    """The root layer of the session's small real build (measured preset, both shading variants)."""
    return str(small_asset / "pigeon.usda")


def test_fan_triangulation_of_mixed_polygons_keeps_area_and_winding():
    counts = [3, 4, 5]
    idx = np.arange(12)
    tris = triangulate.fan_triangulate(counts, idx)
    assert tris.tolist() == [[0, 1, 2], [3, 4, 5], [3, 5, 6], [7, 8, 9], [7, 9, 10], [7, 10, 11]]
    assert triangulate.fan_triangulate(counts, idx, left_handed=True)[1].tolist() == [3, 5, 4]
    with pytest.raises(ValueError, match="face_vertex_counts"):
        triangulate.fan_triangulate([2], [0, 1])


def test_load_scene_reads_every_part_as_the_build_generated_it_in_both_variants(small_asset):
    """The reader against the real authoring code: each part's world points, triangles, primvars and texture
    paths, and the film and LUT, read back from the files equal what the build generated (its cached bird
    and LUT), whichever shading variant is selected."""
    from rockdove.geometry.types import drop_unreferenced_points

    bird, lut = built_value(small_asset, "bird"), built_value(small_asset, "lut")
    tex = small_asset / "textures"
    for variant in ("baked", "physical"):
        s = sc.load_scene(small_asset, variants={"shading": variant})
        assert s.variants == {"shading": variant, "motion": "rest"}
        assert [p.name for p in s.parts] == [p.name for p in bird.parts]
        for src in map(drop_unreferenced_points, bird.parts):  # as written (validators reject unused points)
            got = s.part(src.name)
            assert got.material_kind == src.material
            np.testing.assert_allclose(got.positions_m, src.points_m, atol=1e-6)
            assert len(got.triangles) == int(np.sum(np.asarray(src.face_vertex_counts) - 2))
            np.testing.assert_allclose(np.linalg.norm(got.normals, axis=1), 1, atol=1e-5)
        feathers, body = s.part("NeckFeathers"), s.part("Body")
        np.testing.assert_array_equal(feathers.thickness_nm, drop_unreferenced_points(
            bird.part("NeckFeathers")).primvars["thickness"].values)
        assert feathers.st.shape == (len(feathers.positions_m), 2) and feathers.neck_s is not None
        assert feathers.base_colour_texture == str(tex / "feather_base.png")
        assert feathers.mask_texture == str(tex / "feather_mask.png")
        assert body.base_colour_texture == str(tex / "body_base.png")
        assert body.mask_texture is None and body.thickness_nm is None
        # triangles wind counter-clockwise about the outward normals of the (convex-ish) body
        p, t = body.positions_m.astype(np.float64), body.triangles
        tri_n = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])
        vert_n = body.normals[body.triangles].mean(axis=1)
        assert np.mean(np.sum(tri_n * vert_n, axis=1) > 0) > 0.99
        f = s.film
        assert f.model.name == "keratin" and f.model.cauchy_a == pytest.approx(1.532)
        assert f.model.cauchy_b_nm2 == pytest.approx(5890)
        assert f.thickness_primvar == "thickness" and f.lut_file == str(tex / "thinfilm_lut.exr")
        assert f.thickness_range_nm == tuple(built_value(small_asset, "thickness_range")) == lut.thickness_range_nm
        assert f.angle_warp_gamma == lut.angle_warp_gamma
        np.testing.assert_array_equal(s.load_lut().rgb, lut.rgb)


def test_load_scene_applies_world_transforms(small_asset, tmp_path):
    """A translate op authored over the Body (in the interface layer of a copy) moves its points read back; a rotation
    and scale over the Wings turn and scale their points and turn their normals."""
    from pxr import Gf, Usd, UsdGeom

    copy = copy_asset(small_asset, tmp_path / "pigeon")
    stage = Usd.Stage.Open(str(copy / "pigeon.usda"))
    UsdGeom.Xformable(stage.GetPrimAtPath("/Pigeon/Geom/Body")).AddTranslateOp().Set(Gf.Vec3d(0.1, -0.2, 0.3))
    stage.GetRootLayer().Save()
    before, after = sc.load_scene(small_asset), sc.load_scene(copy)
    np.testing.assert_allclose(after.part("Body").positions_m, before.part("Body").positions_m + [0.1, -0.2, 0.3],
                               atol=1e-6)
    np.testing.assert_array_equal(after.part("Beak").positions_m, before.part("Beak").positions_m)
    # the 3x3 block too: rotateY 90 degrees with a uniform scale 2 (they commute): (x, y, z) -> 2 (z, y, -x), and
    # the normals turn with it (unit length)
    wings = UsdGeom.Xformable(stage.GetPrimAtPath("/Pigeon/Geom/Wings"))
    wings.AddRotateYOp().Set(90.0)
    wings.AddScaleOp().Set(Gf.Vec3f(2.0, 2.0, 2.0))
    stage.GetRootLayer().Save()
    turned, was = sc.load_scene(copy).part("Wings"), before.part("Wings")
    x, y, z = was.positions_m.T.astype(np.float64)
    np.testing.assert_allclose(turned.positions_m, 2.0 * np.stack([z, y, -x], axis=1), atol=1e-6)
    x, y, z = was.normals.T.astype(np.float64)
    np.testing.assert_allclose(turned.normals, np.stack([z, y, -x], axis=1), atol=1e-6)


def test_load_scene_variants_and_bad_input(asset, tmp_path):
    assert sc.load_scene(asset).variants == {"shading": "baked", "motion": "rest"}
    assert sc.load_scene(asset, variants={"shading": "physical"}).variants == {"shading": "physical", "motion": "rest"}
    with pytest.raises(ValueError, match="shading"):
        sc.load_scene(asset, variants={"shading": "nope"})
    with pytest.raises(ValueError, match="asset"):
        sc.load_scene(tmp_path)  # a folder without pigeon.usda
    with pytest.raises(ValueError, match="does not exist"):
        sc.load_scene(tmp_path / "missing.usda")


def test_texture_sampling_uses_texel_centres_and_bottom_origin():
    img = np.zeros((2, 4, 1))
    img[0, :, 0] = 1.0  # top row
    img[:, :, 0] += np.arange(4)  # columns 0..3
    # bottom-left texel centre
    assert texture.sample_texture(img, [0.125, 0.25])[0] == pytest.approx(0.0)
    assert texture.sample_texture(img, [0.125, 0.75])[0] == pytest.approx(1.0)  # top row
    assert texture.sample_texture(img, [0.375, 0.5])[0] == pytest.approx(1.5)  # halfway between rows
    assert texture.sample_texture(img, [0.0, 0.0])[0] == pytest.approx(0.0)  # clamp to edge


def test_views_are_deterministic_serialisable_and_sweep_the_light_view_angle(asset):
    s = sc.load_scene(asset)
    views = default_views(s, 64, 48)
    assert [v.name for v in views] == ["turntable_030", "turntable_210", "sweep_060", "sweep_120"]
    again = default_views(s, 64, 48)
    assert views == again
    for v in views:
        assert View(**json.loads(json.dumps(v.to_dict()))) == v
        assert np.linalg.norm(v.light_direction) == pytest.approx(1.0)
    sweep = light_sweep_views(s.neck_centre_m, 5, 32, 32)
    for v, alpha in zip(sweep, np.linspace(30, 150, 5)):
        view_dir = v.eye_m - s.neck_centre_m
        view_dir /= np.linalg.norm(view_dir)
        assert np.degrees(np.arccos(view_dir @ v.light_direction)) == pytest.approx(alpha)
        np.testing.assert_array_equal(v.camera_to_world, sweep[0].camera_to_world)  # camera still
    # the camera looks at its target down -Z
    m = look_at([0, 0, 2], [0, 0, 0])
    np.testing.assert_allclose(m[:3, 2], [0, 0, 1])
    tt = turntable_views(s.bounds_m, 4, 32, 32)
    assert len({tuple(v.eye_m.round(6)) for v in tt}) == 4
    # issue 12: turntables and the hero view from eye level (a little above the centre, never from below),
    # the hero 3/4 from the front
    centre = np.asarray(s.bounds_m).mean(axis=0)
    hero = hero_view(s.bounds_m, 64, 64)
    for v in tt + [hero]:
        d = (v.eye_m - centre) / np.linalg.norm(v.eye_m - centre)
        assert 0.0 < np.degrees(np.arcsin(d[1])) <= 12.0, v.name
    d = hero.eye_m - centre
    assert hero.name == "hero" and (hero.width, hero.height) == (64, 64)
    assert 25.0 <= np.degrees(np.arctan2(d[0], d[2])) <= 55.0  # 3/4: between the front and the side
    with pytest.raises(ValueError, match="n must be"):
        turntable_views(s.bounds_m, 0, 32, 32)
    with pytest.raises(ValueError, match="width"):
        View("x", np.eye(4), 0.5, 0, 10, [0, 0, 1], [1, 1, 1])


def test_display_images_use_the_srgb_oetf_of_the_clipped_value_and_linear_averaging(tmp_path):
    from PIL import Image

    from rockdove.render.images import box_downsample, contact_sheet
    from rockdove.srgb import linear_to_srgb8

    # sRGB OETF (IEC 61966-2-1): 0.5 linear -> 0.7354 -> 188; out-of-range values clip
    assert linear_to_srgb8(np.array([[0.0, 0.5, 1.0], [-0.2, 2.0, 0.0031308]])).tolist() == [[0, 188, 255],
                                                                                            [0, 255, 10]]
    img = np.zeros((4, 4, 3), np.float32)
    img[:2, :2] = 1.0
    np.testing.assert_array_equal(box_downsample(img, 2)[..., 0], [[1.0, 0.0], [0.0, 0.0]])
    np.testing.assert_array_equal(box_downsample(np.eye(4), 4), [[0.25]])
    with pytest.raises(ValueError, match="factor"):
        box_downsample(img, 3)
    tile = np.full((10, 12, 4), 255, np.uint8)
    tile[:, :6, 3] = 0  # the left half transparent: the background shows through
    path = contact_sheet(tmp_path / "sheet.png", [[("a", tile), ("b", tile)], [("c", tile)]], label_px=16)
    with Image.open(path) as im:
        assert im.size == (2 * 12, 2 * (10 + 16))
        px = np.asarray(im)
    assert px[16 + 5, 2].tolist() == [32, 32, 32] and px[16 + 5, 8].tolist() == [255, 255, 255]
    with pytest.raises(ValueError, match="at least one"):
        contact_sheet(tmp_path / "x.png", [[]])


def test_display_pngs_decode_to_their_pixels_rgb_and_rgba_and_depend_on_the_pixels_alone(tmp_path):
    """save_png writes its own PNG (encode_png: the Up filter, zlib outside the GIL); Pillow reads back every
    pixel, for RGB and RGBA, sizes down to 1 x 1, and wrapping differences between rows (0 below 255)."""
    from PIL import Image

    from rockdove.png import encode_png, save_png

    rng = np.random.default_rng(11)
    ramp = np.zeros((4, 3, 3), np.uint8)
    ramp[1::2] = 255  # rows alternate 0 / 255: every Up difference wraps
    images = [rng.integers(0, 256, (37, 53, 3), dtype=np.uint8), rng.integers(0, 256, (5, 7, 4), dtype=np.uint8),
              np.full((1, 1, 3), 200, np.uint8), ramp]
    for k, img in enumerate(images):
        path = save_png(img, tmp_path / f"{k}.png")
        with Image.open(path) as im:
            assert im.format == "PNG" and im.mode == ("RGBA" if img.shape[2] == 4 else "RGB")
            np.testing.assert_array_equal(np.asarray(im), img)
        assert open(path, "rb").read() == encode_png(img.copy())  # the same pixels, the same bytes
    for bad in (np.zeros((4, 4, 2), np.uint8), np.zeros((0, 4, 3), np.uint8), np.zeros((4, 4, 3), np.float32)):
        with pytest.raises(ValueError, match="image must be"):
            encode_png(bad)

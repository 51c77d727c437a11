"""The rock dove measured on the written asset (rockdove.verify.anatomy): in range on a small build, and a
broken silhouette, posture or part fails."""

import numpy as np
import pytest
from conftest import copy_asset

from rockdove.render.scene import load_scene
from rockdove.verify import anatomy


def _measure(asset):
    return anatomy.measure_scene(load_scene(asset))


def test_every_measure_is_in_its_published_range_on_a_small_asset(small_asset):
    result = _measure(small_asset)
    assert result.failures == () and result.passed
    assert [m.name for m in result.measures] == list(anatomy.RANGES)
    values = {m.name: m.value for m in result.measures}
    assert 29.0 <= values["total_length"] <= 37.0 and 9.5 <= values["tail_length"] <= 12.0
    assert all(len(line.split()) > 3 for line in anatomy.format_rows(result))


def _edit(asset, tmp_path, prim, op):
    """A copy of ``asset`` with ``op(xformable)`` applied to ``/Pigeon/Geom/<prim>`` in its geometry layer."""
    from pxr import Sdf, Usd, UsdGeom

    copy = copy_asset(asset, tmp_path / "edited")
    layer = Sdf.Layer.FindOrOpen(str(copy / "pigeon_geom.usdc"))
    stage = Usd.Stage.Open(layer)
    op(UsdGeom.Xformable(stage.GetPrimAtPath(f"/Pigeon/Geom/{prim}")))
    layer.Save()
    return copy


@pytest.mark.parametrize("prim, op, broken", [
    ("Tail", lambda x: x.AddScaleOp().Set((1.0, 1.0, 1.6)), {"tail_length", "total_length"}),  # a long tail
    ("Legs", lambda x: x.AddTranslateOp().Set((0.0, 0.02, 0.0)), {"toes_ground"}),  # feet off the ground
    ("Wings", lambda x: x.AddScaleOp().Set((1.4, 1.0, 1.0)), {"wing_overhang"}),  # wings standing out
    ("Tail", lambda x: x.AddScaleOp().Set((0.45, 1.0, 1.0)), {"tail_width"}),  # a stick from behind
    ("Tail", lambda x: x.AddScaleOp().Set((1.0, 0.05, 1.0)), {"tail_depth"}),  # a flat board
    ("CoatFeathers", lambda x: x.AddTranslateOp().Set((0.0, 0.5, 0.0)), {"tail_base_depth"}),  # no coverts
    ("HeadFeathers", lambda x: x.AddTranslateOp().Set((0.0, 0.5, 0.0)), {"head_feather_cover"}),  # a bare head
])
def test_a_broken_silhouette_fails_its_measure(small_asset, tmp_path, prim, op, broken):
    result = _measure(_edit(small_asset, tmp_path, prim, op))
    failed = {m.name for m in result.measures if not m.passed}
    assert not result.passed and broken <= failed, failed
    assert all(any(name in f for f in result.failures) for name in broken)


def test_check_ranges_and_a_bird_without_its_parts():
    good = {name: (lo if lo is not None else hi) for name, (lo, hi, *_rest) in anatomy.RANGES.items()}
    assert anatomy.check(good).passed
    bad = anatomy.check({**good, "body_axis": 12.0, "tail_length": float("nan")})
    assert not bad.passed and len(bad.failures) == 2 and "body_axis" in bad.failures[0]

    class Scene:
        parts = ()

    result = anatomy.measure_scene(Scene())
    assert not result.passed and "no mesh 'Body'" in result.failures[0]


def test_colour_measures_read_the_bound_materials(small_asset):
    scene = load_scene(small_asset)
    values = anatomy.measures(scene)
    eyes = next(p for p in scene.parts if p.name == "Eyes")
    object.__setattr__(eyes, "base_colour", np.array([0.1, 0.3, 0.9], np.float32))  # a blue iris
    assert not 0.0 <= anatomy.measures(scene)["iris_hue"] <= 40.0 <= 360.0
    assert values["tail_band_contrast"] < 0.5 and values["rump_luminance"] > 0.5


def _binary_alpha_copy(path, tmp_path):
    from PIL import Image

    with Image.open(path) as im:
        a = np.asarray(im).copy()
    a[..., 3] = np.where(a[..., 3] >= 128, 255, 0)
    out = tmp_path / "binary.png"
    Image.fromarray(a).save(out)
    return str(out)


def test_wing_bars_soft_edges_pupil_and_claws_fail_when_broken(small_asset, tmp_path):
    scene = load_scene(small_asset)
    good = anatomy.measures(scene)
    assert good["wing_bar_count"] == 2 and good["soft_edge_share"] > 0.5 and good["pupil_offset"] < 0.15

    def broken(name, **values):
        part = next(p for p in scene.parts if p.name == name)
        saved = {k: getattr(part, k) for k in values}
        for k, v in values.items():
            object.__setattr__(part, k, v)
        result = anatomy.check(anatomy.measures(scene))
        for k, v in saved.items():
            object.__setattr__(part, k, v)
        return {m.name: m for m in result.measures if not m.passed}

    wings = next(p for p in scene.parts if p.name == "Wings")
    grey = np.broadcast_to(wings.st[:1], wings.st.shape)  # every texel of the wing one pale grey one
    assert "wing_bar_count" in broken("Wings", st=np.ascontiguousarray(grey))
    c = wings.positions_m.mean(0)
    a = np.radians(-45.0)  # the wing turned an eighth about x: its bars along it
    turn = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]], np.float32)
    assert "wing_bar_angle" in broken("Wings", positions_m=(wings.positions_m - c) @ turn.T + c)
    coat = next(p for p in scene.parts if p.name == "CoatFeathers")
    assert "soft_edge_share" in broken("CoatFeathers",
                                       base_colour_texture=_binary_alpha_copy(coat.base_colour_texture, tmp_path))
    eyes = next(p for p in scene.parts if p.name == "Eyes")
    st = eyes.st.copy()
    v, one_side = (st[:, 1] * 4) % 1.0, (st[:, 0] * 16) % 1.0 < 0.5  # v and u in the eye's tile
    st[(v > 0.75) & one_side, 1] -= 0.05  # iris where the pupil was on one side, pupil over the iris on the other
    st[(v > 0.6) & (v < 0.9) & ~one_side, 1] += (0.95 - v[(v > 0.6) & (v < 0.9) & ~one_side]) / 4
    assert "pupil_offset" in broken("Eyes", st=st)
    assert "claw_luminance" in broken("Claws", base_colour=np.full(3, 0.8, np.float32))


def test_straight_diverging_wing_bars_fail(small_asset, tmp_path):
    """Two straight black stripes 30 degrees apart on a flat wing (the old bird's): counted, but neither side by
    side nor curved."""
    import dataclasses

    from PIL import Image

    scene = load_scene(small_asset)
    img = np.full((200, 200, 3), 200, np.uint8)
    yy, xx = np.mgrid[0:200, 0:200]
    img[np.abs(xx - 35) < 8] = 20  # one stripe down the image, one 30 degrees off it
    img[np.abs(xx - 130 - np.tan(np.radians(30)) * (yy - 100)) < 8] = 20
    Image.fromarray(img).save(tmp_path / "bars.png")
    y, z = np.meshgrid([0.06, 0.14], [-0.10, 0.0], indexing="ij")
    quads = np.concatenate([np.stack([np.full(4, x), y.ravel(), z.ravel()], 1) for x in (0.06, -0.06)])
    st = np.tile(np.stack([(z.ravel() + 0.10) / 0.10, (y.ravel() - 0.06) / 0.08], 1), (2, 1))
    wings = dataclasses.replace(next(p for p in scene.parts if p.name == "Wings"), positions_m=quads.astype(np.float32),
                                normals=np.sign(quads[:, :1]) * np.array([[1.0, 0.0, 0.0]], np.float32),
                                st=st.astype(np.float32), triangles=np.array([[0, 1, 3], [0, 3, 2], [4, 7, 5],
                                                                              [4, 6, 7]], np.int32),
                                base_colour_texture=str(tmp_path / "bars.png"), base_colour_srgb=True)
    flat = dataclasses.replace(scene, parts=tuple(wings if p.name == "Wings" else p for p in scene.parts))
    values = anatomy.measures(flat)
    assert values["wing_bar_count"] == 2
    failed = {m.name for m in anatomy.check(values).measures if not m.passed}
    assert {"wing_bar_spread", "wing_bar_bow"} <= failed, values

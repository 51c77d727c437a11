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
    assert result["failures"] == [] and result["passed"]
    assert [r["name"] for r in result["measures"]] == list(anatomy.RANGES)
    values = {r["name"]: r["value"] for r in result["measures"]}
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
])
def test_a_broken_silhouette_fails_its_measure(small_asset, tmp_path, prim, op, broken):
    result = _measure(_edit(small_asset, tmp_path, prim, op))
    failed = {r["name"] for r in result["measures"] if not r["passed"]}
    assert not result["passed"] and broken <= failed, failed
    assert all(any(name in f for f in result["failures"]) for name in broken)


def test_check_ranges_and_a_bird_without_its_parts():
    good = {name: (lo if lo is not None else hi) for name, (lo, hi, *_rest) in anatomy.RANGES.items()}
    assert anatomy.check(good)["passed"]
    bad = anatomy.check({**good, "body_axis": 12.0, "tail_length": float("nan")})
    assert not bad["passed"] and len(bad["failures"]) == 2 and "body_axis" in bad["failures"][0]

    class Scene:
        parts = ()

    result = anatomy.measure_scene(Scene())
    assert not result["passed"] and "no mesh 'Body'" in result["failures"][0]


def test_colour_measures_read_the_bound_materials(small_asset):
    scene = load_scene(small_asset)
    values = anatomy.measures(scene)
    eyes = next(p for p in scene.parts if p.name == "Eyes")
    object.__setattr__(eyes, "base_colour", np.array([0.1, 0.3, 0.9], np.float32))  # a blue iris
    assert not 0.0 <= anatomy.measures(scene)["iris_hue"] <= 40.0 <= 360.0
    assert values["tail_band_contrast"] < 0.5 and values["rump_luminance"] > 0.5

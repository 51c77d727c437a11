"""The rig: skeleton, weights and motions as values (rockdove.rig), their UsdSkel form (rockdove.usd.skel) and the
scene posed by UsdSkel at a time code (rockdove.render.skinning), with the bad inputs each must name."""

import numpy as np
import pytest
from conftest import OUTSIDE, copy_asset

from rockdove.rig import motions
from rockdove.rig.skeleton import build_skeleton


@pytest.fixture(scope="module")
def skel():
    return build_skeleton()


@pytest.fixture(scope="module")
def walk(skel):
    return motions.walk(skel)


def test_skeleton_has_named_joints_parents_first(skel):
    names = skel.names
    assert len(names) >= 20 and len(set(names)) == len(names)
    assert sum("neck" in n for n in names) >= 4 and "head" in names
    assert {f"toe_{k}_{s}" for k in ("inner", "middle", "outer", "hind") for s in "LR"} <= set(names)
    assert all(p < j for j, p in enumerate(skel.parents))
    assert "pelvis/spine_01/spine_02/chest/neck_01/neck_02/neck_03/neck_04/neck_05/head" in skel.paths


def test_walk_holds_the_head_in_space_then_thrusts_once_per_step(walk, skel):
    head = walk.world[:, skel.index("head"), :3, 3]
    pelvis_z = walk.world[:, skel.index("pelvis"), 2, 3]
    dz = np.diff(head[:, 2])
    held = dz < 1e-9  # frames whose head did not move forward
    steps = motions.DURATION_S / motions.STEP_S
    runs = np.count_nonzero(held[1:] & ~held[:-1]) + held[0]
    assert runs == steps  # one hold (and one thrust) per step
    assert np.ptp(head[1:][held, 1]) < 1e-5  # locked vertically too (to 10 um)
    assert np.allclose(walk.world[:, skel.index("head"), :3, :3], np.eye(3))  # and in orientation
    assert pelvis_z[-1] - pelvis_z[0] == pytest.approx(motions.STEP_M * steps)  # forward, +Z
    assert abs(held.mean() - motions.HOLD) < 0.1


def test_walk_feet_planted_and_one_always_down(walk, skel):
    down = []
    for side in "LR":
        foot = walk.world[:, skel.index(f"foot_{side}"), :3, 3]
        rest_y = skel.rest_m[skel.index(f"foot_{side}"), 1]
        assert foot[:, 1].min() >= rest_y - 1e-12  # never below its rest height (the ground)
        on = np.abs(foot[:, 1] - rest_y) < 1e-9
        moved = np.linalg.norm(np.diff(foot, axis=0), axis=1)
        assert moved[on[1:] & on[:-1]].max() < 1e-9  # planted while down
        down.append(on)
        ankle = walk.world[:, skel.index(f"ankle_{side}"), :3, 3]
        tarsus = np.linalg.norm(skel.rest_m[skel.index(f"ankle_{side}")] - skel.rest_m[skel.index(f"foot_{side}")])
        assert np.allclose(np.linalg.norm(foot - ankle, axis=1), tarsus)  # the legs reach: no bone stretched
    assert (down[0] | down[1]).all()


def test_motions_loop(walk, skel):
    for m in (walk, motions.idle(skel)):
        local = m.local(skel)
        d = np.abs(local[-1] - local[0])
        d[skel.index("pelvis"), 2, 3] = 0.0  # the walk's travel (root motion)
        assert d.max() < 1e-9, m.name


def test_asset_has_rig_variants_and_time_range(small_asset):
    from pxr import Usd, UsdSkel

    stage = Usd.Stage.Open(str(small_asset / "pigeon.usda"))
    vset = stage.GetDefaultPrim().GetVariantSet("motion")
    assert vset.GetVariantNames() == ["idle", "rest", "walk"] and vset.GetVariantSelection() == "rest"
    assert stage.GetTimeCodesPerSecond() == motions.FPS and stage.GetEndTimeCode() == motions.FPS * 2
    assert stage.GetPrimAtPath("/Pigeon/Geom").IsA(UsdSkel.Root)
    for prim in stage.GetPrimAtPath("/Pigeon/Geom").GetChildren():
        if prim.GetTypeName() == "Mesh":
            assert UsdSkel.BindingAPI(prim).GetSkeleton(), prim.GetPath()


def _edges(part):
    t = part.triangles
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    return np.linalg.norm(part.positions_m[e[:, 0]] - part.positions_m[e[:, 1]], axis=1)


def test_skinned_by_usdskel_cards_rigid_rest_as_authored(small_asset):
    from rockdove.render.scene import load_scene
    from rockdove.rig.weights import components
    from rockdove.verify.motion import LIMITS

    rest = load_scene(small_asset)
    assert rest.time is None and rest.variants["motion"] == "rest"
    posed = load_scene(small_asset, {"motion": "walk"}, 21)
    assert posed.time == 21
    for a, b in zip(rest.parts, posed.parts):
        moved = np.abs(a.positions_m - b.positions_m).max()
        assert moved > 0.01, a.name  # every part follows the walk (>1 cm)
        if a.name not in ("Body", "Legs"):  # rigid parts under linear blend skinning: within the 1 % limit
            assert np.abs(_edges(b) / _edges(a) - 1).max() < LIMITS["card_stretch"], a.name
    # a neck card's weights are one set (read back from the asset)
    from pxr import Usd, UsdSkel

    from rockdove.geometry.types import MeshPart

    stage = Usd.Stage.Open(str(small_asset / "pigeon.usda"))
    binding = UsdSkel.BindingAPI(stage.GetPrimAtPath("/Pigeon/Geom/NeckFeathers"))
    idx = np.asarray(binding.GetJointIndicesPrimvar().Get()).reshape(-1, 4)
    mesh = stage.GetPrimAtPath("/Pigeon/Geom/NeckFeathers")
    part = MeshPart("NeckFeathers", np.asarray(mesh.GetAttribute("points").Get()),
                    np.asarray(mesh.GetAttribute("faceVertexCounts").Get()),
                    np.asarray(mesh.GetAttribute("faceVertexIndices").Get()), None, None, "feather", (0, 0, 0))
    comp = components(part)
    for c in np.unique(comp)[:50]:
        assert len(np.unique(idx[comp == c], axis=0)) == 1


def test_bad_motion_time_and_skins_are_named(small_asset, tmp_path):
    from pxr import Sdf

    from rockdove.render.scene import load_scene
    from rockdove.usd.skel import RIG_LAYER
    from rockdove.usd.validate import validate_asset
    from rockdove.web.gltf import export_glb

    with pytest.raises(ValueError, match="'motion' must be one of"):
        load_scene(small_asset, {"motion": "fly"})
    with pytest.raises(ValueError, match="time=999 lies outside the animation: time codes 0 to 120"):
        load_scene(small_asset, {"motion": "walk"}, 999)
    for name, edit, message in (("indices", lambda v: [99] + list(v)[1:], "jointIndices outside"),
                                ("weights", lambda v: [0.5] + list(v)[1:], "do not sum to 1")):
        asset = copy_asset(small_asset, tmp_path / name)
        layer = Sdf.Layer.FindOrOpen(str(asset / RIG_LAYER))
        attr = layer.GetAttributeAtPath(f"/Pigeon/Geom/Beak.primvars:skel:joint{name.capitalize()}")
        attr.default = edit(attr.default)
        layer.Save()
        with pytest.raises(ValueError, match=f"/Pigeon/Geom/Beak: .*{message}") as err:
            load_scene(asset, {"motion": "walk"}, 3)
        assert "\n" not in str(err.value)
        with pytest.raises(ValueError, match=f"/Pigeon/Geom/Beak: .*{message}"):  # nor a glb with that skin
            export_glb(str(asset / "pigeon.usda"), str(tmp_path / f"{name}.glb"))
        (asset / "pigeon.usdz").unlink()
        issues = [i for i in validate_asset(str(asset)).issues if i.check == "skin"]
        assert issues and message in issues[0].message


def test_verify_checks_the_walk_measures_and_its_frames(small_asset, tmp_path):
    """``rockdove verify --motion walk``: the motion's measures at every time code and the film of each checked
    frame, GL against the reference of that frame (views named by motion and time code)."""
    from rockdove import api
    from rockdove.verify.motion import LIMITS

    result = api.verify(small_asset, ["glsl"], out=tmp_path / "v", width=48, height=48, motion="walk", times=[21],
                        beauty={"renderer": "off"})
    motion = result.report.motion
    assert motion.frames == 121 and motion.times == (21.0,)
    m = motion.measures
    assert m["card_stretch"] < LIMITS["card_stretch"] and m["frames_without_support"] == 0
    assert m["head_cycles"] == m["steps"] == 10 and abs(m["head_to_body_speed"] - 1) < 0.01
    assert m["stance_slip_m"] < 1e-5 and m["head_hold_drift_m"] < 1e-4
    views = {v.view: v for v in result.report.views}
    assert {"walk021_sweep_090", "walk021_turntable_030"} <= set(views) and views["walk021_sweep_090"].n_pixels
    assert all(views[n].passed for n in motion.views)
    a = motion.animation  # one stride of the walk as an animated WebP, shown in the report
    assert a["frames"] == 12 and (tmp_path / "v" / a["file"]).is_file()
    assert f"<img src='{a['file']}'" in (tmp_path / "v" / "report.html").read_text()


def test_the_motion_measures_find_the_feathers_where_usd_built_its_schemas_first(small_asset):
    """A Python that built USD's schema registry before rockdove registered its plugin (a DCC's, or a script that
    opened a stage first) does not know ``RockDoveThinFilmAPI`` as a schema: the measures still find the feather
    mesh by its authored ``apiSchemas`` (they used to stop with StopIteration there)."""
    import subprocess
    import sys

    code = ("import sys; from pxr import Usd; assert Usd.SchemaRegistry().FindAppliedAPIPrimDefinition("
            "'RockDoveThinFilmAPI') is None; from rockdove.verify.motion import measure_motion; "
            "print(measure_motion(sys.argv[1], 'idle').frames)")
    run = subprocess.run([sys.executable, "-c", code, str(small_asset)], capture_output=True, text=True, cwd=OUTSIDE)
    assert run.returncode == 0 and run.stdout.split() == ["121"], run.stderr[-2000:]


def test_verify_and_render_name_a_bad_motion_or_time(small_asset, tmp_path):
    from rockdove.errors import UsageError
    from rockdove.verify.motion import motion_times

    with pytest.raises(UsageError, match="motion='fly' is not a motion of .*'idle', 'walk'"):
        motion_times(str(small_asset / "pigeon.usda"), "fly")
    with pytest.raises(UsageError, match=r"times=\[500.0\] must lie within the animation's time codes 0 to 120"):
        motion_times(str(small_asset / "pigeon.usda"), "walk", [500])
    with pytest.raises(UsageError, match=r"names a time code twice"):  # its frame's images would overwrite
        motion_times(str(small_asset / "pigeon.usda"), "walk", [21, 21.0])
    from rockdove.verify.motion import frame_prefix

    names = [frame_prefix("walk", t) for t in (15.5, 16, 21, 0.25)]
    assert names == ["walk15_5", "walk016", "walk021", "walk0_25"] and len(set(names)) == 4
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-m", "rockdove.cli", "render", str(small_asset), "--out",
                          str(tmp_path / "r"), "--motion", "walk", "--time", "-3"], capture_output=True, text=True)
    assert out.returncode == 2 and "time=-3.0 lies outside the animation" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and not (tmp_path / "r").exists()
    out = subprocess.run([sys.executable, "-m", "rockdove.cli", "verify", str(small_asset), "--time", "3"],
                         capture_output=True, text=True)
    assert out.returncode == 2 and "--time 3 needs --motion" in out.stderr

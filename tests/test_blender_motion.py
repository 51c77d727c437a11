"""Blender's USD import of ``pigeon_walk.usda`` (the layer that selects the walk, as a shot would): an armature whose
action spans the motion's frames, posed as UsdSkel poses the asset, on every bpy wheel ``make test`` installs
(5.0.1, 4.4, 4.2 LTS), with the add-on installed as the README says: the neck's thin film still binds (where the
wheel can run the add-on's USD hook) and the scene plays at the asset's rate."""

import json

import numpy as np
import pytest
from test_blender_addon import ALL, WHEELS, _run

from rockdove.hosts import blender as host

FRAMES = (0, 30)  # the walk's first frame and half a second (2.5 steps) on
#: Body points compared (every 7th: the armature modifier's result against UsdSkel's).
STRIDE = 7

IMPORT_WALK = r"""
import json, sys
import bpy
zip_path, asset, frames = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
bpy.ops.preferences.addon_install(filepath=zip_path)
bpy.ops.preferences.addon_enable(module="rockdove_blender")
print("IMPORT", bpy.ops.wm.usd_import(filepath=asset))
scene = bpy.context.scene
arm = next(ob for ob in bpy.data.objects if ob.type == "ARMATURE")
body = bpy.data.objects["Body"]
to_usd = bpy.data.objects["Pigeon"].matrix_world.inverted()  # the importer's Y-up to Z-up turn, undone
act = arm.animation_data.action if arm.animation_data else None
neck = bpy.data.objects["NeckFeathers"].material_slots[0].material
out = {"blender": bpy.app.version_string, "bones": len(arm.data.bones), "action": act and act.name,
       "action_range": list(act.frame_range) if act else None, "scene_range": [scene.frame_start, scene.frame_end],
       "fps": scene.render.fps / scene.render.fps_base, "film": bool(neck.get("rockdove:thinFilm")),
       "modifiers": sorted({m.type for ob in bpy.data.objects if ob.type == "MESH" for m in ob.modifiers}), "at": {}}
for f in frames:
    scene.frame_set(f)
    mesh = body.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    head = (to_usd @ arm.matrix_world @ arm.pose.bones["head"].matrix).translation
    out["at"][str(f)] = {"head": list(head), "body": [list(to_usd @ body.matrix_world @ mesh.vertices[i].co)
                                                      for i in range(0, len(mesh.vertices), int(sys.argv[4]))]}
print("RESULT " + json.dumps(out))
"""


def _usdskel(layer, frames):
    """UsdSkel's own pose of ``layer`` at ``frames``: {frame: (head joint position, Body points)}, metres."""
    from pxr import Usd, UsdGeom, UsdSkel

    from rockdove.render.skinning import pose

    stage = Usd.Stage.Open(str(layer), Usd.Stage.LoadAll)
    query = UsdSkel.Cache().GetSkelQuery(UsdSkel.Skeleton(stage.GetPrimAtPath("/Pigeon/Geom/Skeleton")))
    head = [str(j).endswith("/head") for j in query.GetJointOrder()].index(True)
    return {f: (np.asarray(query.ComputeJointWorldTransforms(UsdGeom.XformCache(f)))[head, 3, :3],
                posed["/Pigeon/Geom/Body"][0]) for f, posed in zip(frames, pose(stage, frames))}


@pytest.fixture(scope="module")
def walk_layer(small_asset):
    return small_asset / "pigeon_walk.usda"


@pytest.mark.slow
@pytest.mark.parametrize("version", ALL)
def test_blender_imports_the_walk_as_an_armature_posed_as_usdskel_poses_it(version, walk_layer, tmp_path):
    got, lines = _run(WHEELS[version], IMPORT_WALK, tmp_path, host.addon_zip(tmp_path), walk_layer,
                      json.dumps(FRAMES), STRIDE)
    assert got["blender"].startswith(version or "5.0.1")
    assert got["bones"] == 34 and got["action"] and got["modifiers"] == ["ARMATURE"]
    assert got["action_range"] == [0.0, 120.0] and got["scene_range"] == [0, 120]  # the walk's 2 s
    want = _usdskel(walk_layer, FRAMES)
    for f in FRAMES:
        head, body = np.asarray(got["at"][str(f)]["head"]), np.asarray(got["at"][str(f)]["body"])
        assert np.abs(head - want[f][0]).max() < 1e-4, (f, head, want[f][0])
        assert body.shape == want[f][1][::STRIDE].shape and np.abs(body - want[f][1][::STRIDE]).max() < 1e-4
    travel = np.asarray(got["at"][str(FRAMES[1])]["head"]) - np.asarray(got["at"][str(FRAMES[0])]["head"])
    assert travel[2] > 0.05  # the head walked on along +Z
    if version == "4.2":  # the wheel has no pxr: no hook runs (test_blender_addon), so neither film nor rate
        assert not got["film"] and got["fps"] == 24 and "ships no pxr" in lines[0]
    else:
        assert got["film"] and got["fps"] == 60
        assert lines == ["rockdove: thin-film material on /Pigeon/Geom/NeckFeathers",
                         "rockdove: frame rate 60 fps, the asset's timeCodesPerSecond"]

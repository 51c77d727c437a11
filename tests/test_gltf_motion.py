"""pigeon.glb's rig (rockdove.web.gltf_skin): a skin and the idle and walk animations, valid by the Khronos
glTF-Validator, that pose the vertices as UsdSkel poses the written asset; and the viewer plays them
(three.js's AnimationMixer in headless Chromium), resting by default."""

from __future__ import annotations

import numpy as np
import pytest


def _read(gltf, index):
    """An accessor's values, (count, components) float64 (or its integers)."""
    acc = gltf.accessors[index]
    bv = gltf.bufferViews[acc.bufferView]
    dtype = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}[acc.componentType]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc.type]
    blob = gltf.binary_blob()
    return np.frombuffer(blob[bv.byteOffset + (acc.byteOffset or 0):][:acc.count * width * np.dtype(dtype).itemsize],
                         dtype).reshape(acc.count, width)


def _quat_matrix(q):
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def glb_pose(gltf, animation: str | None, key: int) -> dict:
    """{mesh name: (V, 3) positions} of the glb's skinned meshes, posed as a glTF viewer poses them: the animation's
    ``key``-th keyframe (None: the nodes' rest TRS), joint world matrices down the node tree, linear blend skinning
    with the inverse bind matrices."""
    trs = {i: [np.asarray(n.translation or [0, 0, 0], float), np.asarray(n.rotation or [0, 0, 0, 1], float),
               np.asarray(n.scale or [1, 1, 1], float)] for i, n in enumerate(gltf.nodes)}
    if animation is not None:
        anim = next(a for a in gltf.animations if a.name == animation)
        for ch in anim.channels:
            value = _read(gltf, anim.samplers[ch.sampler].output)[key]
            trs[ch.target.node][("translation", "rotation", "scale").index(ch.target.path)] = value.astype(float)
    local = {}
    for i, (t, r, s) in trs.items():
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = _quat_matrix(r) * s, t
        if gltf.nodes[i].matrix:
            m = np.asarray(gltf.nodes[i].matrix, float).reshape(4, 4).T
        local[i] = m
    world, stack = {}, [(i, np.eye(4)) for i in gltf.scenes[0].nodes]
    while stack:
        i, parent = stack.pop()
        world[i] = parent @ local[i]
        stack += [(c, world[i]) for c in gltf.nodes[i].children or []]
    skin = gltf.skins[0]
    ibm = _read(gltf, skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
    joint_m = np.stack([world[j] for j in skin.joints]) @ ibm
    out = {}
    for node in gltf.nodes:
        if node.skin is None:
            continue
        attributes = gltf.meshes[node.mesh].primitives[0].attributes
        p = _read(gltf, attributes.POSITION).astype(float)
        j, w = _read(gltf, attributes.JOINTS_0).astype(int), _read(gltf, attributes.WEIGHTS_0).astype(float)
        m = np.einsum("vk,vkab->vab", w, joint_m[j])
        out[gltf.meshes[node.mesh].name] = np.einsum("vab,vb->va", m, np.c_[p, np.ones(len(p))])[:, :3]
    return out


@pytest.fixture(scope="module")
def glb(small_asset):
    import pygltflib

    return pygltflib.GLTF2().load(str(small_asset / "pigeon.glb"))


def test_the_glb_carries_a_skin_and_both_motions_and_validates(small_asset, glb):
    from rockdove.web.gltf import validate_glb

    report = validate_glb(small_asset / "pigeon.glb")
    assert (report.errors, report.warnings) == (0, 0), report.messages[:5]
    assert [a.name for a in glb.animations] == ["idle", "walk"] and len(glb.skins) == 1
    skin = glb.skins[0]
    names = [glb.nodes[j].name for j in skin.joints]
    assert len(names) == 34 and {"pelvis", "head", "neck_05", "toe_hind_R"} <= set(names)
    walk = glb.animations[1]
    times = _read(glb, walk.samplers[0].input)[:, 0]
    assert times[0] == 0 and times[-1] == pytest.approx(2.0) and len(times) == 121  # 60 fps, 2 s
    # every mesh node is skinned and a root node (glTF ignores a skinned node's parents)
    skinned = [i for i, n in enumerate(glb.nodes) if n.mesh is not None]
    assert skinned and all(glb.nodes[i].skin == 0 for i in skinned) and set(skinned) <= set(glb.scenes[0].nodes)


@pytest.mark.parametrize("motion, frame", [(None, 0), ("walk", 0), ("walk", 21), ("idle", 47)])
def test_the_glb_poses_every_vertex_as_usdskel_poses_the_asset(small_asset, glb, motion, frame):
    """The exported rig (joint TRS keys, inverse binds, weights) skinned as glTF prescribes against UsdSkel's own
    skinning of the written USD at the same time code (rockdove.render.skinning): within 0.05 mm."""
    from rockdove.render.scene import load_scene

    scene = load_scene(small_asset, None if motion is None else {"motion": motion}, None if motion is None else frame)
    posed = glb_pose(glb, motion, frame)
    assert set(posed) == {p.name for p in scene.parts}
    worst = max(np.abs(posed[p.name] - p.positions_m).max() for p in scene.parts)
    assert worst < 5e-5, worst
    if motion == "walk" and frame:
        rest = load_scene(small_asset)
        assert np.abs(rest.part("Body").positions_m - posed["Body"]).max() > 0.02  # it did move


def _silhouette_x(rgb) -> float:
    """Mean column of the pixels that are not background (0)."""
    cols = np.nonzero(np.abs(rgb).sum(axis=2) > 0)[1]
    return float(cols.mean())


def test_the_viewer_rests_by_default_and_plays_pauses_and_switches_the_motion(small_asset, tmp_path):
    """In headless Chromium: the page opens at rest; three.js's AnimationMixer poses the vertices as UsdSkel does
    (0.1 mm); our LUT shader and three.js's own material draw the skinned mesh (the bird's silhouette moves across a
    fixed side camera by the pelvis's projected travel); the motion switch starts the clock, pause stops it."""
    import base64
    import json
    import time

    from rockdove.render.scene import load_scene
    from rockdove.render.views import View, look_at
    from rockdove.web.browser import Browser
    from rockdove.web.viewer import write_viewer

    page_path = write_viewer(small_asset, small_asset / "pigeon.glb", tmp_path / "verify")
    view = View("side", look_at((0.9, 0.1, 0.1), (0.0, 0.1, 0.1)), np.radians(30.0), 160, 120, (1, 1, 1), (1, 1, 1))
    spec = json.dumps({"camera_to_world": view.camera_to_world.reshape(-1).tolist(), "yfov_rad": view.yfov_rad,
                       "width": 160, "height": 120, "light_direction": [0.6, 0.6, 0.5], "light_rgb": [1, 1, 1]})
    walk_s, walk_frame = 0.35, 21  # time code 21 of 60 per second

    def shot(page, mode):
        res = page.evaluate(f"window.rockdoveRender({spec}, '{mode}')", timeout_s=120)
        return np.frombuffer(base64.b64decode(res["rgb_f32"]), np.float32).reshape(120, 160, 3)

    with Browser() as browser:
        page = browser.open(f"file://{page_path}", 480, 400, timeout_s=120)
        page.evaluate("window.rockdoveReady", timeout_s=120, step="viewer ready")
        default = page.evaluate("[document.getElementById('motion').value, document.getElementById('play').disabled]")
        opened = {m: shot(page, m) for m in ("lut", "physical")}
        rest = page.evaluate("window.rockdoveMotion('rest', 0)")
        walked = page.evaluate(f"window.rockdoveMotion('walk', {walk_s})")
        moved = {m: shot(page, m) for m in ("lut", "physical")}
        page.evaluate("const s = document.getElementById('motion'); s.value = 'idle'; "
                      "s.dispatchEvent(new Event('change'))")  # what a user's choice does: it plays
        time.sleep(1.0)
        t_play = float(page.evaluate("document.getElementById('motion-time').textContent").split()[0])
        page.evaluate("document.getElementById('play').click()")  # pause
        t_paused = float(page.evaluate("document.getElementById('motion-time').textContent").split()[0])
        time.sleep(0.5)
        t_still = float(page.evaluate("document.getElementById('motion-time').textContent").split()[0])
        errors = page.errors
    assert errors == [] and default == ["rest", True]
    assert t_play > 0.1 and t_still == t_paused  # the switch started the clock; pause stopped it
    rest_scene = load_scene(small_asset)
    assert rest["vertices"].keys() == {p.name for p in rest_scene.parts}
    for name, v in rest["vertices"].items():  # at rest the page draws the rest pose, as before the rig
        np.testing.assert_allclose(v, rest_scene.part(name).positions_m[0], atol=1e-6)
    posed = load_scene(small_asset, {"motion": "walk"}, walk_frame)
    for name, v in walked["vertices"].items():  # three.js's skinning = UsdSkel's
        np.testing.assert_allclose(v, posed.part(name).positions_m[0], atol=1e-4)
    # the pelvis's travel, projected: the camera looks along -X, its image x axis is -Z
    focal_px = 60.0 / np.tan(view.yfov_rad / 2)
    travel_m = posed.part("Body").positions_m[:, 2].mean() - rest_scene.part("Body").positions_m[:, 2].mean()
    expected_px = -travel_m * focal_px / 0.9
    assert abs(expected_px) > 10
    for mode in ("lut", "physical"):
        shift = _silhouette_x(moved[mode]) - _silhouette_x(opened[mode])
        print(f"{mode}: silhouette moved {shift:.1f} px, the pelvis's travel {expected_px:.1f} px")
        assert abs(shift - expected_px) < 0.15 * abs(expected_px), (mode, shift, expected_px)

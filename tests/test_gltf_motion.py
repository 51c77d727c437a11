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

    issues = validate_glb(small_asset / "pigeon.glb")["issues"]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), issues["messages"][:5]
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

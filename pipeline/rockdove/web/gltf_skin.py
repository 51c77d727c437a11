"""The rig of ``pigeon.glb``: a glTF skin and one animation per motion, read from the written USD by UsdSkel (never
the generator's values). glTF's skinning is linear blend, UsdSkel's default, so every glTF viewer poses the vertices
as UsdSkel does. Skinned mesh nodes are root nodes (glTF ignores their parents' transforms); the joints hang under a
``Skeleton`` node, so each inverse bind matrix is ``inverse(skeleton to world x bind)``."""

from __future__ import annotations

import numpy as np

from ..errors import UsageError
from ..usd.skel import MOTION_VARIANT_SET as MOTION_SET
from ..usd.skel import REST, target_influences


def _col(m) -> np.ndarray:
    """USD's row-vector matrices (N, 4, 4) or (4, 4) -> column-vector float64."""
    return np.swapaxes(np.asarray(m, np.float64), -1, -2)


def _skeleton(stage):
    """(SkeletonQuery, UsdSkel.Binding) of the stage's one skeleton that binds meshes, or None."""
    from pxr import Usd, UsdSkel

    cache = UsdSkel.Cache()
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if prim.IsA(UsdSkel.Root):
            root = UsdSkel.Root(prim)
            cache.Populate(root, Usd.PrimDefaultPredicate)
            bindings = cache.ComputeSkelBindings(root, Usd.PrimDefaultPredicate)
            if len(bindings) > 1:
                raise UsageError(f"{prim.GetPath()}: {len(bindings)} skeletons bind meshes; glTF export takes one")
            if bindings:
                return cache.GetSkelQuery(bindings[0].GetSkeleton()), bindings[0]
    return None


def _trs(xf) -> tuple:
    """(translations (J, 3), rotations (J, 4) x y z w, scales (J, 3)) float32 of UsdSkel local transforms."""
    from pxr import UsdSkel

    t, r, s = UsdSkel.DecomposeTransforms(xf)
    quats = np.array([[*q.GetImaginary(), q.GetReal()] for q in r], np.float64)
    return np.asarray(t, np.float32), quats.astype(np.float32), np.asarray(s, np.float32)


def motions(stage, query) -> dict:
    """``{motion: (times s (F,), translations, rotations x y z w, scales (F, J, ...))}`` of each animated motion."""
    from pxr import Usd, UsdSkel

    prim = stage.GetDefaultPrim()
    if not prim or not prim.GetVariantSets().HasVariantSet(MOTION_SET):
        return {}
    vset = prim.GetVariantSet(MOTION_SET)
    out = {}
    start, rate = stage.GetStartTimeCode(), stage.GetTimeCodesPerSecond()
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        try:
            for name in vset.GetVariantNames():
                if name == REST:
                    continue
                vset.SetVariantSelection(name)
                cache = UsdSkel.Cache()
                cache.Populate(UsdSkel.Root.Find(query.GetSkeleton().GetPrim()), Usd.PrimDefaultPredicate)
                skel_query = cache.GetSkelQuery(query.GetSkeleton())
                times = skel_query.GetAnimQuery().GetJointTransformTimeSamples() if skel_query.GetAnimQuery() else []
                if len(times) < 2:
                    continue
                keys = [_trs(skel_query.ComputeJointLocalTransforms(t)) for t in times]
                rot = np.stack([k[1] for k in keys])
                flip = np.cumprod(np.where(np.sum(rot[1:] * rot[:-1], axis=2) < 0, -1.0, 1.0), axis=0)
                rot[1:] *= flip[..., None]  # one hemisphere from key to key: every host interpolates the short way
                out[name] = ((np.asarray(times, np.float64) - start) / rate,
                             np.stack([k[0] for k in keys]), rot, np.stack([k[2] for k in keys]))
        finally:
            vset.ClearVariantSelection()  # the session layer's: the stage selects as before
    return out


def _point_map(positions_m, points_world, fvi) -> np.ndarray:
    """Which USD point each exported vertex is (itself, or its corner's: face-varying primvars split vertices)."""
    for index in (np.arange(len(points_world)), np.asarray(fvi, np.int64)):
        if len(index) == len(positions_m) and np.abs(points_world[index] - positions_m).max(initial=0) < 1e-5:
            return index
    raise UsageError("the exported vertices are not the mesh's rest points: glTF skins the rest pose")


def add_skin(gltf, blob, scene, stage) -> None:
    """Skin the mesh nodes (node i: scene part i), add the joints and the motions; UsageError for a posed scene."""
    from pxr import UsdGeom
    from pygltflib import Animation, AnimationChannel, AnimationChannelTarget, AnimationSampler, Node, Skin

    if (found := _skeleton(stage)) is None:
        return
    query, binding = found
    if scene.time is not None:
        raise UsageError(f"{scene.root_layer}: the scene is posed at time code {scene.time:g}; glTF skins the rest "
                         "pose (select motion = rest)")
    topology = query.GetTopology()
    parents = np.asarray(topology.GetParentIndices())
    skel_world = _col(UsdGeom.XformCache().GetLocalToWorldTransform(query.GetSkeleton().GetPrim()))
    bind_world = skel_world @ _col(query.GetJointWorldBindTransforms())
    inverse_binds = np.linalg.inv(bind_world)
    t0, r0, s0 = _trs(query.ComputeJointLocalTransforms(0.0, atRest=True))
    first = len(gltf.nodes)
    names = [str(p).rsplit("/", 1)[-1] for p in query.GetJointOrder()]
    for j, name in enumerate(names):
        node = Node(name=name, translation=[float(v) for v in t0[j]], rotation=[float(v) for v in r0[j]],
                    children=[first + int(c) for c in np.flatnonzero(parents == j)])
        if not np.allclose(s0[j], 1.0):
            node.scale = [float(v) for v in s0[j]]
        gltf.nodes.append(node)
    holder = Node(name=query.GetSkeleton().GetPrim().GetName(), children=[first + int(j) for j in
                                                                          np.flatnonzero(parents < 0)])
    if not np.allclose(skel_world, np.eye(4)):
        holder.matrix = [float(v) for v in skel_world.T.reshape(-1)]  # glTF: column-major
    gltf.nodes.append(holder)
    ibm = blob.accessor(np.ascontiguousarray(np.swapaxes(inverse_binds, 1, 2).reshape(-1, 16), np.float32), "MAT4",
                        target=None)
    gltf.skins.append(Skin(name=holder.name, inverseBindMatrices=ibm, skeleton=len(gltf.nodes) - 1,
                           joints=list(range(first, first + len(names)))))
    mesh_nodes = {p.path: i for i, p in enumerate(scene.parts)}
    for target in binding.GetSkinningTargets():
        path = str(target.GetPrim().GetPath())
        if path not in mesh_nodes:
            continue
        mesh = UsdGeom.Mesh(target.GetPrim())
        indices, weights, per = target_influences(target, len(names))  # a bad skin: one line, as posing says
        mapper = target.GetJointMapper()
        if mapper is not None and not mapper.IsNull() and not mapper.IsIdentity():
            raise UsageError(f"{path}: skel:joints reorders the skeleton's joints; glTF export needs its order")
        geom_bind = _col(target.GetGeomBindTransform())
        points = np.asarray(mesh.GetPointsAttr().Get(), np.float64)
        world = (np.c_[points, np.ones(len(points))] @ (skel_world @ geom_bind).T)[:, :3]
        index = _point_map(scene.parts[mesh_nodes[path]].positions_m, world, mesh.GetFaceVertexIndicesAttr().Get())
        if per > 4:
            raise UsageError(f"{path}: {per} influences per point; glTF's JOINTS_0 / WEIGHTS_0 hold 4")
        idx, w = np.asarray(indices).reshape(-1, per)[index], np.asarray(weights, np.float64).reshape(-1, per)[index]
        idx, w = np.pad(idx, ((0, 0), (0, 4 - per))), np.pad(w, ((0, 0), (0, 4 - per)))
        idx = np.where(w > 0, idx, 0)  # an unused slot names joint 0 with weight 0
        w = (w / w.sum(axis=1, keepdims=True)).astype(np.float32)
        primitive = gltf.meshes[gltf.nodes[mesh_nodes[path]].mesh].primitives[0]
        primitive.attributes.JOINTS_0 = blob.accessor(idx.astype(np.uint8 if len(names) < 256 else np.uint16), "VEC4")
        primitive.attributes.WEIGHTS_0 = blob.accessor(w, "VEC4")
        gltf.nodes[mesh_nodes[path]].skin = len(gltf.skins) - 1
    for name, (times, t, r, s) in motions(stage, query).items():
        anim = Animation(name=name, samplers=[], channels=[])
        time_acc = blob.accessor(times.astype(np.float32).reshape(-1, 1), "SCALAR", target=None, with_bounds=True)
        for path, values, kind in (("translation", t, "VEC3"), ("rotation", r, "VEC4"), ("scale", s, "VEC3")):
            for j in range(len(names)):
                if path == "scale" and np.allclose(values[:, j], 1.0) and np.allclose(s0[j], 1.0):
                    continue  # no scale anywhere: no channel
                anim.samplers.append(AnimationSampler(input=time_acc, output=blob.accessor(
                    np.ascontiguousarray(values[:, j]), kind, target=None), interpolation="LINEAR"))
                anim.channels.append(AnimationChannel(sampler=len(anim.samplers) - 1,
                                                      target=AnimationChannelTarget(node=first + j, path=path)))
        gltf.animations.append(anim)

"""Meshes posed at a time code by USD's own UsdSkel: ``UsdSkel.Cache`` -> skeleton query -> skinning transforms ->
``SkinningQuery.ComputeSkinnedPoints``, and the normals by ``UsdSkel.SkinNormals`` with the inverse transposes of the
same transforms (no second implementation of skinning here). Every bound mesh's influences are checked first: joint
indices in range, weights >= 0 summing to 1; any fault is a UsageError naming the mesh, so no scene is ever made
with a mesh left half-skinned."""

from __future__ import annotations

import numpy as np

from ..errors import UsageError

from ..usd.skel import check_influences

def animated(stage) -> bool:
    """Whether any skeleton of ``stage`` has an animation source bound (a ``motion`` other than rest)."""
    from pxr import Usd, UsdSkel

    return any(p.IsA(UsdSkel.Skeleton) and UsdSkel.BindingAPI(p).GetAnimationSourceRel().GetTargets()
               for p in Usd.PrimRange(stage.GetPseudoRoot()))


def pose(stage, time: float) -> dict:
    """``{mesh path: (points (V, 3) float64, normals (V, 3) float64 or None, skeleton local-to-world (4, 4) row
    vectors)}`` of every mesh bound under a SkelRoot of ``stage``, skinned at ``time`` (points in skeleton space)."""
    from pxr import Gf, Usd, UsdGeom, UsdSkel, Vt

    cache, out = UsdSkel.Cache(), {}
    xcache = UsdGeom.XformCache(time)
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if not prim.IsA(UsdSkel.Root):
            continue
        root = UsdSkel.Root(prim)
        cache.Populate(root, Usd.PrimDefaultPredicate)
        for binding in cache.ComputeSkelBindings(root, Usd.PrimDefaultPredicate):
            query = cache.GetSkelQuery(binding.GetSkeleton())
            xforms = query.ComputeSkinningTransforms(time)
            n_joints = len(query.GetJointOrder())
            to_world = np.asarray(xcache.GetLocalToWorldTransform(binding.GetSkeleton().GetPrim()), np.float64)
            for target in binding.GetSkinningTargets():
                path = str(target.GetPrim().GetPath())
                mesh = UsdGeom.Mesh(target.GetPrim())
                points = mesh.GetPointsAttr().Get(time)
                n, per = len(points), target.GetNumInfluencesPerComponent()
                indices, weights = target.ComputeJointInfluences(time)
                if target.GetInterpolation() != UsdGeom.Tokens.vertex:
                    raise UsageError(f"{path}: skel:jointIndices must be vertex-interpolated (one set per point)")
                check_influences(path, indices, weights, n, per, n_joints)
                joint_xf = xforms if target.GetJointMapper() is None else target.GetJointMapper().RemapTransforms(
                    xforms, Gf.Matrix4d(1))
                if not target.ComputeSkinnedPoints(joint_xf, points, time):
                    raise UsageError(f"{path}: UsdSkel could not skin the mesh at time {time}")
                normals = mesh.GetNormalsAttr().Get(time)
                if normals is not None and len(normals) == n:
                    m3 = np.asarray(joint_xf, np.float64)[:, :3, :3]
                    bind = np.asarray(target.GetGeomBindTransform(time), np.float64)[:3, :3]
                    normals = Vt.Vec3fArray(normals)
                    UsdSkel.SkinNormals(target.GetSkinningMethod(), Gf.Matrix3d(*np.linalg.inv(bind).T.ravel()),
                                        Vt.Matrix3dArray.FromNumpy(np.ascontiguousarray(
                                            np.swapaxes(np.linalg.inv(m3), 1, 2))), indices, weights, per, normals)
                    normals = np.asarray(normals, np.float64)
                else:
                    normals = None
                out[path] = (np.asarray(points, np.float64), normals, to_world)
    return out

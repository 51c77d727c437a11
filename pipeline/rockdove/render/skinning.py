"""Meshes posed at a time code by USD's own UsdSkel: ``UsdSkel.Cache`` -> skeleton query -> skinning transforms ->
``SkinningQuery.ComputeSkinnedPoints``, and the normals by ``UsdSkel.SkinNormals`` with the inverse transposes of the
same transforms (no second implementation of skinning here). Every bound mesh's influences are checked first: joint
indices in range, weights >= 0 summing to 1; any fault is a UsageError naming the mesh, so no scene is ever made
with a mesh left half-skinned."""

from __future__ import annotations

import numpy as np

from ..errors import UsageError
from ..usd.skel import target_influences


def animated(stage) -> bool:
    """Whether any skeleton of ``stage`` has an animation source bound (a ``motion`` other than rest)."""
    from pxr import Usd, UsdSkel

    return any(p.IsA(UsdSkel.Skeleton) and UsdSkel.BindingAPI(p).GetAnimationSourceRel().GetTargets()
               for p in Usd.PrimRange(stage.GetPseudoRoot()))


def pose(stage, times, with_normals: bool = True) -> list:
    """Per time code of ``times``: ``{mesh path: (points (V, 3) float64, normals (V, 3) float64 or None, skeleton
    local-to-world (4, 4) row vectors)}`` of every mesh bound under a SkelRoot of ``stage``, skinned at that time
    (points in skeleton space; the skins are checked once)."""
    from pxr import Gf, Usd, UsdGeom, UsdSkel, Vt

    cache, targets = UsdSkel.Cache(), []
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if prim.IsA(UsdSkel.Root):
            cache.Populate(UsdSkel.Root(prim), Usd.PrimDefaultPredicate)
            for binding in cache.ComputeSkelBindings(UsdSkel.Root(prim), Usd.PrimDefaultPredicate):
                query = cache.GetSkelQuery(binding.GetSkeleton())
                for target in binding.GetSkinningTargets():
                    path, mesh = str(target.GetPrim().GetPath()), UsdGeom.Mesh(target.GetPrim())
                    indices, weights, per = target_influences(target, len(query.GetJointOrder()))
                    targets.append((query, target, mesh, path, indices, weights, per))
    out = []
    for time in times:
        xcache, frame = UsdGeom.XformCache(time), {}
        for query, target, mesh, path, indices, weights, per in targets:
            xforms = query.ComputeSkinningTransforms(time)
            mapper = target.GetJointMapper()
            if mapper is not None and not mapper.IsNull() and not mapper.IsIdentity():
                xforms = mapper.RemapTransforms(xforms, Gf.Matrix4d(1))
            points = mesh.GetPointsAttr().Get(time)
            if not target.ComputeSkinnedPoints(xforms, points, time):
                raise UsageError(f"{path}: UsdSkel could not skin the mesh at time {time}")
            normals = mesh.GetNormalsAttr().Get(time) if with_normals else None
            if normals is not None and len(normals) == len(points):
                m3 = np.linalg.inv(np.asarray(xforms, np.float64)[:, :3, :3])
                bind = np.linalg.inv(np.asarray(target.GetGeomBindTransform(time), np.float64)[:3, :3])
                normals = Vt.Vec3fArray(normals)
                UsdSkel.SkinNormals(target.GetSkinningMethod(), Gf.Matrix3d(*bind.T.ravel()),
                                    Vt.Matrix3dArray.FromNumpy(np.ascontiguousarray(np.swapaxes(m3, 1, 2))),
                                    indices, weights, per, normals)
            to_world = np.asarray(xcache.GetLocalToWorldTransform(query.GetPrim()), np.float64)
            frame[path] = (np.asarray(points, np.float64),
                           np.asarray(normals, np.float64) if normals is not None and len(normals) == len(points)
                           else None, to_world)
        out.append(frame)
    return out

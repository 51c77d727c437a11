"""The rig as UsdSkel (:mod:`rockdove.rig` values, docs/rig.md): ``pigeon_rig.usdc`` (the ``Skeleton``, one
``SkelAnimation`` per motion, the meshes' skins: linear blend, the only method of glTF, three.js and Blender's
armature import), and the interface layer's ``motion`` variant set (``rest`` default) with the time metadata."""

from __future__ import annotations

import numpy as np

from ..errors import UsageError
from ..geometry.types import drop_unreferenced_points
from ..rig.motions import DURATION_S, FPS
from ..rig.motions import MOTIONS as MAKERS
from ..rig.skeleton import build_skeleton
from ..rig.weights import INFLUENCES, part_weights
from .issues import Issue

RIG_LAYER = "pigeon_rig.usdc"
MOTION_VARIANT_SET = "motion"
REST = "rest"
#: The ``motion`` variants, the default first.
MOTIONS = (REST, "idle", "walk")
SKELETON = "/Pigeon/Geom/Skeleton"
#: Largest |sum of a point's weights - 1| accepted (float32 weights of 4 influences).
WEIGHT_SUM_TOLERANCE = 1e-3


def check_influences(path: str, indices, weights, n_points: int, n_per_point: int, n_joints: int) -> None:
    """UsageError (one line, naming the mesh) unless ``indices``/``weights`` are a valid skin: indices in
    [0, n_joints), weights >= 0, each point's summing to 1 (within :data:`WEIGHT_SUM_TOLERANCE`)."""
    idx, w = np.asarray(indices, np.int64), np.asarray(weights, np.float64)
    if len(idx) != n_points * n_per_point or len(w) != len(idx):
        raise UsageError(f"{path}: {len(idx)} skel:jointIndices and {len(w)} skel:jointWeights for {n_points} "
                         f"points x {n_per_point} influences")
    bad = np.flatnonzero((idx < 0) | (idx >= n_joints))
    if len(bad):
        raise UsageError(f"{path}: {len(bad)} skel:jointIndices outside [0, {n_joints}) (the skeleton's joints), "
                         f"e.g. {idx[bad[0]]} at point {bad[0] // n_per_point}")
    sums = w.reshape(n_points, n_per_point).sum(axis=1)
    off = np.flatnonzero((np.abs(sums - 1.0) > WEIGHT_SUM_TOLERANCE) | (w.reshape(n_points, -1) < 0).any(axis=1))
    if len(off):
        raise UsageError(f"{path}: skel:jointWeights of {len(off)} points are negative or do not sum to 1, e.g. "
                         f"{sums[off[0]]:.4f} at point {off[0]}")


def target_influences(target, n_joints: int) -> tuple:
    """``(indices, weights, influences per point)`` of a ``UsdSkel.SkinningQuery``, checked: UsageError (one line,
    naming the mesh) unless vertex-interpolated and :func:`check_influences` holds."""
    from pxr import UsdGeom

    path, per = str(target.GetPrim().GetPath()), target.GetNumInfluencesPerComponent()
    if target.GetInterpolation() != UsdGeom.Tokens.vertex:
        raise UsageError(f"{path}: skel:jointIndices must be vertex-interpolated (one set per point)")
    indices, weights = target.ComputeJointInfluences()
    n = len(UsdGeom.Mesh(target.GetPrim()).GetPointsAttr().Get() or [])
    check_influences(path, indices, weights, n, per, n_joints)
    return indices, weights, per


def check_skins(stage) -> list:
    """The :class:`rockdove.usd.issues.Issue` of every mesh whose skin :func:`check_influences` rejects."""
    from pxr import Usd, UsdGeom, UsdSkel

    issues = []
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        binding = UsdSkel.BindingAPI(prim)
        if not (prim.IsA(UsdGeom.Mesh) and prim.HasAPI(UsdSkel.BindingAPI)) or not binding.GetSkeleton():
            continue
        idx, w = binding.GetJointIndicesPrimvar(), binding.GetJointWeightsPrimvar()
        try:
            check_influences(str(prim.GetPath()), idx.Get() or [], w.Get() or [],
                             len(UsdGeom.Mesh(prim).GetPointsAttr().Get() or []), idx.GetElementSize(),
                             len(binding.GetSkeleton().GetJointsAttr().Get() or []))
        except ValueError as exc:
            issues.append(Issue("skin", str(prim.GetPath()), str(exc)))
    return issues


def _matrices(m):
    """(N, 4, 4) column-vector transforms -> Vt.Matrix4dArray (USD's row vectors: transposed)."""
    from pxr import Vt

    return Vt.Matrix4dArray.FromNumpy(np.ascontiguousarray(np.swapaxes(np.asarray(m, np.float64), -1, -2)))


def animation_path(motion: str) -> str:
    return f"{SKELETON}/{motion.capitalize()}"


def author_rig(stage, bird) -> None:
    """The rig layer's content in ``stage``'s edit target, for ``bird``'s meshes as :mod:`.stage` writes them."""
    from pxr import Sdf, UsdSkel, Vt

    skel = build_skeleton()
    parts = [drop_unreferenced_points(p) for p in bird.parts]
    for path in ("/Pigeon", "/Pigeon/Geom"):
        stage.OverridePrim(path)
    skeleton = UsdSkel.Skeleton.Define(stage, SKELETON)
    skeleton.CreateJointsAttr(Vt.TokenArray(skel.paths))
    rest = np.tile(np.eye(4), (len(skel.names), 1, 1))
    rest[:, :3, 3] = skel.rest_m
    skeleton.CreateBindTransformsAttr(_matrices(rest))
    local = rest.copy()
    local[skel.parents >= 0, :3, 3] -= skel.rest_m[skel.parents[skel.parents >= 0]]
    skeleton.CreateRestTransformsAttr(_matrices(local))
    UsdSkel.BindingAPI.Apply(skeleton.GetPrim())  # its skel:animationSource is the motion variants'
    for name, make in MAKERS.items():
        motion = make(skel)
        anim = UsdSkel.Animation.Define(stage, animation_path(name))
        anim.CreateJointsAttr(Vt.TokenArray(skel.paths))
        for f, xf in enumerate(motion.local(skel)):
            anim.SetTransforms(_matrices(xf), float(f))
    weights = part_weights(parts, skel)
    for part in parts:
        idx, w = weights[part.name]
        binding = UsdSkel.BindingAPI.Apply(stage.OverridePrim(f"/Pigeon/Geom/{part.name}"))
        binding.CreateSkeletonRel().SetTargets([Sdf.Path(SKELETON)])
        binding.CreateJointIndicesPrimvar(False, INFLUENCES).Set(Vt.IntArray.FromNumpy(idx.reshape(-1)))
        binding.CreateJointWeightsPrimvar(False, INFLUENCES).Set(Vt.FloatArray.FromNumpy(w.reshape(-1)))


def author_motion_variants(stage, prim) -> None:
    """The ``motion`` variant set on ``prim`` (``/Pigeon``) and the root layer's time metadata."""
    vset = prim.GetVariantSets().AddVariantSet(MOTION_VARIANT_SET)
    for name in MOTIONS:
        vset.AddVariant(name)
        if name != REST:
            vset.SetVariantSelection(name)
            with vset.GetVariantEditContext():
                rel = stage.OverridePrim(SKELETON).CreateRelationship("skel:animationSource", custom=False)
                rel.SetTargets([animation_path(name)])
    vset.SetVariantSelection(REST)
    stage.SetTimeCodesPerSecond(FPS)
    stage.SetFramesPerSecond(FPS)
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(round(DURATION_S * FPS))


def motion_layer(interface: str, motion: str):
    """A layer, as a shot would write one, that sublayers ``interface`` and selects ``motion`` (for Blender, which
    imports default variants), with the time metadata (a stage takes it from its root layer)."""
    from pxr import Sdf

    layer = Sdf.Layer.CreateAnonymous(".usda")
    root = layer.pseudoRoot
    for key, value in (("defaultPrim", "Pigeon"), ("upAxis", "Y"), ("metersPerUnit", 1.0),
                       ("timeCodesPerSecond", float(FPS)), ("framesPerSecond", float(FPS)),
                       ("startTimeCode", 0.0), ("endTimeCode", float(round(DURATION_S * FPS)))):
        root.SetInfo(key, value)
    layer.documentation = f"The pigeon asset playing its '{motion}' motion: open this layer instead of {interface}."
    layer.subLayerPaths = [f"./{interface}"]
    prim = Sdf.CreatePrimInLayer(layer, "/Pigeon")
    prim.specifier = Sdf.SpecifierOver
    prim.variantSelections[MOTION_VARIANT_SET] = motion
    return layer

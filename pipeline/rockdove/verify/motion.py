"""A motion measured at every time code on the written asset as UsdSkel poses it, each measure with the limit
that fails the verification (:data:`LIMITS`): ``card_stretch`` (largest relative change of an edge of a rigid part);
``card_root_off_skin_m`` (a neck card's root moving off the Body point under it at rest); ``head_into_cards_m`` (how
deep a neck-card point in front of the head at rest goes behind it); ``stance_slip_m``, ``toe_below_ground_m``,
``frames_without_support`` of the Legs' soles; and for the walk the head (the Eyes' centre) against the trunk (the
Wings'): ``head_hold_drift_m`` (within a hold: head speed under :data:`HOLD_SPEED` of the trunk's mean),
``hold_fraction``, ``head_cycles`` against the steps (foot-falls) and ``head_to_body_speed`` (mean forward speeds)."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import trimesh
from pxr import UsdGeom, UsdSkel
from scipy.sparse import csr_matrix

from ..errors import UsageError
from ..render.animation import frame_image
from ..render.gl import GLRenderer
from ..render.images import write_webp
from ..render.scene import load_scene
from ..render.skinning import pose
from ..render.triangulate import fan_triangulate
from ..render.views import View, look_at
from ..rig.weights import SMOOTH_PARTS
from ..usd.layout import resolve_root_layer
from ..usd.schema import has_thin_film
from ..usd.skel import MOTION_VARIANT_SET, REST
from ..usd.stage import open_asset
from .inputs import BOUNDARY_SWEEP_ANGLE_DEG, verification_views
from .results import MotionCheck

#: measure -> (low, high) allowed, or high alone.
LIMITS = {"card_stretch": 0.01, "card_root_off_skin_m": 0.0005, "head_into_cards_m": 0.0005,
          "stance_slip_m": 0.0005, "toe_below_ground_m": 0.0005, "frames_without_support": 0,
          "head_hold_drift_m": 0.001, "hold_fraction": (0.4, 0.8), "head_to_body_speed": (0.98, 1.02)}
#: Forward speed of the head under which it holds, as a fraction of the trunk's mean.
HOLD_SPEED = 0.05
#: Card points this close to the head's bounds are checked against it, metres.
NEAR_HEAD_M = 0.01
#: A sole point is down within this height of the rest pose's lowest point, metres.
CONTACT_M = 0.001


def _mesh(stage, name):
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"/Pigeon/Geom/{name}"))
    counts, fvi = (np.asarray(a.Get(), np.int64) for a in (mesh.GetFaceVertexCountsAttr(),
                                                               mesh.GetFaceVertexIndicesAttr()))
    return np.asarray(mesh.GetPointsAttr().Get(), np.float64), fan_triangulate(counts, fvi, False).astype(np.int64)


def _closest(points, tris_xyz):
    """(closest points (N, 3), triangle index (N,)) of ``points`` on the triangles (T, 3, 3)."""
    mesh = trimesh.Trimesh(tris_xyz.reshape(-1, 3), np.arange(len(tris_xyz) * 3).reshape(-1, 3), process=False)
    closest, _, tri = trimesh.proximity.closest_point(mesh, points)
    return closest, tri


def _rigid(a, b):
    """(R (3, 3), t (3,)): the rigid motion taking points ``a`` (N, 3) nearest to ``b``: b ~ a @ R.T + t (Kabsch)."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    rot = (u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt).T
    return rot, cb - ca @ rot.T


def measure_motion(asset, motion: str) -> MotionCheck:
    """The measures of ``motion`` in the asset (folder or layer) against :data:`LIMITS`."""
    stage = open_asset(resolve_root_layer(asset))
    rest = {p.GetName(): _mesh(stage, p.GetName()) for p in stage.GetPrimAtPath("/Pigeon/Geom").GetChildren()
            if p.GetTypeName() == "Mesh"}
    body_w = UsdSkel.BindingAPI(stage.GetPrimAtPath("/Pigeon/Geom/Body"))
    joints = [str(j).rsplit("/", 1)[-1] for j in body_w.GetSkeleton().GetJointsAttr().Get()]
    stage.GetDefaultPrim().GetVariantSet(MOTION_VARIANT_SET).SetVariantSelection(motion)
    times = np.arange(stage.GetStartTimeCode(), stage.GetEndTimeCode() + 1)
    posed = [{k.rsplit("/", 1)[-1]: v[0] @ v[2][:3, :3] + v[2][3, :3] for k, v in frame.items()}
             for frame in pose(stage, times, with_normals=False)]
    m = {}
    edges = {n: tris[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2) for n, (_, tris) in rest.items() if n not in SMOOTH_PARTS}
    length = lambda p, e: np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1)  # noqa: E731
    m["card_stretch"] = max(float(np.abs(length(f[n], e) / np.maximum(length(rest[n][0], e), 1e-12) - 1).max())
                            for f in posed for n, e in edges.items())
    body, body_tris = rest["Body"]
    feather = next(p.GetName() for p in stage.GetPrimAtPath("/Pigeon/Geom").GetChildren() if has_thin_film(p))
    cards, card_tris = rest[feather]
    comp = trimesh.graph.connected_component_labels(card_tris[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2),
                                                    node_count=len(cards))
    foot, tri = _closest(cards, body[body_tris])
    depth = np.einsum("ij,ij->i", cards - foot, trimesh.triangles.normals(body[body_tris[tri]])[0])
    lowest = np.full(comp.max() + 1, np.inf)
    np.minimum.at(lowest, comp, depth)
    sel = depth <= lowest[comp] + 1e-4  # each card's deepest points (its quill's corners): their middle is its root
    counts = np.bincount(comp[sel], minlength=comp.max() + 1)
    mix = csr_matrix((1.0 / counts[comp[sel]], (comp[sel], np.flatnonzero(sel))), shape=(len(counts), len(cards)))
    roots = mix @ cards
    foot, tri = _closest(roots, body[body_tris])
    bary = trimesh.triangles.points_to_barycentric(body[body_tris[tri]], foot)
    anchor = lambda p: np.einsum("nk,nkd->nd", bary, p[body_tris[tri]])  # noqa: E731
    off0 = np.linalg.norm(roots - anchor(body), axis=1)
    m["card_root_off_skin_m"] = max(float(np.abs(np.linalg.norm(mix @ f[feather] - anchor(f["Body"]), axis=1)
                                                 - off0).max()) for f in posed)
    idx = np.asarray(body_w.GetJointIndicesPrimvar().Get()).reshape(len(body), -1)
    w = np.asarray(body_w.GetJointWeightsPrimvar().Get()).reshape(len(body), -1)
    on_head = (w * (idx == joints.index("head"))).sum(axis=1) > 0.999
    head_tris = body_tris[on_head[body_tris].all(axis=1)]

    head = trimesh.Trimesh(body, head_tris, process=False)  # the head at rest: it moves rigidly

    def side(p):  # signed distance to the head's surface at rest, metres (negative behind it; 0 where the point
        # is nearest to the rim of that open patch, not over it)
        closest, dist, t = trimesh.proximity.closest_point(head, p)
        d = np.einsum("ij,ij->i", p - closest, head.face_normals[t])
        return np.where(np.abs(d) >= 0.99 * dist, d, 0.0)

    lo, hi = body[head_tris].min(axis=(0, 1)) - NEAR_HEAD_M, body[head_tris].max(axis=(0, 1)) + NEAR_HEAD_M
    close = np.flatnonzero(((cards > lo) & (cards < hi)).all(axis=1))
    close = close[side(cards[close]) >= 0.0]  # the card points in front of the head at rest
    on = np.unique(head_tris)
    depths = [0.0]
    for f in posed[::2]:
        rot, shift = _rigid(body[on], f["Body"][on])
        depths.append(float(np.clip(-side((f[feather][close] - shift) @ rot), 0.0, NEAR_HEAD_M).max(initial=0.0)))
    m["head_into_cards_m"] = max(depths)
    legs = rest["Legs"][0]
    ground = legs[:, 1].min()
    sole = legs[:, 1] < ground + 0.002
    down, slip = [], 0.0
    for half in (legs[:, 0] >= 0, legs[:, 0] < 0):  # the left foot, the right
        pts = np.array([f["Legs"][sole & half] for f in posed])
        on = pts[:, :, 1].min(axis=1) < ground + CONTACT_M
        centre = pts.mean(axis=1)[:, [0, 2]]
        start = None
        for i, d in enumerate(on):
            start = (i if start is None else start) if d else None
            if d:
                slip = max(slip, float(np.linalg.norm(centre[i] - centre[start])))
        down.append(on)
    m["stance_slip_m"] = slip
    m["toe_below_ground_m"] = max(0.0, float(ground - min(f["Legs"][:, 1].min() for f in posed)))
    m["frames_without_support"] = int((~(down[0] | down[1])).sum())
    if motion == "walk":
        fps = stage.GetTimeCodesPerSecond()
        head = np.array([f["Eyes"].mean(axis=0) for f in posed])
        trunk = np.array([f["Wings"].mean(axis=0) for f in posed])
        v_head, v_trunk = np.diff(head[:, 2]) * fps, np.diff(trunk[:, 2]) * fps
        hold = v_head < HOLD_SPEED * v_trunk.mean()
        runs = np.flatnonzero(np.diff(np.r_[0, hold.astype(int)]) == 1)
        ends = np.flatnonzero(np.diff(np.r_[hold.astype(int), 0]) == -1) + 1
        m["head_hold_drift_m"] = max(float(np.ptp(head[a:b + 1, 1:], axis=0).max()) for a, b in zip(runs, ends))
        m["hold_fraction"] = float(hold.mean())
        m["head_cycles"] = len(runs)
        m["steps"] = int(sum(np.count_nonzero(np.diff(d.astype(int)) == 1) for d in down))
        m["head_to_body_speed"] = float(v_head.mean() / v_trunk.mean())
        m["body_speed_m_s"] = float(v_trunk.mean())
        m["head_peak_speed_m_s"] = float(v_head.max())
    failures = []
    for key, limit in LIMITS.items():
        if key not in m:
            continue
        lo, hi = limit if isinstance(limit, tuple) else (None, limit)
        if (hi is not None and m[key] > hi) or (lo is not None and m[key] < lo):
            failures.append(f"motion {motion}: {key} = {m[key]:.4g}, allowed {limit}")
    if "head_cycles" in m and abs(m["head_cycles"] - m["steps"]) > 1:
        failures.append(f"motion {motion}: {m['head_cycles']} head cycles for {m['steps']} steps, expected one each")
    return MotionCheck(motion, len(times), m, LIMITS, tuple(failures))


#: Time codes the film is checked at by default (of 60 a second): in one step of the walk, the hold's start, its
#: end and the thrust.
DEFAULT_TIMES = (15.0, 21.0, 26.0)


def motion_times(layer: str, motion: str, times=None) -> tuple:
    """``times`` (default :data:`DEFAULT_TIMES`); UsageError for a motion the asset has not or a time outside it."""
    stage = open_asset(layer)
    names = stage.GetDefaultPrim().GetVariantSet(MOTION_VARIANT_SET).GetVariantNames()
    if motion not in names or motion == REST:
        raise UsageError(f"motion={motion!r} is not a motion of {layer}; it has {[n for n in names if n != REST]}")
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    times = tuple(float(t) for t in (DEFAULT_TIMES if times is None else times))
    bad = [t for t in times if not start <= t <= end]
    if bad or not times:
        raise UsageError(f"times={list(times)} must lie within the animation's time codes {start:g} to {end:g} "
                         f"({stage.GetTimeCodesPerSecond():g} per second)")
    if len(set(times)) < len(times):  # each frame's views and images are named by its time code
        raise UsageError(f"times={list(times)} names a time code twice")
    return times


def frame_prefix(motion: str, t: float) -> str:
    """The views of ``motion``'s frame at time code ``t`` are named ``<prefix>_<view>``: ``walk021``, ``walk015_5``."""
    return f"{motion}{t:03.0f}" if float(t).is_integer() else f"{motion}{t:g}".replace(".", "_")


def frame_views(scene, width: int, height: int, prefix: str) -> list:
    """A posed frame's views, ``<prefix>_<view>``: the light sweep at the green/purple flip, the first turntable."""
    views = verification_views(scene, width, height, 2)
    keep = [v for v in views if v.name == f"sweep_{int(round(BOUNDARY_SWEEP_ANGLE_DEG)):03d}"]
    keep += [v for v in views if v.name.startswith("turntable_")][:1]
    return [dataclasses.replace(v, name=f"{prefix}_{v.name}") for v in keep]


#: The report's animation of a motion: file name, time codes between frames, frames (one stride of the walk at
#: 30 frames a second), size in pixels.
ANIMATION_FILE, ANIMATION_STEP, ANIMATION_FRAMES, ANIMATION_SIZE = "{motion}.webp", 2, 12, 256


def animation(layer: str, motion: str, out_dir: str, lut=None) -> dict:
    """The motion seen from the bird's left at its neck, the camera gliding at the trunk's mean speed, as an animated
    WebP in ``out_dir`` (caption below); the report's entry: ``{"file", "frames", "fps", "caption"}``."""
    times = [ANIMATION_STEP * k for k in range(ANIMATION_FRAMES)]
    scenes = [load_scene(layer, {"motion": motion}, t) for t in times]
    neck = np.array([s.neck_centre_m for s in scenes])
    glide = np.polyfit(times, neck, 1)  # (2, 3): the neck's mean travel per time code and its start
    light = np.array([0.5, 0.6, 0.62]) / np.linalg.norm([0.5, 0.6, 0.62])
    images = []
    for t, scene in zip(times, scenes):
        target = glide[0] * t + glide[1] - np.array([0.0, 0.012, 0.0])
        view = View(f"{motion}{t:03d}", look_at(target + np.array([0.45, 0.04, 0.05]), target), np.radians(24.0),
                    ANIMATION_SIZE, ANIMATION_SIZE, light, np.ones(3))
        with GLRenderer(scene, lut=lut, width=ANIMATION_SIZE, height=ANIMATION_SIZE, mipmaps=True) as renderer:
            images.append(frame_image(renderer, view))
    fps = 60.0 / ANIMATION_STEP
    path = write_webp(images, os.path.join(out_dir, ANIMATION_FILE.format(motion=motion)), fps)
    return {"file": os.path.basename(path), "frames": len(images), "fps": fps,
            "caption": f"{motion}: one stride, {len(images)} frames at {fps:g} a second, our GLSL of each frame "
                       f"skinned by UsdSkel, a white light fixed in the world: the neck's colour moves as it bobs"}

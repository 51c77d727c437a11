"""Skin weights as values: :data:`INFLUENCES` (joint index, weight) pairs per point of every part, no USD.

- ``Body``: linear weights between the two joints of the axial chain (:data:`AXIAL`) that a parameter u falls
  between: on the trunk the closest point of the polyline tail_fan -> chest, on the neck (neck coordinate s of
  ``rockdove.geometry.neck`` >= 0 within the band's radius) s itself, so the head (s >= 1) is rigid; blended over s
  in [-0.35, 0] and 12 mm of radius, and into the head within :data:`HEAD_BLEND_M` of its ellipsoid.
- ``Legs``: inverse fourth power of the distance to the bones of the point's side, the two nearest kept.
- ``Wings``: each feather (connected component) on the wing joint of its side nearest its root.
- every other part, per connected component (a card, a rectrix, an eye, the beak): one weight set, the Body's at
  the foot on the skin of its root (the middle of its deepest points: a card's quill) when it reaches within
  :data:`ROOTED_M` of the body's surface, else the nearest visible skin vertex's (a claw: its toe's)."""

from __future__ import annotations

import numpy as np

from ..errors import UsageError
from ..geometry.sdf import HEAD, NECK_BAND_RADIUS_M, body_sdf, neck_s, sdf_gradient, smoothstep
from .skeleton import NECK_S, TOE_NAMES

#: Influences per point (the glTF JOINTS_0/WEIGHTS_0 size); unused slots have weight 0 and joint 0.
INFLUENCES = 4
#: Parts skinned smoothly; the rest is rigid per connected component.
SMOOTH_PARTS = ("Body", "Legs")
#: The axial chain of the body's weights, tail tip to head.
AXIAL = ("tail_fan", "tail_base", "pelvis", "spine_01", "spine_02", "chest", "neck_01", "neck_02", "neck_03",
         "neck_04", "neck_05", "head")
#: The tarsus bone stops this fraction of its length short of the foot: the toes' base moves with the foot.
TARSUS_FOOT_SHARE = 0.25
#: Components with a point this close to the body's surface (or inside) grow from the Body: its weights, metres.
ROOTED_M = 0.002
#: The skin within this distance of the head's ellipsoid (``sdf.HEAD``) blends into the head, metres.
HEAD_BLEND_M = 0.008
#: Blend from the trunk to the neck: over these neck coordinates and this width past the band's radius, metres.
NECK_GATE_S, NECK_GATE_M = (-0.35, 0.0), 0.012


def _pack(idx: np.ndarray, w: np.ndarray):
    """(V, k) joint indices and weights -> the :data:`INFLUENCES` largest, normalised: ((V, 4) int32, (V, 4) f32)."""
    order = np.argsort(-w, axis=1, kind="stable")[:, :INFLUENCES]
    idx, w = np.take_along_axis(idx, order, 1), np.take_along_axis(w, order, 1)
    if idx.shape[1] < INFLUENCES:
        pad = ((0, 0), (0, INFLUENCES - idx.shape[1]))
        idx, w = np.pad(idx, pad), np.pad(w, pad)
    w = np.where(w > 1e-4, w, 0.0)
    w = w / w.sum(axis=1, keepdims=True)
    return np.where(w > 0, idx, 0).astype(np.int32), w.astype(np.float32)


def _segments(p, a, b):
    """(N, S) distance from points (N, 3) to segments a -> b (S, 3), and (N, S) the clamped fraction along each."""
    ab = b - a
    t = np.clip(((p[:, None] - a[None]) * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-20), 0.0, 1.0)
    return np.linalg.norm(p[:, None] - (a[None] + t[..., None] * ab[None]), axis=-1), t


def body_weights(points_m, skel):
    """(indices, weights) of the Body's points (V, 3): module docstring."""
    p = np.asarray(points_m, np.float64)
    chain = skel.indices(*AXIAL)
    trunk = skel.rest_m[chain[:6]]
    d, t = _segments(p, trunk[:-1], trunk[1:])
    seg = np.argmin(d, axis=1)
    u_trunk = seg + t[np.arange(len(p)), seg]
    s, r = neck_s(p)
    k = np.clip(np.searchsorted(NECK_S, s, side="right") - 1, 0, len(NECK_S) - 2)  # neck_01 .. head at NECK_S
    u_neck = 6 + k + np.clip((s - np.take(NECK_S, k)) / np.diff(NECK_S)[k], 0.0, None)
    gate = smoothstep(*NECK_GATE_S, s) * (1.0 - smoothstep(NECK_BAND_RADIUS_M, NECK_BAND_RADIUS_M + NECK_GATE_M, r))
    u = np.clip((1.0 - gate) * u_trunk + gate * np.maximum(u_neck, 5.0), 0.0, len(AXIAL) - 1.0)
    near_head = 1.0 - smoothstep(0.0, HEAD_BLEND_M, HEAD.sdf(p))  # the skin at the head's rim goes with it
    u += near_head * (len(AXIAL) - 1.0 - u)
    lo = np.minimum(np.floor(u).astype(np.int64), len(AXIAL) - 2)
    f = u - lo
    return _pack(np.take(chain, np.stack([lo, lo + 1], 1)), np.stack([1.0 - f, f], 1))


def _bones(skel, side: str):
    """(joint indices (B,), bone starts (B, 3), bone ends (B, 3)) of one leg: knee, ankle, foot and the toes."""
    names = ["knee", "ankle", "foot", *TOE_NAMES]
    idx = skel.indices(*(f"{n}_{side}" for n in names))
    start = skel.rest_m[idx]
    at = {n: skel.rest_m[skel.index(f"{n}_{side}")] for n in names}
    end = {"knee": at["ankle"], "ankle": at["foot"] + TARSUS_FOOT_SHARE * (at["ankle"] - at["foot"]),
           "foot": at["foot"]}
    return np.array(idx), start, np.array([end[n] if n in end else 2 * at[n] - at["foot"] for n in names])


def leg_weights(points_m, skel):
    """(indices, weights) of the Legs' points (V, 3): module docstring."""
    p = np.asarray(points_m, np.float64)
    idx, w = np.zeros((len(p), 2), np.int64), np.zeros((len(p), 2))
    for side, sel in (("L", p[:, 0] >= 0), ("R", p[:, 0] < 0)):
        joints, a, b = _bones(skel, side)
        inv = (_segments(p[sel], a, b)[0] + 2e-4) ** -4.0
        top = np.argsort(-inv, axis=1)[:, :2]
        idx[sel], w[sel] = joints[top], np.take_along_axis(inv, top, 1)
    return _pack(idx, w)


def components(part) -> np.ndarray:
    """(V,) int64: the connected component of each point of a :class:`rockdove.geometry.MeshPart` (by faces)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    fvi = np.asarray(part.face_vertex_indices, np.int64)
    first = np.repeat(np.cumsum(part.face_vertex_counts) - part.face_vertex_counts, part.face_vertex_counts)
    n = part.n_points
    graph = coo_matrix((np.ones(len(fvi)), (fvi, fvi[first])), shape=(n, n))  # each corner to its face's first
    return connected_components(graph, directed=False)[1].astype(np.int64)


def _per_component(comp, dist, values):
    """For each component, the row of ``values`` at its point of least ``dist``, given to all its points."""
    order = np.lexsort((dist, comp))
    first = order[np.r_[True, comp[order][1:] != comp[order][:-1]]]  # the nearest point of each component
    return values[first][np.searchsorted(comp[first], comp)]


def _roots(comp, depth, pts, tie_m: float = 1e-4):
    """Each point's component's root: the mean of its points within ``tie_m`` of its least ``depth`` (a card's two
    quill corners: the middle of its root row)."""
    sel = depth <= _per_component(comp, depth, depth) + tie_m
    n = np.bincount(comp[sel], minlength=comp.max() + 1)[:, None]
    total = np.stack([np.bincount(comp[sel], pts[sel, k], minlength=comp.max() + 1) for k in range(3)], 1)
    return (total / np.maximum(n, 1))[comp]


def part_weights(parts, skel) -> dict:
    """``{part name: (joint indices (V, 4) int32, weights (V, 4) float32)}`` for every part (module docstring);
    ``parts`` as the USD meshes hold them (:func:`rockdove.geometry.types.drop_unreferenced_points`)."""
    from scipy.spatial import cKDTree

    smooth = {"Body": body_weights, "Legs": leg_weights}
    out = {part.name: smooth[part.name](part.points_m, skel) for part in parts if part.name in smooth}
    if not out:
        raise UsageError(f"parts {[p.name for p in parts]}: no smooth part ({SMOOTH_PARTS}) to bind the rest to")
    skin = np.concatenate([np.asarray(p.points_m, np.float64) for p in parts if p.name in out])
    skin_idx = np.concatenate([out[p.name][0] for p in parts if p.name in out])
    skin_w = np.concatenate([out[p.name][1] for p in parts if p.name in out])
    seen = np.concatenate([np.full(p.n_points, p.name == "Body") for p in parts if p.name in out])
    seen |= body_sdf(skin) > 0.0  # a leg's hidden top, inside the body, is no card's root
    skin, skin_idx, skin_w = skin[seen], skin_idx[seen], skin_w[seen]
    tree = cKDTree(skin)
    for part in parts:
        if part.name in out:
            continue
        pts = np.asarray(part.points_m, np.float64)
        comp, sdf = components(part), body_sdf(pts)
        root = _roots(comp, sdf, pts)
        if part.name.startswith("Wing"):  # one feather, one wing joint: the nearest to its root
            wing = np.array([i for i, n in enumerate(skel.names) if n.startswith("wing_")])
            j = wing[np.argmin(np.linalg.norm(root[:, None] - skel.rest_m[wing][None], axis=-1), axis=1)]
            out[part.name] = _pack(j[:, None], np.ones((len(pts), 1)))
            continue
        on_body = _per_component(comp, sdf, sdf) <= ROOTED_M  # rooted on the body's skin
        idx, w = np.zeros((len(pts), INFLUENCES), np.int32), np.zeros((len(pts), INFLUENCES), np.float32)
        if on_body.any():  # the skin's own weights at the root's foot on the skin
            foot = root[on_body] - body_sdf(root[on_body])[:, None] * sdf_gradient(body_sdf, root[on_body])
            idx[on_body], w[on_body] = body_weights(foot, skel)
        if not on_body.all():  # else the nearest skin vertex's (a claw: its toe's)
            dist, k = tree.query(pts[~on_body])
            idx[~on_body] = _per_component(comp[~on_body], dist, skin_idx[k])
            w[~on_body] = _per_component(comp[~on_body], dist, skin_w[k])
        out[part.name] = idx, w
    return out

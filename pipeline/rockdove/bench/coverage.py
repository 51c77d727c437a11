"""How much of the neck band the feather cards hide (``rockdove bench geometry``'s coverage column; the tests hold
the default cards to 95%). Nothing in a build or a verification measures it.

Coverage is measured by ray casting (trimesh ray queries, Embree when installed) from outside onto random band
points (:func:`band_coverage`): a point is hidden when the first opaque thing its ray meets is a card, opaque
meaning, with a feather ``alpha`` texture, alpha >= 0.5 (the renderers' ``opacityThreshold``: the feather's
silhouette, not the card rectangle); points the body itself hides from that direction are left out."""

from __future__ import annotations

import numpy as np

from ..errors import UsageError
from ..geometry import neck as _neck
from ..geometry import sdf as _sdf

#: Rays start this far outside the skin, metres (beyond the highest card tip).
RAY_START_M = 0.02
#: A first body hit within this distance of the target counts as the target itself, metres.
TARGET_TOLERANCE_M = 0.001


def _tilted(n: np.ndarray, tilt_deg: float, rng: np.random.Generator) -> np.ndarray:
    """Unit directions at ``tilt_deg`` from each normal (N, 3), toward random tangent azimuths."""
    if tilt_deg == 0:
        return n
    helper = np.where(np.abs(n[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    t1 = np.cross(n, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(n, t1)
    phi = rng.uniform(0.0, 2.0 * np.pi, len(n))[:, None]
    a = np.deg2rad(tilt_deg)
    d = np.cos(a) * n + np.sin(a) * (np.cos(phi) * t1 + np.sin(phi) * t2)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def band_coverage(body_vertices_m, body_faces, cards, rays: int = 2000, tilt_deg: float = 0.0, seed: int = 0,
                  alpha: np.ndarray | None = None) -> float:
    """Fraction in [0, 1] of the neck band's skin hidden behind ``cards`` (FeatherCards) on the welded body mesh,
    seen from outside: ``rays`` random band points (``seed``) looked at at ``tilt_deg`` from the skin normal
    (random azimuth), counting only the points visible from there at all. ``alpha``: (H, W) feather alpha in
    [0, 255] (row 0 = tip, v = 1); when given, card hits outside the silhouette (alpha < 128) do not hide."""
    import trimesh

    rng = np.random.default_rng(seed)
    target = _neck.sample_band_uniform(body_vertices_m, body_faces, rays, rng)
    view = _tilted(_sdf.sdf_gradient(_sdf.body_sdf, target), tilt_deg, rng)
    origin = target + RAY_START_M * view
    card_tri = cards.triangles()
    verts = np.concatenate([cards.points_m.astype(np.float64), body_vertices_m])
    faces = np.concatenate([card_tri, np.asarray(body_faces) + len(cards.points_m)])
    scene = trimesh.Trimesh(verts, faces, process=False)
    loc, ray_id, tri_id = scene.ray.intersects_location(origin, -view, multiple_hits=True)
    dist = np.einsum("ij,ij->i", loc - origin[ray_id], -view[ray_id])
    is_card = tri_id < len(card_tri)
    opaque = np.ones(len(tri_id), dtype=bool)
    if alpha is not None:
        tri = scene.triangles[tri_id[is_card]]
        bary = trimesh.triangles.points_to_barycentric(tri, loc[is_card])
        st = np.einsum("nk,nkd->nd", bary, cards.st.astype(np.float64)[card_tri[tri_id[is_card]]])
        h, w = alpha.shape
        col = np.clip((st[:, 0] * w).astype(int), 0, w - 1)
        row = np.clip(((1.0 - st[:, 1]) * h).astype(int), 0, h - 1)
        opaque[is_card] = alpha[row, col] >= 128
    keep = opaque & (dist > 0)
    ray_id, dist, is_card = ray_id[keep], dist[keep], is_card[keep]
    order = np.lexsort((dist, ray_id))
    ray_id, dist, is_card = ray_id[order], dist[order], is_card[order]
    first = np.unique(ray_id, return_index=True)[1]
    d, hidden = dist[first], is_card[first]
    visible_skin = (~hidden) & (np.abs(d - RAY_START_M) < TARGET_TOLERANCE_M)
    counted = hidden.sum() + visible_skin.sum()
    if counted == 0:
        raise UsageError("no band point is visible from outside in this direction")
    return float(hidden.sum() / counted)

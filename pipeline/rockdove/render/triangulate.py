"""Polygon meshes to triangles: fan triangulation of USD faces and area-weighted vertex normals (numpy only)."""

from __future__ import annotations

import numpy as np

from ..errors import UsageError


def fan_triangulate(face_vertex_counts, face_vertex_indices, left_handed: bool = False) -> np.ndarray:
    """Fan-triangulate USD faces (counts >= 3, concatenated vertex indices): face ``(v0, v1, ..., vk)`` ->
    ``(v0, vi, vi+1)``, i = 1..k-1, (sum(counts - 2), 3) int64 vertex indices; ``left_handed`` (USD
    ``orientation = leftHanded``) reverses the winding so the triangles are counter-clockwise."""
    counts = np.asarray(face_vertex_counts, dtype=np.int64)
    fvi = np.asarray(face_vertex_indices, dtype=np.int64)
    if counts.size and counts.min() < 3:
        raise UsageError(f"face_vertex_counts must all be >= 3, got a face with {int(counts.min())}")
    if counts.sum() != fvi.size:
        raise UsageError(f"face_vertex_indices has {fvi.size} entries, face_vertex_counts sum to {counts.sum()}")
    tris = fvi[fan_triangulate_corners(counts)]
    if left_handed:
        tris = tris[:, [0, 2, 1]]
    return tris


def fan_triangulate_corners(face_vertex_counts) -> np.ndarray:
    """Like :func:`fan_triangulate` but returns indices of face *corners* (positions in face_vertex_indices)."""
    counts = np.asarray(face_vertex_counts, dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    ntri = counts - 2
    face = np.repeat(np.arange(counts.size), ntri)
    first_tri = np.concatenate([[0], np.cumsum(ntri)[:-1]])
    k = np.arange(ntri.sum()) - first_tri[face] + 1
    s = starts[face]
    return np.stack([s, s + k, s + k + 1], axis=1)


def vertex_normals(positions, triangles) -> np.ndarray:
    """Area-weighted vertex normals, (V, 3) float32 unit (zero-area vertices get +Y)."""
    p = np.asarray(positions, dtype=np.float64)
    t = np.asarray(triangles)
    fn = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])
    n = np.zeros_like(p)
    for c in range(3):
        np.add.at(n, t[:, c], fn)
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(norm > 1e-30, n / np.maximum(norm, 1e-30), [0.0, 1.0, 0.0])
    return n.astype(np.float32)

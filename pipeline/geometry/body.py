"""The body that carries the feathers: one closed, watertight, smooth surface meshed from an implicit field.

Meshing is naive surface nets (Gibson, "Constrained elastic surface nets", MERL TR99-24, 1999): one vertex per
grid cell that the surface crosses (the mean of its edge crossings), one quad per grid edge that changes sign,
joining the four cells around that edge. Each vertex is then projected onto the zero set by Newton steps
along the field gradient, so the mesh is smooth and on the surface. For a field that is smooth at the grid
scale every interior edge is shared by exactly two quads, so the mesh is closed; it is checked with trimesh.
Normals are the unit field gradient (outward).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.geometry import sdf as _sdf

#: Newton projection steps onto the zero set.
PROJECTION_STEPS = 4


@dataclass(frozen=True)
class BodyMesh:
    """The unsplit (welded) body surface, before UVs.

    Attributes
    ----------
    vertices_m : np.ndarray
        (V, 3) float64, metres, on the surface.
    faces : np.ndarray
        (F, 3) int64 triangles, counter-clockwise seen from outside.
    normals : np.ndarray
        (V, 3) float64 unit outward normals.
    """

    vertices_m: np.ndarray
    faces: np.ndarray
    normals: np.ndarray


def surface_nets(values: np.ndarray, origin_m: np.ndarray, voxel_m: float):
    """Mesh the zero set of a sampled field (negative inside) by naive surface nets.

    Parameters
    ----------
    values : np.ndarray
        (nx, ny, nz) field samples at ``origin_m + voxel_m * (i, j, k)``; must be positive on the boundary.
    origin_m : np.ndarray
        (3,) position of sample (0, 0, 0), metres.
    voxel_m : float
        Grid spacing, metres.

    Returns
    -------
    vertices_m : np.ndarray
        (V, 3) float64 cell vertices (mean of the edge crossings).
    quads : np.ndarray
        (Q, 4) int64, counter-clockwise seen from the positive (outside) side.
    """
    f = np.asarray(values, dtype=np.float64)
    if f.ndim != 3 or min(f.shape) < 3:
        raise ValueError(f"values must be a 3-D grid of at least 3 samples per axis, got shape {f.shape}")
    border = np.concatenate([f[[0, -1]].ravel(), f[:, [0, -1]].ravel(), f[:, :, [0, -1]].ravel()])
    if np.any(border <= 0):
        raise ValueError("values must be positive on the grid boundary (the surface must lie inside the grid)")
    inside = f < 0
    cshape = tuple(n - 1 for n in f.shape)
    ncell = int(np.prod(cshape))
    acc = np.zeros((ncell, 3))
    cnt = np.zeros(ncell)
    edge_sets = []
    for axis in range(3):  # the three edge directions
        sl0 = [slice(None)] * 3
        sl1 = [slice(None)] * 3
        sl0[axis] = slice(0, -1)
        sl1[axis] = slice(1, None)
        f0, f1 = f[tuple(sl0)], f[tuple(sl1)]
        change = inside[tuple(sl0)] != inside[tuple(sl1)]
        idx = np.argwhere(change)  # (E, 3) lower corner of each crossing edge
        t = f0[change] / (f0[change] - f1[change])
        point = idx.astype(np.float64)
        point[:, axis] += t
        # the four cells around an edge along `axis`: offsets of -1/0 in the two other axes
        o1, o2 = (axis + 1) % 3, (axis + 2) % 3  # right-handed: e[o1] x e[o2] = e[axis]
        cells = []
        for d1, d2 in ((-1, -1), (0, -1), (0, 0), (-1, 0)):  # counter-clockwise about +axis
            c = idx.copy()
            c[:, o1] += d1
            c[:, o2] += d2
            cells.append(c)
            flat = np.ravel_multi_index(c.T, cshape)
            for a in range(3):
                acc[:, a] += np.bincount(flat, weights=point[:, a], minlength=ncell)
            cnt += np.bincount(flat, minlength=ncell)
        edge_sets.append((cells, f0[change] < 0))
    active = cnt > 0
    vid = np.full(ncell, -1, dtype=np.int64)
    vid[active] = np.arange(int(active.sum()))
    vid = vid.reshape(cshape)
    vertices = origin_m + voxel_m * (acc[active] / cnt[active][:, None])
    quads = []
    for cells, outward_positive in edge_sets:
        q = np.stack([vid[c[:, 0], c[:, 1], c[:, 2]] for c in cells], axis=1)
        # inside at the lower end: the surface faces +axis, keep the order; else reverse it
        q[~outward_positive] = q[~outward_positive][:, ::-1]
        quads.append(q)
    return vertices, np.concatenate(quads)


def quads_to_triangles(vertices: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Split each quad (Q, 4) along its shorter diagonal into two triangles, keeping the winding. (2Q, 3)."""
    d02 = np.linalg.norm(vertices[quads[:, 0]] - vertices[quads[:, 2]], axis=1)
    d13 = np.linalg.norm(vertices[quads[:, 1]] - vertices[quads[:, 3]], axis=1)
    use02 = (d02 <= d13)[:, None]
    a = np.where(use02, quads[:, [0, 1, 2]], quads[:, [0, 1, 3]])
    b = np.where(use02, quads[:, [0, 2, 3]], quads[:, [1, 2, 3]])
    return np.concatenate([a, b])


def project_to_surface(field, points_m: np.ndarray, steps: int = PROJECTION_STEPS, max_step_m: float = 0.002):
    """Move (N, 3) points onto the zero set of ``field`` by Newton steps along its gradient."""
    p = np.array(points_m, dtype=np.float64)
    for _ in range(steps):
        d = field(p)
        g = _sdf.sdf_gradient(field, p)
        p -= np.clip(d, -max_step_m, max_step_m)[:, None] * g
    return p


def mesh_field(field, bounds_m, voxel_m: float) -> BodyMesh:
    """Mesh the closed zero set of ``field`` inside ``bounds_m`` ((3,), (3,)) at grid spacing ``voxel_m``."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in bounds_m)
    n = np.ceil((hi - lo) / voxel_m).astype(int) + 3
    origin = lo - voxel_m
    axes = [origin[a] + voxel_m * np.arange(n[a]) for a in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    values = field(grid).reshape(tuple(n))
    vertices, quads = surface_nets(values, origin, voxel_m)
    vertices = project_to_surface(field, vertices)
    faces = quads_to_triangles(vertices, quads)
    normals = _sdf.sdf_gradient(field, vertices)
    return BodyMesh(vertices_m=vertices, faces=faces, normals=normals)


def build_body_mesh(voxel_m: float = 0.002) -> BodyMesh:
    """The rock dove's body (torso, neck, head, folded wings, tail) as one closed surface, welded, no UVs.

    Parameters
    ----------
    voxel_m : float
        Grid spacing, metres (0.0008 .. 0.01).
    """
    if not (0.0008 <= voxel_m <= 0.01):
        raise ValueError(f"voxel_m={voxel_m!r} must lie within [0.0008, 0.01] m")
    return mesh_field(_sdf.body_sdf, _sdf.BODY_BOUNDS_M, voxel_m)

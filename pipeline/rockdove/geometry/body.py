"""The body that carries the feathers: one closed, watertight, smooth surface meshed from an implicit field.

Meshing is naive surface nets (Gibson, "Constrained elastic surface nets", MERL TR99-24, 1999): one vertex per
grid cell that the surface crosses (the mean of its edge crossings), one quad per grid edge that changes sign,
joining the four cells around that edge. Each vertex is then projected onto the zero set by Newton steps
along the field gradient, so the mesh is smooth and on the surface. For a field that is smooth at the grid
scale every interior edge is shared by exactly two quads, so the mesh is closed (the tests check it with
trimesh at subdivision levels 0, 1 and 2). Normals are the unit field gradient (outward).

Detail without a slow unwrap: xatlas's time grows faster than linearly with the face count (2.6 s at 17.6k
faces, 26-29 s at 70.6k on the project's 2-core machine), so the body is meshed on a coarse grid
(:data:`UNWRAP_VOXEL_M`, about 4.4k triangles), unwrapped there, and then refined: midpoint subdivision of the
seam-split mesh (``trimesh.remesh.subdivide``, which interpolates st linearly; each triangle becomes four),
the new vertices projected onto the implicit surface after every level, normals from the field gradient. A
midpoint on a seam is the mean of the same two endpoint positions on both sides, so the two copies are
bitwise equal; they are welded by exact position before projection, projected once, and scattered back, so
they stay equal and the welded mesh stays closed. Projecting after each level (rather than once at the end)
moves each new vertex about a quarter as far at the finest level; on the 8 mm body it leaves no triangle
folded against the field's normal (projecting once at the end folded a few on the tail's thin edge).

After each level's projection the welded vertices get a few steps of tangential relaxation, the smoothing
step of isotropic remeshing (Botsch, Kobbelt, Pauly, Alliez and Levy, "Polygon Mesh Processing", AK Peters
2010, section 6.5.3): each vertex moves part of the way toward the mean of its neighbours (the umbrella
operator, ``trimesh.smoothing.laplacian_calculation``), within its tangent plane (the field gradient), then
one Newton step back onto the zero set. Subdivision keeps the coarse triangles' shapes, and projection
distorts them where the coarse mesh is a poor chord of the surface (the tail's rim); relaxation evens them
out: on the default body the 1st percentile of the smallest triangle angle goes from 15 to 33 degrees (surface
nets at 2 mm: 28) and the largest distance of a triangle centroid from the surface from 1.0 to 0.74 mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rockdove.geometry import sdf as _sdf

#: Newton projection steps onto the zero set.
PROJECTION_STEPS = 4
#: Newton steps for the midpoints of a subdivision level (they start closer, and relaxation adds one step per
#: iteration): on the default body 3 leave every vertex within 9e-6 m of the zero set, as 4 leave 4e-6 m.
SUBDIVISION_PROJECTION_STEPS = 3
#: Grid spacing of the coarse mesh that xatlas unwraps, metres: 4,384 triangles, unwrapped in ~0.3 s. 8 mm
#: meshes the thin tail (22 mm) and the wing creases as one closed surface; 6 mm does not (one
#: non-manifold edge where a wing meets the neck), so the grid is fixed rather than derived from the detail.
UNWRAP_VOXEL_M = 0.008
#: Tangential relaxation after each subdivision level: iterations, and the fraction of the way to the
#: neighbours' mean moved per iteration (2 and 0.5: more iterations changed the angles by < 1 degree).
RELAX_ITERATIONS = 2
RELAX_STEP = 0.5


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


def _check_voxel(voxel_m) -> float:
    from rockdove.config import limits

    lo, hi = limits("geometry.body_voxel_m")  # the config's range (schemas/config.schema.json)
    try:
        v = float(voxel_m)
    except (TypeError, ValueError):
        raise ValueError(f"voxel_m={voxel_m!r} must be a number of metres in [{lo}, {hi}]") from None
    if not (lo <= v <= hi):
        raise ValueError(f"voxel_m={voxel_m!r} must lie within [{lo}, {hi}] m")
    return v


def build_body_mesh(voxel_m: float = UNWRAP_VOXEL_M) -> BodyMesh:
    """The rock dove's body (torso, neck, head, folded wings, tail) as one closed surface, welded, no UVs.

    Surface nets on a grid of ``voxel_m``, no subdivision (:func:`rockdove.geometry.build_body` builds the
    detailed, unwrapped body from the :data:`UNWRAP_VOXEL_M` one).

    Parameters
    ----------
    voxel_m : float
        Grid spacing, metres (0.0008 .. 0.01).
    """
    return mesh_field(_sdf.body_sdf, _sdf.BODY_BOUNDS_M, _check_voxel(voxel_m))


def subdivision_levels(voxel_m: float) -> int:
    """Midpoint subdivisions of the :data:`UNWRAP_VOXEL_M` mesh that bring its edges nearest to ``voxel_m``.

    ``k = max(0, round(log2(UNWRAP_VOXEL_M / voxel_m)))``: each level halves the edges and multiplies the
    triangles by 4, so 0.002 m gives k = 2 (about 70k triangles, the density of surface nets at 2 mm),
    0.004 m gives 1, anything from about 0.0057 m up gives 0 (the unwrap mesh itself).
    """
    v = _check_voxel(voxel_m)
    return max(0, int(round(math.log2(UNWRAP_VOXEL_M / v))))


def weld_exact(points_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices whose positions are bitwise equal.

    Parameters
    ----------
    points_m : np.ndarray
        (V, 3) float64.

    Returns
    -------
    welded_m : np.ndarray
        (W, 3) the distinct positions, in lexicographic order (deterministic).
    to_welded : np.ndarray
        (V,) int64 index of each input vertex in ``welded_m``.
    """
    welded, inverse = np.unique(np.asarray(points_m, dtype=np.float64), axis=0, return_inverse=True)
    return welded, inverse.reshape(-1).astype(np.int64)


def relax_on_surface(field, points_m: np.ndarray, faces: np.ndarray, iterations: int = RELAX_ITERATIONS,
                     step: float = RELAX_STEP, max_step_m: float = 0.002) -> np.ndarray:
    """Tangential relaxation of a closed welded triangle mesh on the zero set of ``field``.

    Each iteration: ``n`` = unit field gradient at the vertices; ``d`` = umbrella (mean of the neighbours)
    minus the vertex, less its normal component; ``p += step * d``; one Newton step
    ``p -= field(p) * n`` (clipped to ``max_step_m``) back onto the surface.

    Parameters
    ----------
    field : callable
        (N, 3) -> (N,) signed distance, metres.
    points_m : np.ndarray
        (W, 3) welded vertices on the surface, metres.
    faces : np.ndarray
        (F, 3) triangles in those vertices (closed: every edge in both directions).
    iterations : int
        >= 0.
    step : float
        Fraction of the tangential umbrella vector moved per iteration, in (0, 1].

    Returns
    -------
    np.ndarray
        (W, 3) float64 relaxed vertices, on the surface to about 1e-5 m (default body: 9e-6 m at most).
    """
    import trimesh
    from trimesh import smoothing

    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) or iterations < 0:
        raise ValueError(f"iterations={iterations!r} must be an integer >= 0")
    if not (0.0 < step <= 1.0):
        raise ValueError(f"step={step!r} must lie in (0, 1]")
    p = np.array(points_m, dtype=np.float64)
    if iterations == 0:
        return p
    umbrella = smoothing.laplacian_calculation(trimesh.Trimesh(p, faces, process=False)).tocsr()
    for _ in range(int(iterations)):
        n = _sdf.sdf_gradient(field, p)
        d = umbrella @ p - p
        d -= np.einsum("ij,ij->i", d, n)[:, None] * n
        p += step * d
        p -= np.clip(field(p), -max_step_m, max_step_m)[:, None] * n
    return p


def subdivide_onto_surface(field, points_m: np.ndarray, faces: np.ndarray, st: np.ndarray, levels: int,
                           steps: int = SUBDIVISION_PROJECTION_STEPS, relax_iterations: int = RELAX_ITERATIONS):
    """Refine a seam-split triangle mesh that lies on the zero set of ``field``, keeping its seams closed.

    Each level: ``trimesh.remesh.subdivide`` (every triangle -> 4, st interpolated at edge midpoints), weld the
    vertices by exact position (the two copies of a seam midpoint are bitwise equal), project the new welded
    vertices onto the zero set (:func:`project_to_surface`), relax them all (:func:`relax_on_surface`),
    scatter back to the split vertices (so copies stay bitwise equal).

    Parameters
    ----------
    field : callable
        (N, 3) -> (N,) signed distance, negative inside, metres.
    points_m : np.ndarray
        (V, 3) vertices, metres, split at UV seams (copies of a vertex have equal positions).
    faces : np.ndarray
        (F, 3) triangles in split vertex indices, counter-clockwise seen from outside.
    st : np.ndarray
        (V, 2) texture coordinates.
    levels : int
        Subdivisions, >= 0.
    steps : int
        Newton steps per level.
    relax_iterations : int
        Tangential relaxation iterations per level (:func:`relax_on_surface`).

    Returns
    -------
    welded_m : np.ndarray
        (W, 3) float64 welded vertices, on the surface (the input's where ``levels`` is 0).
    to_welded : np.ndarray
        (V',) int64: the welded vertex of each split vertex.
    faces : np.ndarray
        (4**levels F, 3) int64 triangles in split indices, same winding; the children of input face i are
        contiguous in input order.
    st : np.ndarray
        (V', 2) float64, linear along every original edge.
    """
    from trimesh import remesh

    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 0:
        raise ValueError(f"levels={levels!r} must be an integer >= 0")
    points = np.asarray(points_m, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    st = np.asarray(st, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or st.shape != (len(points), 2):
        raise ValueError(f"points_m (V, 3) and st (V, 2) must match, got {points.shape} and {st.shape}")
    welded, to_welded = weld_exact(points)
    for _ in range(int(levels)):
        n_old = len(points)  # subdivide keeps the old vertices first and appends the midpoints
        points, faces, attributes = remesh.subdivide(points, faces, vertex_attributes={"st": st})
        st = attributes["st"]
        welded, to_welded = weld_exact(points)
        is_new = np.ones(len(welded), dtype=bool)  # only the midpoints move; the old vertices are on the surface
        is_new[to_welded[:n_old]] = False
        welded[is_new] = project_to_surface(field, welded[is_new], steps)
        welded = relax_on_surface(field, welded, to_welded[faces], relax_iterations)
        points = welded[to_welded]
    return welded, to_welded, faces, st

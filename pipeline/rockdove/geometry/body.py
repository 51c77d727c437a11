"""The body that carries the feathers: one closed, watertight, smooth surface meshed from an implicit field.

Meshing is naive surface nets (Gibson, "Constrained elastic surface nets", MERL TR99-24, 1999): one vertex per
grid cell that the surface crosses (the mean of its edge crossings), one quad per grid edge that changes sign,
joining the four cells around that edge; each vertex is then projected onto the zero set by Newton steps along
the field gradient. For a field smooth at the grid scale every interior edge is shared by exactly two quads, so
the mesh is closed (tested with trimesh). Normals are the unit field gradient (outward).

Detail without a slow unwrap: xatlas's time grows faster than linearly with the face count (2.6 s at 17.6k
faces, 26-29 s at 70.6k on 2 cores), so the body is meshed on a coarse grid (:data:`UNWRAP_VOXEL_M`), unwrapped
there, and refined: midpoint subdivision of the seam-split mesh (``trimesh.remesh.subdivide``, st interpolated
linearly), the new vertices projected onto the surface after every level. The two copies of a seam midpoint are
bitwise equal (the mean of the same endpoints), so they are welded by exact position, projected once and
scattered back: the welded mesh stays closed. Projecting after each level rather than once at the end moves each
new vertex a quarter as far, and leaves no triangle folded on the tail's thin edge.

After each level's projection the vertices get a few steps of tangential relaxation, the smoothing step of
isotropic remeshing (Botsch, Kobbelt, Pauly, Alliez and Levy, "Polygon Mesh Processing", AK Peters 2010, 6.5.3):
part of the way toward the mean of the neighbours (the umbrella operator), within the tangent plane, then one
Newton step back. It evens out the triangles projection distorts where the coarse mesh is a poor chord (the
tail's rim): on the default body the 1st percentile of the smallest angle goes from 15 to 33 degrees and the
largest centroid distance from the surface from 1.0 to 0.74 mm."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rockdove.geometry import sdf as _sdf

from ..errors import UsageError

#: Newton projection steps onto the zero set.
PROJECTION_STEPS = 4
#: Newton steps for the midpoints of a subdivision level (they start closer, and relaxation adds one step per
#: iteration): on the default body 3 leave every vertex within 9e-6 m of the zero set, as 4 leave 4e-6 m.
SUBDIVISION_PROJECTION_STEPS = 3
#: Grid spacing of the coarse mesh that xatlas unwraps, metres (3,112 triangles): fixed, not derived from the
#: detail, which subdivision gives.
UNWRAP_VOXEL_M = 0.008
#: Tangential relaxation after each subdivision level: iterations, and the fraction of the way to the
#: neighbours' mean moved per iteration (2 and 0.5: more iterations changed the angles by < 1 degree).
RELAX_ITERATIONS = 2
RELAX_STEP = 0.5


@dataclass(frozen=True)
class BodyMesh:
    """The welded body surface, before UVs: ``vertices_m`` (V, 3) float64 on the surface, ``faces`` (F, 3) int64
    counter-clockwise seen from outside, ``normals`` (V, 3) float64 unit outward."""

    vertices_m: np.ndarray
    faces: np.ndarray
    normals: np.ndarray


def surface_nets(values: np.ndarray, origin_m: np.ndarray, voxel_m: float):
    """Naive surface nets of the zero set of field samples ``values`` (nx, ny, nz) at ``origin_m + voxel_m * (i, j,
    k)``, negative inside, positive on the grid's boundary: (vertices (V, 3) float64, the mean of each cell's edge
    crossings; quads (Q, 4) int64, counter-clockwise seen from outside)."""
    f = np.asarray(values, dtype=np.float64)
    inside = f < 0
    cshape = tuple(n - 1 for n in f.shape)
    ncell = int(np.prod(cshape))
    acc = np.zeros((ncell, 3))
    cnt = np.zeros(ncell)
    edge_sets = []
    for axis in range(3):  # the three edge directions
        sl0 = tuple(slice(0, -1) if a == axis else slice(None) for a in range(3))
        sl1 = tuple(slice(1, None) if a == axis else slice(None) for a in range(3))
        f0, f1 = f[sl0], f[sl1]
        change = inside[sl0] != inside[sl1]
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


def build_body_mesh(voxel_m: float = UNWRAP_VOXEL_M) -> BodyMesh:
    """The body (torso, neck, head) as one closed, welded surface without UVs: surface nets on a grid of
    ``voxel_m`` metres, no subdivision (:func:`rockdove.geometry.build_body` refines the :data:`UNWRAP_VOXEL_M` one)."""
    lo, hi = _sdf.BODY_BOUNDS_M
    n = np.ceil((hi - lo) / voxel_m).astype(int) + 3
    origin = lo - voxel_m
    axes = [origin[a] + voxel_m * np.arange(n[a]) for a in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    vertices, quads = surface_nets(_sdf.body_sdf(grid).reshape(tuple(n)), origin, voxel_m)
    vertices = project_to_surface(_sdf.body_sdf, vertices)
    return BodyMesh(vertices_m=vertices, faces=quads_to_triangles(vertices, quads),
                    normals=_sdf.sdf_gradient(_sdf.body_sdf, vertices))


def subdivision_levels(voxel_m: float) -> int:
    """Midpoint subdivisions of the :data:`UNWRAP_VOXEL_M` mesh that bring its edges nearest to ``voxel_m``:
    ``max(0, round(log2(UNWRAP_VOXEL_M / voxel_m)))`` (each level halves the edges), so 0.002 m gives 2 (the density
    of surface nets at 2 mm), 0.004 m gives 1, from about 0.0057 m up 0. ValueError outside the config's range."""
    from rockdove.config import limits

    lo, hi = limits("geometry.body_voxel_m")  # the config's range (schemas/config.schema.json)
    try:
        v = float(voxel_m)
    except (TypeError, ValueError):
        raise UsageError(f"voxel_m={voxel_m!r} must be a number of metres in [{lo}, {hi}]") from None
    if not (lo <= v <= hi):
        raise UsageError(f"voxel_m={voxel_m!r} must lie within [{lo}, {hi}] m")
    return max(0, int(round(math.log2(UNWRAP_VOXEL_M / v))))


def weld_exact(points_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the distinct positions of (V, 3) points, in lexicographic order; (V,) int64 index of each point in them)."""
    welded, inverse = np.unique(np.asarray(points_m, dtype=np.float64), axis=0, return_inverse=True)
    return welded, inverse.reshape(-1).astype(np.int64)


def relax_on_surface(field, points_m: np.ndarray, faces: np.ndarray, iterations: int = RELAX_ITERATIONS,
                     step: float = RELAX_STEP, max_step_m: float = 0.002) -> np.ndarray:
    """Tangential relaxation (module docstring) of a closed welded mesh (W, 3) / (F, 3) on the zero set of ``field``:
    each iteration moves ``step`` of the way to the neighbours' mean within the tangent plane, then one Newton step
    back (clipped to ``max_step_m``); on the surface to about 1e-5 m (default body: 9e-6 m at most)."""
    import trimesh
    from trimesh import smoothing

    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) or iterations < 0:
        raise UsageError(f"iterations={iterations!r} must be an integer >= 0")
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


def subdivide_onto_surface(field, points_m: np.ndarray, faces: np.ndarray, st: np.ndarray, levels: int):
    """Refine a seam-split triangle mesh (``points_m`` (V, 3) metres, copies of a vertex at equal positions;
    ``faces`` (F, 3) counter-clockwise from outside; ``st`` (V, 2)) on the zero set of ``field`` ``levels`` times,
    keeping its seams closed (module docstring). Returns (welded (W, 3) float64 on the surface; to_welded (V',)
    int64, the welded vertex of each split vertex; faces (4**levels F, 3) int64 in split indices, the children of
    input face i contiguous in input order; st (V', 2) float64, linear along every original edge)."""
    from trimesh import remesh

    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 0:
        raise UsageError(f"levels={levels!r} must be an integer >= 0")
    points = np.asarray(points_m, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    st = np.asarray(st, dtype=np.float64)
    welded, to_welded = weld_exact(points)
    for _ in range(int(levels)):
        n_old = len(points)  # subdivide keeps the old vertices first and appends the midpoints
        points, faces, attributes = remesh.subdivide(points, faces, vertex_attributes={"st": st})
        st = attributes["st"]
        welded, to_welded = weld_exact(points)
        is_new = np.ones(len(welded), dtype=bool)  # only the midpoints move; the old vertices are on the surface
        is_new[to_welded[:n_old]] = False
        welded[is_new] = project_to_surface(field, welded[is_new], SUBDIVISION_PROJECTION_STEPS)
        welded = relax_on_surface(field, welded, to_welded[faces])
        points = welded[to_welded]
    return welded, to_welded, faces, st

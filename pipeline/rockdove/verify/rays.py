"""Primary rays of the CPU reference: one ray per pixel centre, first opaque hit through alpha-cut-out feathers.

The rays are the GL renderer's pinhole camera's (OpenGL convention, vertical field of view ``yfov_rad``, square
pixels), cast with trimesh's ray queries (Embree through embreex when installed). A hit where the part's base
texture has an alpha below the part's ``opacity_threshold`` (the feather cards) is skipped and the ray continues
from just behind it (up to :data:`MAX_ALPHA_LAYERS` layers, vectorised over the rays still travelling). The
:class:`Hits` depend on the geometry and the camera only (:func:`ray_digest`, :func:`camera_key`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..digest import Digest
from ..render.texture import read_texture, sample_texture

#: Feather layers a ray may pass through (alpha-cut-out parts) before the reference gives up and keeps the
#: last hit. Overlapping neck feathers are rarely more than a few layers deep where their alpha is < 0.5.
MAX_ALPHA_LAYERS = 24


def camera_rays(view, pixels=None):
    """World ``(origin (3,), unit directions (P, 3), forward (3,): the camera's -Z)`` of the rays through the pixel
    centres of ``view``'s pinhole camera, or of the flat, row-major ``pixels`` only."""
    h, w = view.height, view.width
    tan_half = np.tan(0.5 * view.yfov_rad)
    idx = np.arange(h * w) if pixels is None else np.asarray(pixels, np.int64).reshape(-1)
    row, col = np.divmod(idx, w)
    d_cam = np.stack([(2.0 * (col + 0.5) / w - 1.0) * tan_half * w / h, (1.0 - 2.0 * (row + 0.5) / h) * tan_half,
                      np.full(idx.size, -1.0)], axis=1)
    m = np.asarray(view.camera_to_world, np.float64)
    d = d_cam @ m[:3, :3].T
    d /= np.sqrt(np.einsum("ij,ij->i", d, d))[:, None]
    fwd = -m[:3, 2] / np.linalg.norm(m[:3, 2])
    return m[:3, 3].copy(), d, fwd


class SceneGeometry:
    """All parts in one trimesh for ray queries, plus per-face part index and the loaded textures."""

    def __init__(self, scene):
        import trimesh

        parts = scene.parts
        offsets = np.cumsum([0] + [len(p.positions_m) for p in parts])
        self.vertices = np.concatenate([np.asarray(p.positions_m, np.float64) for p in parts])
        self.faces = np.concatenate([np.asarray(p.triangles, np.int64) + o for p, o in zip(parts, offsets)])
        self.part_of_face = np.concatenate([np.full(len(p.triangles), i, np.int32) for i, p in enumerate(parts)])
        self.mesh = trimesh.Trimesh(self.vertices, self.faces, process=False)
        self.normals = np.concatenate([np.asarray(p.normals, np.float64) for p in parts])
        self.st = np.concatenate([np.asarray(p.st, np.float64) for p in parts])
        self.thickness = np.concatenate([np.zeros(len(p.positions_m)) if p.thickness_nm is None
                                         else np.asarray(p.thickness_nm, np.float64) for p in parts])
        self.is_feather = np.array([p.is_feather for p in parts])
        self.two_sided = np.array([p.is_feather or p.double_sided for p in parts])
        self.threshold = np.array([p.opacity_threshold for p in parts])
        self.base_tex = [read_texture(p.base_colour_texture, p.base_colour_srgb) if p.base_colour_texture else None
                         for p in parts]
        self.cut_out = np.array([t is not None and t.shape[2] in (2, 4) for t in self.base_tex])  # alpha-tested
        self.mask_tex = [read_texture(p.mask_texture, False) if p.mask_texture else None for p in parts]
        self.base_const = [np.asarray(p.base_colour, np.float64) for p in parts]
        self.scale = float(np.linalg.norm(self.vertices.max(axis=0) - self.vertices.min(axis=0)))

    def interp(self, attr, face, bary):
        return np.einsum("nk,nk...->n...", bary, attr[self.faces[face]])


def _first_opaque_hits(geom: SceneGeometry, origin, dirs, stats: dict):
    """First hit along each ray that is not an alpha-cut-out feather fragment: ``face`` (-1: a miss), point, bary."""
    import trimesh

    n = len(dirs)
    face = np.full(n, -1, np.int64)
    point, bary = np.zeros((2, n, 3))
    live = np.arange(n)
    origins = np.broadcast_to(origin, (n, 3)).copy()
    last = np.full(n, -1, np.int64)
    offset = max(geom.scale * 1e-6, 1e-9)
    layers = 0
    for layers in range(1, MAX_ALPHA_LAYERS + 1):
        tri, ray, loc = geom.mesh.ray.intersects_id(origins[live], dirs[live], multiple_hits=False,
                                                    return_locations=True)
        if len(tri) == 0:
            break
        rays = live[ray]
        tri = np.asarray(tri, np.int64)
        stuck = last[rays] == tri  # re-hit the face we just left (float32 precision): step further
        b = trimesh.triangles.points_to_barycentric(geom.vertices[geom.faces[tri]], loc)
        part = geom.part_of_face[tri]
        transparent = np.zeros(len(tri), bool)
        for p in np.unique(part[geom.cut_out[part]]):
            sel = part == p
            st = geom.interp(geom.st, tri[sel], b[sel])
            transparent[sel] = sample_texture(geom.base_tex[p], st)[:, -1] < geom.threshold[p]  # cut_out: has alpha
        keep = ~(transparent | stuck)
        if layers == MAX_ALPHA_LAYERS:  # give up: keep what we have
            keep[:] = True
        face[rays[keep]] = tri[keep]
        point[rays[keep]] = loc[keep]
        bary[rays[keep]] = b[keep]
        go = rays[~keep]
        last[go] = tri[~keep]
        origins[go] = loc[~keep] + dirs[go] * offset * np.where(stuck[~keep], 10.0, 1.0)[:, None]
        live = go
        if live.size == 0:
            break
    stats["alpha_layers"] = int(layers)
    return face, point, bary


@dataclass(frozen=True)
class Hits:
    """The first opaque hit of every primary ray of one camera (:func:`cast_view`), R = width * height, row-major."""

    face: np.ndarray  # (R,) int64 index into the parts' concatenated triangles (scene.parts order), -1: a miss
    point: np.ndarray  # (R, 3) world position of the hit, metres (0 for a miss)
    bary: np.ndarray  # (R, 3) barycentric coordinates of the hit in its triangle (0 for a miss)
    stats: dict  # rays, alpha_layers (feather layers the rays passed through)


def camera_key(view) -> str:
    """sha256 of a view's camera pose, field of view and size, not its light (the light sweep shares one camera)."""
    return Digest().add("camera", [float(view.yfov_rad), int(view.width), int(view.height)]) \
        .add("pose", np.asarray(view.camera_to_world, np.float64)).hexdigest()


def ray_digest(scene) -> str:
    """sha256 of what the ray casts read from a scene: positions, triangles, and of textured (maybe alpha-tested)
    parts their ``st``, opacity thresholds and base-colour texture bytes; not the film, normals or colours."""
    d = Digest()
    for p in scene.parts:
        d.add(p.name, [bool(p.is_feather), float(p.opacity_threshold)])
        d.add("points", np.asarray(p.positions_m, np.float64)).add("triangles", np.asarray(p.triangles, np.int64))
        if p.base_colour_texture:
            d.add("st", np.asarray(p.st, np.float64)).file("alpha", p.base_colour_texture)
    return d.hexdigest()


def cast_view(geom: SceneGeometry, view) -> Hits:
    origin, dirs, _ = camera_rays(view)
    stats = {"rays": len(dirs)}
    face, point, bary = _first_opaque_hits(geom, origin, dirs, stats)
    return Hits(face, point, bary, stats)

"""The independent CPU reference render: ray casting plus the exact spectral thin-film model, no LUT.

For each :class:`pipeline.render.views.View` the reference casts one primary ray through every pixel centre
of the same pinhole camera as the GL renderer (OpenGL convention: the camera looks down its -Z, +Y up,
vertical field of view ``yfov_rad``, square pixels), finds the first surface with trimesh's ray queries
(Embree through embreex when installed: ``trimesh.ray.has_embree``), and shades it with the model of
docs/design.md, "Conventions":

- feather cards are alpha-tested: a hit where the feather base texture's alpha is below the part's
  ``opacity_threshold`` (0.5) is skipped and the ray continues from just behind it (up to
  :data:`MAX_ALPHA_LAYERS` layers, vectorised over all rays still travelling);
- normals, ``st`` and the film thickness are interpolated with the hit's barycentric coordinates;
  textures are sampled bilinearly, clamp-to-edge, texel centres at (k + 0.5) / N, t = 0 at the image's
  bottom (:func:`pipeline.render.scene.sample_texture`, the convention OpenGL uses);
- cards are two-sided: the interpolated ``N`` is flipped when ``dot(N, V) < 0``, so it faces the viewer
  (as ``materials/glsl/thinfilm.frag`` does); a feather part without a mask texture has mask 1;
- ``cos_theta = dot(L, H) = sqrt((1 + dot(L, V)) / 2)``, ``H = normalize(L + V)``;
- ``structural = exact spectral colour of the film at (cos_theta, thickness_nm)``;
  ``colour = mix(base_rgb, structural, mask)``; ``radiance = colour * light_rgb * max(dot(N, L), 0)``;
  other parts ``base_rgb * light_rgb * max(dot(N, L), 0)``; no ambient term.

The exact structural colour
---------------------------
The Airy reflectance of the film (Born and Wolf, Principles of Optics, 7th ed., section 7.6.1, eq. 58;
method.md step 1) is evaluated by :func:`pipeline.optics.reflectance` with the film read from the USD
(``n(lambda) = cauchyA + cauchyB_nm2 / lambda^2`` and the incident/substrate indices of
``RockDoveThinFilmAPI``), on a wavelength grid over 360-780 nm, and integrated to lin_rec709 with
:func:`pipeline.spectral.spectral_weights` (CIE 1931 2 degree observer, D65, normalised so that a perfect
reflector is Y = 1). The wavelength step depends on cos_theta, because near grazing incidence both Fresnel
coefficients tend to -1 and the film becomes a high-finesse resonator whose spectrum is a comb of sharp
lines: :data:`SPECTRAL_STEPS_NM` gives the step per cos_theta band. Measured (keratin film, 450-720 nm,
random samples per band, dE2000 of the displayed colour against a 0.004-0.02 nm integration): 2 nm errs
<= 0.0056 for cos_theta >= 0.08 (0.026 at 0.03-0.08), 1 nm <= 0.0033 at 0.03-0.08, 0.5 nm <= 0.0013 at 0.01-0.03,
0.1 nm <= 0.0001 at 0.003-0.01, 0.05 nm <= 0.0001 at 0.001-0.003, 0.01 nm <= 0.005 below 0.001 (where even
the comparison grid barely resolves the lines; the colour tends to white there). Every band stays below
0.01 dE2000, two orders of magnitude under the verification goal (checked by ``tests/test_reference.py::
test_spectral_step_is_exact_against_a_finer_grid``). Pixels are de-duplicated on quantised
``(cos_theta, thickness_nm)`` keys (steps :data:`COS_THETA_QUANTUM`, :data:`THICKNESS_QUANTUM_NM`): the film
phase ``4 pi n d cos(theta_b) / lambda`` changes by less than 5e-5 rad within one key, far below anything
visible (measured < 0.005 dE2000), so this is still the exact model per pixel, not an interpolated table.

Lighting models (``lobe``, :data:`LOBES`; the hosts of :mod:`pipeline.hosts` name theirs):

- ``"half_angle"`` (the default, above): the paper's model under the View's one directional light;
- ``"view_angle"``: the smooth film's mirror lobe alone under a uniform white environment of unit radiance.
  For a smooth film the mirror direction makes the angle of incidence the view angle, so the film lit by
  the environment from the mirror direction reflects ``R(|N.V|)`` of unit radiance: a feather pixel is
  ``mask * structural(cos_theta = |N.V|)``; no light, base colour black (diffuse off), other parts 0.
  This is what the MaterialX baked network (``LUT(|N.V|)``) and the hosts' own thin-film BSDFs draw under
  that environment with the base colour set to black. Both lobes of one call share the ray casts
  (:func:`render_reference_lobes`).

The PNGs use the GL path's tone mapping (:func:`pipeline.spectral.linear_to_srgb8`); the comparison uses the linear data.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field

import numpy as np

#: Feather layers a ray may pass through (alpha-cut-out parts) before the reference gives up and keeps the
#: last hit. Overlapping neck feathers are rarely more than a few layers deep where their alpha is < 0.5.
MAX_ALPHA_LAYERS = 24
#: Wavelength range of the spectral integral, nm (the CIE 1931 2 degree CMFs are negligible outside).
WAVELENGTH_RANGE_NM = (360.0, 780.0)
#: Wavelength step per cos_theta band: ``(cos_theta_lo, step_nm)``; a pixel uses the step of the last
#: band whose lower bound it reaches. See the module docstring for how they were chosen.
SPECTRAL_STEPS_NM = ((0.0, 0.01), (0.001, 0.05), (0.003, 0.1), (0.01, 0.5), (0.03, 1.0), (0.08, 2.0))
#: De-duplication keys (see module docstring).
COS_THETA_QUANTUM = 2e-6
THICKNESS_QUANTUM_NM = 0.002
#: Pixels per chunk of the spectral evaluation (bounds memory: chunk x wavelengths x 8 bytes per array).
SPECTRAL_CHUNK = 4096
#: The lighting models the reference renders (module docstring, "Lighting models").
LOBES = ("half_angle", "view_angle")


@dataclass
class ReferenceResult:
    """The reference render of one view.

    Attributes
    ----------
    view : str
    rgb : ndarray, (H, W, 3) float32
        Linear lin_rec709 radiance (light_rgb = (1, 1, 1) is D65 white); 0 on the background.
    coverage : ndarray, (H, W) bool
        A surface was hit.
    part_id : ndarray, (H, W) int32
        ``index + 1`` of the part in ``scene.parts`` (0 = background), as the GL renderer numbers them.
    depth_m : ndarray, (H, W) float32
        Eye-space depth (distance along the camera's -Z), metres; +inf on the background.
    n_dot_l : ndarray, (H, W) float32
        ``max(dot(N, L), 0)`` of the shaded surface (0 on the background); with the ``view_angle`` lobe, 1 on
        feather pixels (lit by the environment) and 0 elsewhere.
    cos_theta : ndarray, (H, W) float32
        ``dot(L, H)`` (``|dot(N, V)|`` with the ``view_angle`` lobe) on feather pixels, NaN elsewhere.
    thickness_nm : ndarray, (H, W) float32
        Interpolated film thickness on feather pixels, NaN elsewhere.
    mask : ndarray, (H, W) float32
        Structural-colour mask on feather pixels, 0 elsewhere.
    timings_s : dict
        Wall time of the stages (``rays``, ``spectral``, ``shade``), seconds.
    stats : dict
        Counts: rays, hits, alpha layers used, spectral evaluations, de-duplicated keys.
    """

    view: str
    rgb: np.ndarray
    coverage: np.ndarray
    part_id: np.ndarray
    depth_m: np.ndarray
    n_dot_l: np.ndarray
    cos_theta: np.ndarray
    thickness_nm: np.ndarray
    mask: np.ndarray
    timings_s: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)

    @property
    def display8(self) -> np.ndarray:
        """(H, W, 3) uint8 sRGB image of :attr:`rgb` (:func:`pipeline.spectral.linear_to_srgb8`)."""
        from ..spectral import linear_to_srgb8

        return linear_to_srgb8(self.rgb)


# -- exact structural colour -------------------------------------------------------------------------------
def _wavelengths(step_nm: float) -> np.ndarray:
    lo, hi = WAVELENGTH_RANGE_NM
    n = int(round((hi - lo) / step_nm)) + 1
    return np.linspace(lo, hi, n)


def _weights(step_nm: float):
    """(wavelengths (n,), weights (n, 3)) such that ``rgb = R(lambda) @ weights``; cached per step."""
    from .. import spectral

    key = float(step_nm)
    if key not in _WEIGHTS_CACHE:
        wl = _wavelengths(step_nm)
        w = np.asarray(spectral.spectral_weights(wl, colour_space="lin_rec709"), dtype=np.float64)
        if w.shape != (len(wl), 3):
            raise ValueError(f"spectral_weights returned shape {w.shape}, expected {(len(wl), 3)}")
        w.setflags(write=False)
        _WEIGHTS_CACHE[key] = (wl, w)
    return _WEIGHTS_CACHE[key]


_WEIGHTS_CACHE: dict = {}


def film_indices(film):
    """``(n_film(lambda) callable, n_incident, n_substrate)`` of a :class:`~pipeline.render.scene.ThinFilmParams`."""
    return film.film_index, float(film.incident_index), float(film.substrate_index)


def structural_rgb_at_step(cos_theta, thickness_nm, film, step_nm: float) -> np.ndarray:
    """Exact film colour integrated on a uniform wavelength grid of ``step_nm``.

    Parameters
    ----------
    cos_theta : ndarray, (P,)
        Cosine of the angle of incidence on the film, in the incident medium, in [0, 1].
    thickness_nm : ndarray, (P,)
        Film thickness, nm.
    film : ThinFilmParams
        Film indices (see :func:`film_indices`).
    step_nm : float
        Wavelength step over :data:`WAVELENGTH_RANGE_NM`.

    Returns
    -------
    ndarray, (P, 3) float64, linear lin_rec709 (unclipped).
    """
    from .. import optics

    cos_theta = np.asarray(cos_theta, np.float64).reshape(-1)
    thickness_nm = np.asarray(thickness_nm, np.float64).reshape(-1)
    wl, w = _weights(step_nm)
    n_film, n_inc, n_sub = film_indices(film)
    n_wl = n_film(wl)[None, :]
    out = np.empty((cos_theta.size, 3))
    chunk = max(1, int(SPECTRAL_CHUNK * 421 / len(wl)))
    for s in range(0, cos_theta.size, chunk):
        c = cos_theta[s : s + chunk, None]
        d = thickness_nm[s : s + chunk, None]
        refl = optics.reflectance(wl[None, :], c, d, n_film=n_wl, n_incident=n_inc, n_substrate=n_sub)
        out[s : s + chunk] = refl @ w
    return out


def spectral_step_nm(cos_theta) -> np.ndarray:
    """Wavelength step (nm) used at each ``cos_theta`` (:data:`SPECTRAL_STEPS_NM`), same shape."""
    c = np.asarray(cos_theta, np.float64)
    step = np.full(c.shape, SPECTRAL_STEPS_NM[0][1])
    for lo, s in SPECTRAL_STEPS_NM[1:]:
        step = np.where(c >= lo, s, step)
    return step


def structural_rgb(cos_theta, thickness_nm, film, stats: dict | None = None) -> np.ndarray:
    """Exact structural colour per pixel, de-duplicated on fine keys and with a cos_theta-dependent step.

    Parameters
    ----------
    cos_theta : ndarray, (P,), in [0, 1]
    thickness_nm : ndarray, (P,), nm, >= 0
    film : ThinFilmParams
    stats : dict, optional
        Receives ``spectral_pixels`` and ``spectral_keys``.

    Returns
    -------
    ndarray, (P, 3) float64, linear lin_rec709.
    """
    c = np.clip(np.asarray(cos_theta, np.float64).reshape(-1), 0.0, 1.0)
    d = np.asarray(thickness_nm, np.float64).reshape(-1)
    if c.shape != d.shape:
        raise ValueError(f"cos_theta {c.shape} and thickness_nm {d.shape} must have the same length")
    if not (np.all(np.isfinite(d)) and np.all(d >= 0)):
        raise ValueError(f"thickness_nm must be finite and >= 0, got min {np.nanmin(d) if d.size else 'n/a'}")
    out = np.zeros((c.size, 3))
    if c.size == 0:
        return out
    keys = np.stack([np.round(c / COS_THETA_QUANTUM), np.round(d / THICKNESS_QUANTUM_NM)], axis=1).astype(np.int64)
    uniq, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    uc = np.clip(uniq[:, 0] * COS_THETA_QUANTUM, 0.0, 1.0)
    ud = uniq[:, 1] * THICKNESS_QUANTUM_NM
    urgb = np.empty((len(uniq), 3))
    steps = spectral_step_nm(uc)
    for s in np.unique(steps):
        sel = steps == s
        urgb[sel] = structural_rgb_at_step(uc[sel], ud[sel], film, float(s))
    if stats is not None:
        stats["spectral_pixels"] = stats.get("spectral_pixels", 0) + int(c.size)
        stats["spectral_keys"] = stats.get("spectral_keys", 0) + int(len(uniq))
    return urgb[inverse]


# -- ray casting -------------------------------------------------------------------------------------------
def camera_rays(view):
    """Primary rays through the pixel centres of ``view``'s pinhole camera.

    Returns
    -------
    origin : ndarray, (3,) world metres
    directions : ndarray, (H * W, 3) unit world directions, row-major from the top-left pixel
    forward : ndarray, (3,) the camera's viewing axis (its -Z) in world space
    """
    h, w = view.height, view.width
    tan_half = np.tan(0.5 * view.yfov_rad)
    aspect = w / h
    x = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * tan_half * aspect
    y = (1.0 - 2.0 * (np.arange(h) + 0.5) / h) * tan_half
    xx, yy = np.meshgrid(x, y)
    d_cam = np.stack([xx, yy, -np.ones_like(xx)], axis=-1).reshape(-1, 3)
    m = np.asarray(view.camera_to_world, np.float64)
    d = d_cam @ m[:3, :3].T
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    fwd = -m[:3, 2] / np.linalg.norm(m[:3, 2])
    return m[:3, 3].copy(), d, fwd


class _SceneGeometry:
    """All parts in one trimesh for ray queries, plus per-face part index and the loaded textures."""

    def __init__(self, scene):
        import trimesh

        from .scene import read_texture

        verts, faces, part_of_face, offset = [], [], [], 0
        for i, p in enumerate(scene.parts):
            verts.append(np.asarray(p.positions_m, np.float64))
            faces.append(np.asarray(p.triangles, np.int64) + offset)
            part_of_face.append(np.full(len(p.triangles), i, np.int32))
            offset += len(p.positions_m)
        self.vertices = np.concatenate(verts)
        self.faces = np.concatenate(faces)
        self.part_of_face = np.concatenate(part_of_face)
        self.face_offset = np.concatenate([[0], np.cumsum([len(p.triangles) for p in scene.parts])])
        self.mesh = trimesh.Trimesh(self.vertices, self.faces, process=False)
        self.normals = np.concatenate([np.asarray(p.normals, np.float64) for p in scene.parts])
        self.st = np.concatenate([np.asarray(p.st, np.float64) for p in scene.parts])
        self.thickness = np.concatenate(
            [np.asarray(p.thickness_nm, np.float64) if p.thickness_nm is not None else np.zeros(len(p.positions_m))
             for p in scene.parts]
        )
        self.is_feather = np.array([p.is_feather for p in scene.parts])
        self.threshold = np.array([p.opacity_threshold for p in scene.parts])
        self.base_tex, self.mask_tex = [], []
        for p in scene.parts:
            base = p.base_colour_texture
            self.base_tex.append(read_texture(base, p.base_colour_srgb) if base else None)
            self.mask_tex.append(read_texture(p.mask_texture, False) if p.mask_texture else None)
        self.base_const = [np.asarray(p.base_colour, np.float64) for p in scene.parts]
        self.scale = float(np.linalg.norm(self.vertices.max(axis=0) - self.vertices.min(axis=0)))

    def barycentric(self, face, points):
        import trimesh

        return trimesh.triangles.points_to_barycentric(self.vertices[self.faces[face]], points)

    def interp(self, attr, face, bary):
        return np.einsum("nk,nk...->n...", bary, attr[self.faces[face]])

    def alpha(self, part, st):
        tex = self.base_tex[part]
        if tex is None or tex.shape[2] not in (2, 4):
            return np.ones(len(st))
        from .scene import sample_texture

        return sample_texture(tex, st)[:, -1]


def _first_opaque_hits(geom: _SceneGeometry, origin, dirs, stats: dict):
    """First hit along each ray that is not an alpha-cut-out feather fragment.

    Returns
    -------
    face : (R,) int64, -1 for a miss; point : (R, 3); bary : (R, 3)
    """
    n = len(dirs)
    face = np.full(n, -1, np.int64)
    point = np.zeros((n, 3))
    bary = np.zeros((n, 3))
    live = np.arange(n)
    origins = np.broadcast_to(origin, (n, 3)).copy()
    last = np.full(n, -1, np.int64)
    offset = max(geom.scale * 1e-6, 1e-9)
    layers = 0
    for layers in range(1, MAX_ALPHA_LAYERS + 1):
        tri, ray, loc = geom.mesh.ray.intersects_id(
            origins[live], dirs[live], multiple_hits=False, return_locations=True
        )
        if len(tri) == 0:
            break
        rays = live[ray]
        tri = np.asarray(tri, np.int64)
        stuck = last[rays] == tri  # re-hit the face we just left (float32 precision): step further
        b = geom.barycentric(tri, loc)
        part = geom.part_of_face[tri]
        transparent = np.zeros(len(tri), bool)
        for p in np.unique(part[geom.is_feather[part]]):
            sel = part == p
            st = geom.interp(geom.st, tri[sel], b[sel])
            transparent[sel] = geom.alpha(p, st) < geom.threshold[p]
        transparent |= stuck
        keep = ~transparent
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
    """The first opaque hit of every primary ray of one camera (:func:`cast_hits`): what the geometry and the
    camera decide, before any shading, so it can be cached across film changes.

    Attributes
    ----------
    face : ndarray, (R,) int64
        Index into the scene's concatenated triangles (parts in ``scene.parts`` order), -1 for a miss;
        R = width * height, row-major from the top-left pixel.
    point : ndarray, (R, 3) float64
        World position of the hit, metres (0 for a miss).
    bary : ndarray, (R, 3) float64
        Barycentric coordinates of the hit in its triangle (0 for a miss).
    stats : dict
        ``rays`` and ``alpha_layers`` (feather layers the rays passed through).
    """

    face: np.ndarray
    point: np.ndarray
    bary: np.ndarray
    stats: dict

    def to_arrays(self) -> dict:
        """Compact arrays for storage (the hit rays only; exact round trip through :meth:`from_arrays`)."""
        hit = np.nonzero(self.face >= 0)[0]
        return {"n_rays": np.int64(self.face.size), "hit": hit.astype(np.int64), "face": self.face[hit],
                "point": self.point[hit], "bary": self.bary[hit]}

    @classmethod
    def from_arrays(cls, arrays, stats: dict) -> "Hits":
        n, hit = int(arrays["n_rays"]), np.asarray(arrays["hit"], np.int64)
        face = np.full(n, -1, np.int64)
        point, bary = np.zeros((n, 3)), np.zeros((n, 3))
        face[hit], point[hit], bary[hit] = arrays["face"], arrays["point"], arrays["bary"]
        return cls(face, point, bary, dict(stats))


def camera_key(view) -> str:
    """sha256 of what a view's primary rays depend on: its camera pose, vertical field of view and size (not
    its light). Views that share a camera (the light sweep) share their :class:`Hits`."""
    m = np.ascontiguousarray(view.camera_to_world, np.float64)
    head = f"{float(view.yfov_rad)!r}:{int(view.width)}x{int(view.height)}:".encode()
    return hashlib.sha256(head + m.tobytes()).hexdigest()


def ray_digest(scene) -> str:
    """sha256 of what the ray casts read from a scene: every part's positions and triangles, which parts are
    alpha-tested feathers, their ``st``, opacity thresholds and base-colour texture bytes (the alpha). Not the
    film, the LUT, normals, masks or colours: a film change leaves it, and so the cached :class:`Hits`, as
    they were."""
    h = hashlib.sha256()
    for p in scene.parts:
        h.update(f"{p.name}:{bool(p.is_feather)}:{float(p.opacity_threshold)!r}\0".encode())
        arrays = [np.asarray(p.positions_m, np.float64), np.asarray(p.triangles, np.int64)]
        if p.is_feather:
            arrays.append(np.asarray(p.st, np.float64))
        for a in arrays:
            h.update(f"{a.shape}".encode() + np.ascontiguousarray(a).tobytes())
        if p.is_feather and p.base_colour_texture:
            with open(p.base_colour_texture, "rb") as f:
                h.update(f.read())
    return h.hexdigest()


def cast_hits(scene, views) -> dict:
    """Cast the primary rays of every distinct camera among ``views``: ``{camera_key(view): Hits}``."""
    geom = _SceneGeometry(scene)
    out: dict = {}
    for v in views:
        key = camera_key(v)
        if key not in out:
            out[key] = _cast(geom, v)
    return out


def _cast(geom: "_SceneGeometry", view) -> Hits:
    origin, dirs, _ = camera_rays(view)
    stats = {"rays": int(len(dirs))}
    face, point, bary = _first_opaque_hits(geom, origin, dirs, stats)
    return Hits(face, point, bary, stats)


def render_reference(scene, views, structural_fn=None, hits=None, lobe: str = "half_angle") -> list[ReferenceResult]:
    """Render ``views`` of ``scene`` on the CPU with the exact spectral thin-film model.

    Parameters
    ----------
    scene : pipeline.render.scene.RenderScene
        The asset read back from USD.
    views : sequence of pipeline.render.views.View
    structural_fn : callable, optional
        ``f(cos_theta (P,), thickness_nm (P,)) -> (P, 3)`` lin_rec709; default the exact model of
        :func:`structural_rgb` for ``scene.film`` (tests may substitute a simpler one).
    hits : mapping, optional
        Ready-made :class:`Hits` by :func:`camera_key` (e.g. cached by the build for this scene's
        :func:`ray_digest`); cameras not in it are cast here. Either way the result is the same.
    lobe : str
        The lighting model, one of :data:`LOBES` (module docstring).

    Returns
    -------
    list of ReferenceResult, one per view, in order.

    Raises
    ------
    ValueError
        ``views`` is empty, or the scene has feathers but no thin-film parameters.
    """
    return render_reference_lobes(scene, views, (lobe,), structural_fn, hits=hits)[lobe]


def render_reference_lobes(scene, views, lobes=LOBES, structural_fn=None, hits=None) -> dict:
    """:func:`render_reference` for several lighting models at once, sharing the scene's ray casts.

    Returns
    -------
    dict
        lobe -> list of ReferenceResult (one per view, in order).
    """
    lobes = tuple(dict.fromkeys(lobes))
    bad = [lb for lb in lobes if lb not in LOBES]
    if bad or not lobes:
        raise ValueError(f"lobe: {bad or lobes!r} not allowed; use one of {list(LOBES)}")
    views = list(views)
    if not views:
        raise ValueError("views must hold at least one View, got none")
    has_feathers = any(p.is_feather for p in scene.parts)
    if structural_fn is None:
        if has_feathers and scene.film is None:
            raise ValueError(f"scene {scene.root_layer!r} has feather parts but no RockDoveThinFilmAPI film")
    geom = _SceneGeometry(scene)
    hits_cache: dict = dict(hits or {})  # the light sweep keeps its camera still: cast its rays once
    return {lb: [_render_view(geom, scene, v, structural_fn, hits_cache, lb) for v in views] for lb in lobes}


def _render_view(geom: _SceneGeometry, scene, view, structural_fn, hits_cache: dict,
                 lobe: str = "half_angle") -> ReferenceResult:
    from .scene import sample_texture

    t0 = time.perf_counter()
    h, w = view.height, view.width
    key = camera_key(view)
    if key not in hits_cache:
        hits_cache[key] = _cast(geom, view)
    origin, dirs, fwd = camera_rays(view)
    face, point, bary = hits_cache[key].face, hits_cache[key].point, hits_cache[key].bary
    stats = dict(hits_cache[key].stats)
    t1 = time.perf_counter()

    hit = np.nonzero(face >= 0)[0]
    stats["hits"] = int(hit.size)
    f, b = face[hit], bary[hit]
    part = geom.part_of_face[f]
    V = -dirs[hit]
    L = np.asarray(view.light_direction, np.float64)
    L = L / np.linalg.norm(L)
    light = np.asarray(view.light_rgb, np.float64)
    N = geom.interp(geom.normals, f, b)
    N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-30)
    feather = geom.is_feather[part]
    back = np.einsum("ij,ij->i", N, V) < 0
    N[feather & back] *= -1.0  # two-sided cards: the (interpolated) normal faces the viewer, as in the GLSL
    st = geom.interp(geom.st, f, b)
    base = np.empty((hit.size, 3))
    mask = np.zeros(hit.size)
    for p in np.unique(part):
        sel = part == p
        tex = geom.base_tex[p]
        if tex is None:
            base[sel] = geom.base_const[p][None, :]
        else:
            rgb = sample_texture(tex, st[sel])
            base[sel] = rgb[:, :3] if tex.shape[2] >= 3 else np.repeat(rgb[:, :1], 3, axis=1)
        if geom.is_feather[p]:  # a feather without a mask texture is structural everywhere (mask = 1)
            tex = geom.mask_tex[p]
            mask[sel] = sample_texture(tex, st[sel])[:, 0] if tex is not None else 1.0
    view_angle = lobe == "view_angle"
    if view_angle:  # mirror lobe under a uniform unit environment: incidence = view angle; base black
        cos_theta = np.clip(np.abs(np.einsum("ij,ij->i", N, V)), 0.0, 1.0)
        base = np.zeros_like(base)
    else:
        cos_theta = np.sqrt(np.clip((1.0 + V @ L) / 2.0, 0.0, 1.0))
    thickness = geom.interp(geom.thickness, f, b)
    colour = base.copy()
    structural = feather & (mask > 0)
    t2 = time.perf_counter()
    if structural.any():
        c, d = cos_theta[structural], thickness[structural]
        if structural_fn is None:
            s_rgb = structural_rgb(c, d, scene.film, stats)
        else:
            s_rgb = np.asarray(structural_fn(c, d), np.float64).reshape(-1, 3)
        m = mask[structural, None]
        colour[structural] = base[structural] * (1.0 - m) + s_rgb * m
    t3 = time.perf_counter()
    if view_angle:  # the environment lights every feather pixel with unit radiance; other parts are black
        n_dot_l = feather.astype(np.float64)
        radiance = colour * n_dot_l[:, None]
    else:
        n_dot_l = np.maximum(N @ L, 0.0)
        radiance = colour * light[None, :] * n_dot_l[:, None]

    def image(fill, values, dtype):
        out = np.full(h * w, fill, dtype) if np.ndim(values) == 1 else np.full((h * w, values.shape[1]), fill, dtype)
        out[hit] = values
        return out.reshape((h, w) + out.shape[1:])

    feather_cos = np.where(feather, cos_theta, np.nan)
    feather_d = np.where(feather, thickness, np.nan)
    res = ReferenceResult(
        view=view.name,
        rgb=image(0.0, radiance, np.float32),
        coverage=image(False, np.ones(hit.size, bool), bool),
        part_id=image(0, part + 1, np.int32),
        depth_m=image(np.inf, (point[hit] - origin) @ fwd, np.float32),
        n_dot_l=image(0.0, n_dot_l, np.float32),
        cos_theta=image(np.nan, feather_cos, np.float32),
        thickness_nm=image(np.nan, feather_d, np.float32),
        mask=image(0.0, np.where(feather, mask, 0.0), np.float32),
    )
    t4 = time.perf_counter()
    res.timings_s = {"rays": t1 - t0, "shade": (t2 - t1) + (t4 - t3), "spectral": t3 - t2, "total": t4 - t0}
    res.stats = stats
    return res

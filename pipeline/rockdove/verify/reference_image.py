"""The independent CPU reference images: the exact spectral thin-film model shaded per pixel, no LUT.

Each pixel's primary ray takes its first opaque hit (:mod:`rockdove.verify.rays`: the GL renderer's pinhole camera,
feather cards alpha-tested), shaded with the model of docs/design.md, "Conventions": normals, ``st`` and thickness
interpolated barycentrically; textures sampled as OpenGL does (:func:`rockdove.render.texture.sample_texture`);
two-sided cards (``N`` flipped to face the viewer, as ``materials/glsl/thinfilm.frag``; no mask texture: mask 1);
``cos_theta = dot(L, H) = sqrt((1 + dot(L, V)) / 2)``; ``colour = mix(base_rgb, structural, mask)``, ``radiance =
colour * light_rgb * max(dot(N, L), 0)``; other parts ``base_rgb * light_rgb * max(dot(N, L), 0)``; no ambient.

The structural colour is :func:`rockdove.lut.reference.reference_colour` (the Airy spectrum of the USD's film, to
lin_rec709 under D65) at each pixel's ``(cos_theta, thickness_nm)``: for real films from cos_theta 0.01 up, the
wavenumber interpolant :data:`IMAGE_INTERPOLATION` (:mod:`rockdove.lut.reference`, "Wavenumber interpolation": within
0.0008 dE2000 of a 0.02-0.05 nm integration, 9.6x faster on the default views); below, and for absorbing films, the
wavelength steps :data:`IMAGE_STEPS_NM` (product integration, :func:`rockdove.lut.reference.product_weights`),
validated up to :data:`IMAGE_STEPS_CALIBRATED_NM` of film and scaled down in proportion for thicker pixels (the phase
advances with thickness). Measured (keratin, 40 random samples per band, dE2000 of the displayed colour against a
0.002-0.02 nm integration, films of 450-720, 700-1000, 1500-2000 and 4000-5000 nm): 4 nm errs <= 0.0010 for cos_theta
>= 0.12 (0.011 at 0.08-0.12), 3 nm <= 0.0017 at 0.08-0.12, 2 nm <= 0.0016 at 0.05-0.08, 1 nm <= 0.0001 at 0.03-0.05,
0.5 nm <= 0.0003 at 0.01-0.03, 0.1 nm <= 0.0001 at 0.003-0.01, 0.05 nm <= 0.0001 at 0.001-0.003, 0.01 nm <= 0.0016
below: all under 0.01 dE2000 (``tests/test_reference.py::test_spectral_step_is_exact_against_a_finer_grid``). Pixels
are de-duplicated on keys quantised by :data:`COS_THETA_QUANTUM` and :data:`THICKNESS_QUANTUM_NM`: the film phase
``4 pi n d cos(theta_b) / lambda`` changes by under 5e-5 rad within a key (< 0.005 dE2000): still exact per pixel.

Lighting models (:data:`LOBES`, named by the hosts of :mod:`rockdove.hosts`): ``"half_angle"`` (the default, above)
under the View's one directional light; ``"view_angle"``, the smooth film's mirror lobe alone under a uniform white
environment of unit radiance: a feather pixel is ``mask * structural(cos_theta = |N.V|)``, other parts 0 (what the
MaterialX baked network, ``LUT(|N.V|)``, and the hosts' thin-film BSDFs draw with a black base colour). Lobes of one
call share the ray casts."""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import numpy as np

from ..digest import Digest
from ..errors import UsageError
from ..lut.reference import reference_colour
from ..render.texture import sample_texture
from .rays import SceneGeometry, camera_key, camera_rays, cast_view, ray_digest

#: Wavelength step per cos_theta band, ``(cos_theta_lo, step_nm)`` (:func:`rockdove.lut.reference.reference_step_nm`).
IMAGE_STEPS_NM = ((0.0, 0.01), (0.001, 0.05), (0.003, 0.1), (0.01, 0.5), (0.03, 1.0), (0.05, 2.0), (0.08, 3.0),
                  (0.12, 4.0))
#: The film thickness (nm) up to which :data:`IMAGE_STEPS_NM` was validated; thicker pixels scale their steps down.
IMAGE_STEPS_CALIBRATED_NM = 720.0
#: The wavenumber interpolant ``(cos_theta_lo, kappa, max_step_rad)`` and its stencil (``reference_colour``'s
#: ``interpolation`` and ``order``).
IMAGE_INTERPOLATION = (0.01, 0.35, 0.6)
IMAGE_INTERPOLANT_ORDER = 16
COS_THETA_QUANTUM = 2e-6
THICKNESS_QUANTUM_NM = 0.002
LOBES = ("half_angle", "view_angle")


@dataclass
class ReferenceResult:
    """The reference render of one view: (H, W) float32 images, linear lin_rec709 (light_rgb 1 = D65 white)."""

    view: str
    rgb: np.ndarray  # (H, W, 3) radiance, 0 on the background
    coverage: np.ndarray  # bool: a surface was hit
    part_id: np.ndarray  # int32, index + 1 in scene.parts (0 = background), as the GL renderer numbers them
    depth_m: np.ndarray  # eye-space depth along the camera's -Z; +inf on the background
    n_dot_l: np.ndarray  # max(dot(N, L), 0) (view_angle lobe: 1 on feathers), 0 on the background
    cos_theta: np.ndarray  # dot(L, H) (view_angle lobe: |dot(N, V)|) on feathers, NaN elsewhere
    thickness_nm: np.ndarray  # film thickness on feathers, NaN elsewhere
    mask: np.ndarray  # structural-colour mask on feathers, 0 elsewhere
    timings_s: dict = field(default_factory=dict)  # rays (with the Surface when not given), spectral, shade, total
    stats: dict = field(default_factory=dict)  # rays, hits, alpha layers, spectral pixels and keys


def structural_rgb(cos_theta, thickness_nm, film, stats: dict | None = None) -> np.ndarray:
    """Exact structural colour, (P, 3) lin_rec709, of (P,) ``cos_theta`` and ``thickness_nm`` for a
    :class:`rockdove.render.film.ThinFilmParams`, de-duplicated on fine keys; counted in ``stats``."""
    c = np.clip(np.asarray(cos_theta, np.float64).reshape(-1), 0.0, 1.0)
    d = np.asarray(thickness_nm, np.float64).reshape(-1)
    if c.shape != d.shape:
        raise UsageError(f"cos_theta {c.shape} and thickness_nm {d.shape} must have the same length")
    if not (np.all(np.isfinite(d)) and np.all(d >= 0)):
        raise UsageError(f"thickness_nm must be finite and >= 0, got min {np.nanmin(d) if d.size else 'n/a'}")
    if c.size == 0:
        return np.zeros((0, 3))
    kc = np.round(c / COS_THETA_QUANTUM).astype(np.int64)  # 0 .. 5e5
    kd = np.round(d / THICKNESS_QUANTUM_NM).astype(np.int64)
    stride = int(kd.max()) + 1  # one int64 key per (cos, d) pair: 1-D unique is several times faster
    uniq, inverse = np.unique(kc * stride + kd, return_inverse=True)
    uc = np.clip((uniq // stride) * COS_THETA_QUANTUM, 0.0, 1.0)
    ud = (uniq % stride) * THICKNESS_QUANTUM_NM
    urgb = reference_colour(uc, ud, film.model, colour_space="lin_rec709", steps_nm=IMAGE_STEPS_NM,
                            calibrated_thickness_nm=IMAGE_STEPS_CALIBRATED_NM, interpolation=IMAGE_INTERPOLATION,
                            order=IMAGE_INTERPOLANT_ORDER)
    if stats is not None:
        stats["spectral_pixels"] = stats.get("spectral_pixels", 0) + int(c.size)
        stats["spectral_keys"] = stats.get("spectral_keys", 0) + len(uniq)
    return urgb[inverse.reshape(-1)]


def render_reference(scene, views, structural_fn=None, lobe: str = "half_angle",
                     surfaces=None) -> list[ReferenceResult]:
    """:class:`ReferenceResult` of each of ``views`` of a :class:`rockdove.render.scene.RenderScene`, exact model.

    ``structural_fn``: ``f(cos_theta (P,), thickness_nm (P,)) -> (P, 3)`` in place of :func:`structural_rgb` (tests).
    ``surfaces``: ready-made :class:`Surface` by camera key (the build caches them); other cameras are cast here.
    ValueError for no views, or feathers without a film."""
    return render_reference_lobes(scene, views, (lobe,), structural_fn, surfaces=surfaces)[lobe]


def render_reference_lobes(scene, views, lobes=LOBES, structural_fn=None, surfaces=None) -> dict:
    """:func:`render_reference` for several lighting models sharing the ray casts: ``{lobe: [ReferenceResult]}``."""
    lobes = tuple(dict.fromkeys(lobes))
    bad = [lb for lb in lobes if lb not in LOBES]
    if bad or not lobes:
        raise UsageError(f"lobe: {bad or lobes!r} not allowed; use one of {list(LOBES)}")
    views = list(views)
    if not views:
        raise UsageError("views must hold at least one View, got none")
    if structural_fn is None and scene.film is None and any(p.is_feather for p in scene.parts):
        raise UsageError(f"scene {scene.root_layer!r} has feather parts but no RockDoveThinFilmAPI film")
    geometry = functools.cache(lambda: SceneGeometry(scene))  # not built when every camera's surface is given
    surface_cache: dict = dict(surfaces or {})  # the light sweep keeps its camera still: cast its rays once
    return {lb: [_render_view(geometry, scene, v, structural_fn, surface_cache, lb) for v in views]
            for lb in lobes}


#: The precision a :class:`Surface` keeps (computed in float64): its rounding (relative 6e-8) is below the
#: de-duplication keys; against float64 surfaces on the default asset's six views, radiance within 2.1e-6 and dE2000
#: within 0.0011 (dark pixels), inside the 0.005 budget, and half the cache (58 -> 30 MB).
SURFACE_DTYPE = np.float32


@dataclass(frozen=True)
class Surface:
    """What the reference shades at each of the P hit pixels of one camera before any light or film (a build caches
    it across film and light changes: :func:`surface_digest`)."""

    n_pixels: int  # width * height
    hit: np.ndarray  # int32 flat indices (row-major from the top-left) of the pixels hit
    part: np.ndarray  # int32 index in scene.parts of the part hit
    normal: np.ndarray  # unit interpolated normal, flipped towards the viewer on two-sided cards
    view_dir: np.ndarray  # unit direction to the camera, V
    base: np.ndarray  # linear base colour (texture sampled bilinearly, or the part's constant)
    mask: np.ndarray  # structural-colour mask (0 off the feathers)
    thickness_nm: np.ndarray  # interpolated film thickness (0 on parts without a film)
    depth_m: np.ndarray  # eye-space depth along the camera's -Z
    stats: dict  # the ray casts' rays and alpha_layers

    ARRAYS = ("hit", "part", "normal", "view_dir", "base", "mask", "thickness_nm", "depth_m")

    def to_arrays(self) -> dict:
        return {"n_pixels": np.int64(self.n_pixels), **{k: getattr(self, k) for k in self.ARRAYS}}

    @classmethod
    def from_arrays(cls, arrays, stats: dict) -> Surface:
        return cls(int(arrays["n_pixels"]), **{k: np.asarray(arrays[k]) for k in cls.ARRAYS}, stats=dict(stats))


def surface_digest(scene) -> str:
    """sha256 of what a :class:`Surface` reads from a scene (the ray casts' :func:`~rockdove.verify.rays.ray_digest`,
    normals, ``st``, thickness, base colours, textures); not the film or the LUT."""
    d = Digest().add("rays", ray_digest(scene))
    for p in scene.parts:
        d.add(p.name, [bool(p.base_colour_srgb), bool(p.double_sided), np.asarray(p.base_colour, np.float64).tolist()])
        for f in ("normals", "st", "thickness_nm"):
            if getattr(p, f) is not None:
                d.add(f, getattr(p, f))
        d.file("base", p.base_colour_texture).file("mask", p.mask_texture)
    return d.hexdigest()


def cast_surfaces(scene, views) -> dict:
    """``{camera_key(view): Surface}`` of the cameras of ``views``, their rays cast here."""
    geometry = functools.cache(lambda: SceneGeometry(scene))  # not built when there are no views
    return {key: _surface(geometry(), v) for key, v in {camera_key(v): v for v in views}.items()}


def _surface(geom, view) -> Surface:
    hits = cast_view(geom, view)
    face, point, bary = hits.face, hits.point, hits.bary
    hit = np.nonzero(face >= 0)[0]
    origin, dirs, fwd = camera_rays(view, hit)  # the rays of the hit pixels only
    f, b = face[hit], bary[hit]
    part = geom.part_of_face[f]
    V = -dirs
    N = geom.interp(geom.normals, f, b)
    N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-30)
    back = np.einsum("ij,ij->i", N, V) < 0
    N[geom.two_sided[part] & back] *= -1.0  # two-sided cards: the (interpolated) normal faces the viewer, as GLSL
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
    floats = {k: v.astype(SURFACE_DTYPE) for k, v in (("normal", N), ("view_dir", V), ("base", base), ("mask", mask),
              ("thickness_nm", geom.interp(geom.thickness, f, b)), ("depth_m", (point[hit] - origin) @ fwd))}
    return Surface(n_pixels=int(face.size), hit=hit.astype(np.int32), part=part.astype(np.int32), **floats,
                   stats=hits.stats)


def _render_view(geometry, scene, view, structural_fn, surface_cache: dict, lobe: str) -> ReferenceResult:
    t0 = time.perf_counter()
    h, w = view.height, view.width
    key = camera_key(view)
    if key not in surface_cache:
        surface_cache[key] = _surface(geometry(), view)
    srf = surface_cache[key]
    if srf.n_pixels != h * w:
        raise UsageError(f"the surface of camera {key[:12]} holds {srf.n_pixels} pixels, view {view.name!r} {h * w}")
    stats = dict(srf.stats)
    t1 = time.perf_counter()

    hit, part = srf.hit, srf.part
    N, V = srf.normal.astype(np.float64), srf.view_dir.astype(np.float64)  # shaded in double precision
    stats["hits"] = int(hit.size)
    feather = np.array([p.is_feather for p in scene.parts], bool)[part]
    L = np.asarray(view.light_direction, np.float64) / np.linalg.norm(view.light_direction)
    light = np.asarray(view.light_rgb, np.float64)
    base, mask = srf.base.astype(np.float64), srf.mask.astype(np.float64)
    if lobe == "view_angle":  # mirror lobe under a uniform unit environment: incidence = view angle; base black;
        # every feather pixel lit with unit radiance, other parts black
        cos_theta = np.clip(np.abs(np.einsum("ij,ij->i", N, V)), 0.0, 1.0)
        base, n_dot_l, light = np.zeros_like(base), feather.astype(np.float64), np.ones(3)
    else:
        cos_theta = np.sqrt(np.clip((1.0 + V @ L) / 2.0, 0.0, 1.0))
        n_dot_l = np.maximum(N @ L, 0.0)
    thickness = srf.thickness_nm.astype(np.float64)
    colour = base.copy()
    structural = feather & (mask > 0)
    t2 = time.perf_counter()
    if structural.any():
        c, d = cos_theta[structural], thickness[structural]
        s_rgb = (structural_rgb(c, d, scene.film, stats) if structural_fn is None
                 else np.asarray(structural_fn(c, d), np.float64).reshape(-1, 3))
        m = mask[structural, None]
        colour[structural] = base[structural] * (1.0 - m) + s_rgb * m
    t3 = time.perf_counter()
    radiance = colour * light[None, :] * n_dot_l[:, None]

    def image(fill, values, dtype=np.float32):
        out = np.full((h * w,) + np.shape(values)[1:], fill, dtype)
        out[hit] = values
        return out.reshape((h, w) + out.shape[1:])

    images = (image(0.0, radiance), image(False, True, bool), image(0, part + 1, np.int32), image(np.inf, srf.depth_m),
              image(0.0, n_dot_l), image(np.nan, np.where(feather, cos_theta, np.nan)),
              image(np.nan, np.where(feather, thickness, np.nan)), image(0.0, np.where(feather, mask, 0.0)))
    t4 = time.perf_counter()
    return ReferenceResult(view.name, *images, timings_s={"rays": t1 - t0, "shade": (t2 - t1) + (t4 - t3),
                                                          "spectral": t3 - t2, "total": t4 - t0}, stats=stats)

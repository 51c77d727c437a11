"""The beauty render's GL path (:mod:`rockdove.render.beauty`) where Blender is not installed: the verification's
shaders (:class:`rockdove.render.gl.GLRenderer`), whose radiance is linear in each light, with the look built around
them in linear light:

- the ground (:func:`rockdove.render.beauty.cyclorama`) is one more Lambert part of neutral grey;
- the key: one render under the sun (``light_rgb`` = its irradiance / pi, as Cycles' sun of that strength lights a
  Lambert surface), times its visibility from a shadow map (:func:`_visibility`: percentage-closer soft shadows,
  R. Fernando, "Percentage-Closer Soft Shadows", SIGGRAPH 2005 sketch);
- the sky: :data:`SKY_LIGHTS` unshadowed directional lights (:func:`_sky_lights`);
- anti-aliasing: the key at :data:`SUPERSAMPLE` x the size, its shadow looked up at each sample, box-filtered;
  mip-mapped textures (the coat's feather tiles showed moire);
- exposed, put through a filmic curve (K. Narkowicz, "ACES Filmic Tone Mapping Curve", 2016) and the sRGB OETF.

What these choices were measured against (a 16-sample render; shadow rays): docs/pictures.md."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from . import beauty as B
from .views import View, direction, look_at

#: Samples of each picture pixel per axis (anti-aliasing of the edges: the shaders sample pixel centres).
SUPERSAMPLE = 2
#: Directional lights standing in for the sky: a ring at 35 degrees elevation and the zenith.
SKY_LIGHTS = 3
#: Shadow map: largest size in pixels (a texel ~0.2 mm on the default bird), field of view of the sun camera
#: (degrees), constant depth bias (metres) and PCF taps.
SHADOW_PX = 2048
SHADOW_FOV_DEG = 2.0
SHADOW_BIAS_M = 0.0003
SHADOW_TAPS = 16
#: Slope-scaled depth bias: texels of depth per unit of slope (tan of the angle between the receiver's normal and
#: the sun), up to a slope of SHADOW_SLOPE_MAX.
SHADOW_SLOPE_TEXELS = 1.5
SHADOW_SLOPE_MAX = 4.0
#: Occluders nearer a point than this (metres) cast a penumbra narrower than a shadow-map texel (the sun's 4 degrees
#: widen it by 3.5 % of their distance): a PCF over one texel; the farther ones' penumbra is estimated (PCSS).
SHADOW_CONTACT_M = 0.012
#: Exposure of the linear picture before the curve (stops; the curve's middle grey is ~0.18 -> 0.45).
EXPOSURE = 0.3


def _ground_part(scene, views):
    from .scene import ScenePart
    from .triangulate import vertex_normals

    verts, quads = B.cyclorama(scene, views)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]).astype(np.int32)
    return ScenePart(name="BeautyGround", path="/BeautyGround", material_kind="ground",
                     positions_m=verts.astype(np.float32), normals=vertex_normals(verts, tris), triangles=tris,
                     st=np.zeros((len(verts), 2), np.float32), base_colour=np.full(3, B.GROUND_ALBEDO, np.float32))


def _sky_lights() -> list[tuple[np.ndarray, np.ndarray]]:
    """(direction, weight x colour) of the sky's lights: a Lambert surface lit by them shows albedo x the sky's
    radiance (strength x colour) when horizontal (sum of weight x sin(elevation) = 1), as under Cycles' world."""
    dirs = [direction(60.0 + 360.0 * k / SKY_LIGHTS, 35.0) for k in range(SKY_LIGHTS)] + [np.array([0.0, 1.0, 0.0])]
    horizon, zenith = np.asarray(B.SKY_HORIZON_RGB), np.asarray(B.SKY_ZENITH_RGB)
    rgb = [0.5 * (horizon + zenith)] * SKY_LIGHTS + [zenith]
    total = sum(d[1] for d in dirs)
    return [(d, c * B.SKY_STRENGTH / total) for d, c in zip(dirs, rgb)]


def _pixel_rays(view: View) -> np.ndarray:
    """World directions through the pixel centres, scaled to unit length along the camera's axis, (H, W, 3)."""
    w, h = view.width, view.height
    ty = math.tan(view.yfov_rad / 2)
    tx = ty * w / h
    x = (2 * (np.arange(w) + 0.5) / w - 1) * tx
    y = (1 - 2 * (np.arange(h) + 0.5) / h) * ty
    cam = np.stack(np.broadcast_arrays(x[None, :], y[:, None], -np.ones((h, w))), -1)
    return cam @ view.camera_to_world[:3, :3].T


def _sun_camera(scene, sun_dir, px: int = SHADOW_PX) -> View:
    """A far camera looking down the sun's rays at the bird, its bounding sphere filling its ``px`` x ``px``."""
    b = scene.bounds_m
    centre, radius = b.mean(axis=0), 0.5 * float(np.linalg.norm(b[1] - b[0]))
    dist = 1.05 * radius / math.tan(math.radians(SHADOW_FOV_DEG) / 2)
    eye = centre + dist * np.asarray(sun_dir)
    up = (0.0, 0.0, 1.0) if abs(sun_dir[1]) > 0.99 else (0.0, 1.0, 0.0)
    return View("sun", look_at(eye, centre, up), math.radians(SHADOW_FOV_DEG), px, px, sun_dir, (1.0, 1.0, 1.0))


def _visibility(points, slope, sun: View, depth_map, texel_m: float, reach_m: float) -> np.ndarray:
    """Fraction of the sun each world point (N, 3) sees: PCSS over ``depth_map`` (the sun camera's view depth,
    0 where nothing was drawn), occluders searched up to ``reach_m`` away along the rays, nearer the sun than the
    point by more than the depth bias: :data:`SHADOW_BIAS_M` plus :data:`SHADOW_SLOPE_TEXELS` texels times
    ``slope``, the tan of the angle between the receiver's normal and the sun (slope-scaled bias: a receiver
    turned from the sun spans more depth per texel). Points nearer the sun than every texel within the widest
    penumbra (a minimum filter of the map) are lit without a search."""
    from scipy.ndimage import minimum_filter

    w2c = np.linalg.inv(sun.camera_to_world)
    q = points @ w2c[:3, :3].T + w2c[:3, 3]
    depth = -q[:, 2]
    t, n = math.tan(sun.yfov_rad / 2), sun.width
    u = (q[:, 0] / (depth * t) + 1) * 0.5 * n - 0.5
    v = (1 - q[:, 1] / (depth * t)) * 0.5 * n - 0.5
    half = math.tan(math.radians(B.SUN_ANGLE_DEG) / 2)
    search = max(1.0, reach_m * half / texel_m)  # the widest penumbra, texels
    pad = int(search) + 2  # the map framed by nothing (inf), as wide as a tap reaches
    m = np.pad(np.where(depth_map > 0, depth_map, np.inf), pad, constant_values=np.inf).ravel()
    nearest = minimum_filter(m.reshape(n + 2 * pad, -1), size=2 * int(search) + 3).ravel()
    u, v, w = u + pad, v + pad, n + 2 * pad

    def texel(img, du, dv, sel):  # the nearest texel; off the map: inf
        iu, iv = (np.clip(np.rint(x[sel] + dx), 0, w - 1).astype(np.intp) for x, dx in ((u, du), (v, dv)))
        return img[iv * w + iu]

    vis = np.ones(len(points))
    bias = SHADOW_BIAS_M + SHADOW_SLOPE_TEXELS * texel_m * np.minimum(slope, SHADOW_SLOPE_MAX)
    sel = np.flatnonzero(texel(nearest, 0, 0, slice(None)) < depth - bias)
    if not len(sel):
        return vis
    k = np.arange(SHADOW_TAPS)
    disc = np.stack([np.cos(k * 2.39996323), np.sin(k * 2.39996323)], 1) * np.sqrt((k + 0.5) / SHADOW_TAPS)[:, None]
    near, far = depth[sel] - bias[sel], depth[sel] - SHADOW_CONTACT_M  # occluders: d < near; far ones: d < far

    def taps(radius):  # the depth map over a disc of ``radius`` texels (Vogel's golden-angle disc), (taps, N)
        return np.stack([texel(m, radius * x, radius * y, sel) for x, y in disc])

    d = taps(1.0)
    contact = ((d < near) & (d >= far)).mean(axis=0)  # within SHADOW_CONTACT_M: a penumbra under a texel
    d = taps(search)  # the far occluders' mean distance sets their penumbra (PCSS)
    hit = d < far
    blocker = np.where(hit, d, 0.0).sum(axis=0) / np.maximum(hit.sum(axis=0), 1)
    radius = np.clip((depth[sel] - blocker) * half / texel_m, 1.0, search)
    lit = 1.0 - np.where(hit.any(axis=0), (taps(radius) < far).mean(axis=0), 0.0)
    vis[sel] = lit * (1.0 - contact)
    return vis


def filmic(x) -> np.ndarray:
    """Narkowicz's fit of the ACES filmic curve (linear scene value -> [0, 1] display-linear)."""
    x = np.maximum(np.asarray(x, np.float64), 0.0)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def sun_visibility(r, scene, view: View, key) -> np.ndarray:
    """The sun's visibility (H, W) at each pixel of ``key``, ``r``'s render of ``view`` lit by the sun (``r``: a
    :class:`rockdove.render.gl.GLRenderer` of ``scene``'s parts, then the ground), from the bird's shadow map
    (:func:`_visibility`; 4 texels a view pixel, the bird filling about half of it), slope-scaled by the key's N.L."""
    px = min(SHADOW_PX, 2 ** math.ceil(math.log2(4 * max(view.width, view.height))))
    sun = _sun_camera(scene, view.light_direction, px)
    shot = r.render(sun)
    depth_map = np.where(shot.part_id > len(scene.parts), 0.0, shot.depth_m)  # the bird's, not the ground's
    texel = 2 * math.tan(sun.yfov_rad / 2) * float(np.linalg.norm(sun.eye_m - scene.bounds_m.mean(0))) / sun.width
    drawn = key.depth_m > 0
    vis, ndl = np.ones(drawn.shape), np.clip(key.n_dot_l[drawn], 1e-3, 1.0)
    points = view.eye_m + _pixel_rays(view)[drawn] * key.depth_m[drawn][:, None]
    vis[drawn] = _visibility(points, np.sqrt(1 - ndl ** 2) / ndl, sun, depth_map, texel,
                             float(np.linalg.norm(np.ptp(scene.bounds_m, axis=0))))
    return vis


def render_gl(scene, views, ground_y_m: float, lut=None) -> dict:
    """Render the beauty ``views`` (:func:`rockdove.render.beauty.beauty_views`) of ``scene`` with the GL path;
    ``{view name: (H, W, 3) uint8}`` display-referred (sRGB)."""
    from ..srgb import srgb_encode
    from .gl import GLRenderer
    from .images import box_downsample

    staged = dataclasses.replace(scene, parts=tuple(scene.parts) + (_ground_part(scene, views),))
    out = {}
    with GLRenderer(staged, lut=lut, mipmaps=True) as r:
        for v in views:
            s = SUPERSAMPLE
            big = dataclasses.replace(v, width=v.width * s, height=v.height * s,
                                      light_rgb=np.asarray(B.SUN_RGB) * B.SUN_STRENGTH / math.pi)
            key = r.render(big)
            fill = sum(r.render_radiance(dataclasses.replace(v, light_direction=d, light_rgb=c))[0]
                       for d, c in _sky_lights())  # smooth light: at the picture's size
            # the sun's visibility at each supersample (a feather's contact shadow is sharper than a pixel)
            vis = sun_visibility(r, scene, big, key)
            rgb = (box_downsample(key.radiance_rgb * vis[..., None], s) + fill) * 2.0 ** EXPOSURE
            out[v.name] = np.clip(np.rint(srgb_encode(filmic(rgb)) * 255), 0, 255).astype(np.uint8)
    return out

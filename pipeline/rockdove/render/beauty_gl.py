"""The beauty render's GL path (:mod:`rockdove.render.beauty`) where Blender is not installed: the verification's
shaders (:class:`rockdove.render.gl.GLRenderer`), whose radiance is linear in each light, with the look built around
them in linear light:

- the ground (:func:`rockdove.render.beauty.cyclorama`) is one more Lambert part of neutral grey;
- the key: one render under the sun (``light_rgb`` = its irradiance / pi, as Cycles' sun of that strength lights a
  Lambert surface), times its visibility from a shadow map (the scene drawn from a far, nearly orthographic sun
  camera), averaged over a disc of taps whose radius grows with the distance to the occluder by the sun's angular
  radius (percentage-closer soft shadows, R. Fernando, "Percentage-Closer Soft Shadows", SIGGRAPH 2005 sketch);
- the sky: :data:`SKY_LIGHTS` directional lights over the upper hemisphere and the zenith, without shadows,
  weighted so a horizontal surface receives the sky's irradiance pi x strength x colour;
- the key rendered at :data:`SUPERSAMPLE` x the size and box-filtered, exposed, put through a filmic curve
  (K. Narkowicz, "ACES Filmic Tone Mapping Curve", 2016) and the sRGB OETF.
"""

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
#: Shadow map: size in pixels, field of view of the sun camera (degrees), depth bias (metres) and PCF taps.
SHADOW_PX = 1024
SHADOW_FOV_DEG = 2.0
SHADOW_BIAS_M = 0.003
SHADOW_TAPS = 16
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


def _sun_camera(scene, sun_dir) -> View:
    """A far camera looking down the sun's rays at the bird, its bounding sphere filling the frame."""
    b = scene.bounds_m
    centre, radius = b.mean(axis=0), 0.5 * float(np.linalg.norm(b[1] - b[0]))
    dist = 1.05 * radius / math.tan(math.radians(SHADOW_FOV_DEG) / 2)
    eye = centre + dist * np.asarray(sun_dir)
    up = (0.0, 0.0, 1.0) if abs(sun_dir[1]) > 0.99 else (0.0, 1.0, 0.0)
    return View("sun", look_at(eye, centre, up), math.radians(SHADOW_FOV_DEG), SHADOW_PX, SHADOW_PX, sun_dir,
                (1.0, 1.0, 1.0))


def _visibility(points, sun: View, depth_map, texel_m: float, reach_m: float) -> np.ndarray:
    """Fraction of the sun each world point (N, 3) sees: PCSS over ``depth_map`` (the sun camera's view depth,
    0 where nothing was drawn), occluders searched up to ``reach_m`` away along the rays. Points nearer the sun
    than every texel within the widest penumbra (a minimum filter of the map) are lit without a search."""
    from scipy.ndimage import minimum_filter

    w2c = np.linalg.inv(sun.camera_to_world)
    q = points @ w2c[:3, :3].T + w2c[:3, 3]
    depth = -q[:, 2]
    t, n = math.tan(sun.yfov_rad / 2), SHADOW_PX
    u = (q[:, 0] / (depth * t) + 1) * 0.5 * n - 0.5
    v = (1 - q[:, 1] / (depth * t)) * 0.5 * n - 0.5
    half = math.tan(math.radians(B.SUN_ANGLE_DEG) / 2)
    search = max(1.0, reach_m * half / texel_m)  # the widest penumbra, texels
    nearest = minimum_filter(np.where(depth_map > 0, depth_map, np.inf), size=2 * int(search) + 3)

    def texel(m, du, dv, sel):
        iu, iv = np.rint(u[sel] + du).astype(np.intp), np.rint(v[sel] + dv).astype(np.intp)
        inside = (iu >= 0) & (iu < n) & (iv >= 0) & (iv < n)  # outside the map: nothing of the bird
        return np.where(inside, m[np.clip(iv, 0, n - 1), np.clip(iu, 0, n - 1)], np.inf)

    vis = np.ones(len(points))
    sel = np.flatnonzero(texel(nearest, 0, 0, slice(None)) < depth - SHADOW_BIAS_M)
    if not len(sel):
        return vis
    k = np.arange(SHADOW_TAPS)
    ang, rad = k * 2.39996323, np.sqrt((k + 0.5) / SHADOW_TAPS)  # golden-angle (Vogel) disc
    dsel = depth[sel] - SHADOW_BIAS_M
    blocker, count = np.zeros(len(sel)), np.zeros(len(sel))
    for a, r in zip(ang, rad):  # blocker search over the widest disc, then the penumbra from their distance
        d = texel(depth_map, search * r * math.cos(a), search * r * math.sin(a), sel)
        hit = (d > 0) & (d < dsel)
        blocker += np.where(hit, d, 0.0)
        count += hit
    radius = np.clip((depth[sel] - blocker / np.maximum(count, 1)) * half / texel_m, 0.5, search)
    lit = np.zeros(len(sel))
    for a, r in zip(ang, rad):
        d = texel(depth_map, radius * r * math.cos(a), radius * r * math.sin(a), sel)
        lit += ~((d > 0) & (d < dsel))
    vis[sel] = np.where(count > 0, lit / SHADOW_TAPS, 1.0)
    return vis


def filmic(x) -> np.ndarray:
    """Narkowicz's fit of the ACES filmic curve (linear scene value -> [0, 1] display-linear)."""
    x = np.maximum(np.asarray(x, np.float64), 0.0)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def render_gl(scene, views, ground_y_m: float, lut=None) -> dict:
    """Render the beauty ``views`` (:func:`rockdove.render.beauty.beauty_views`) of ``scene`` with the GL path;
    ``{view name: (H, W, 3) uint8}`` display-referred (sRGB)."""
    from ..srgb import srgb_encode
    from .gl import GLRenderer
    from .images import box_downsample

    staged = dataclasses.replace(scene, parts=tuple(scene.parts) + (_ground_part(scene, views),))
    reach = float(np.linalg.norm(np.ptp(scene.bounds_m, axis=0)))
    out = {}
    with GLRenderer(staged, lut=lut) as r:
        for v in views:
            s = SUPERSAMPLE
            key = r.render(dataclasses.replace(v, width=v.width * s, height=v.height * s,
                                               light_rgb=np.asarray(B.SUN_RGB) * B.SUN_STRENGTH / math.pi))
            fill = sum(r.render(dataclasses.replace(v, light_direction=d, light_rgb=c)).radiance_rgb
                       for d, c in _sky_lights())  # smooth light: at the picture's size
            sun = _sun_camera(scene, v.light_direction)
            shot = r.render(sun)
            depth_map = np.where(shot.part_id == len(staged.parts), 0.0, shot.depth_m)  # the bird's, not the ground's
            texel = 2 * math.tan(sun.yfov_rad / 2) * float(np.linalg.norm(sun.eye_m - scene.bounds_m.mean(0)))
            texel /= SHADOW_PX
            # the sun's visibility at one sample of each picture pixel (its penumbrae are wider than a pixel)
            depth = key.depth_m[s // 2::s, s // 2::s]
            drawn = depth > 0
            vis = np.ones(depth.shape)
            rays = _pixel_rays(v)
            vis[drawn] = _visibility(v.eye_m + rays[drawn] * depth[drawn][:, None], sun, depth_map, texel, reach)
            rgb = (box_downsample(key.radiance_rgb, s) * vis[..., None] + fill) * 2.0 ** EXPOSURE
            out[v.name] = np.clip(np.rint(srgb_encode(filmic(rgb)) * 255), 0, 255).astype(np.uint8)
    return out

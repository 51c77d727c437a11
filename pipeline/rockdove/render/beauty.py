"""The beauty render: the picture the verification report opens with, the bird as a look-dev artist shows it.

Not a measurement (docs/pictures.md): the written asset on a neutral grey ground under a moderate sky and a warm
key sun with soft shadows, from a 3/4 and a side view (:func:`beauty_views`). Renderers (:data:`RENDERERS`, run by
:func:`rockdove.hosts.beauty.render_beauty`): ``cycles``, Blender's Cycles through the rockdove add-on
(:mod:`rockdove.hosts.blender_beauty_job`); ``gl``, the verification shaders (:mod:`rockdove.render.beauty_gl`);
``auto``, Cycles when the Blender host is available and named (``--hosts blender``), else GL, the caption saying
which and why; ``off``. Sizes and samples: ``[beauty]`` (schemas/config.schema.json)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import UsageError
from .views import View, direction, look_at

RENDERERS = ("auto", "cycles", "gl", "off")
#: (name, azimuth, elevation) of the two cameras, degrees; azimuth 0 is in front of the beak, positive toward the
#: bird's left (+X; the bird faces +Z, Y is up), as in rockdove.render.views.
VIEWS = (("beauty_34", 35.0, 15.0), ("beauty_side", 90.0, 5.0))
#: Vertical field of view, degrees (a short telephoto: little perspective distortion of the bird).
YFOV_DEG = 24.0
#: Fraction of the frame's height (or width) the bird may fill: the rest is headroom and ground.
FILL = 0.78
#: How far below the frame's centre the bird's projected centre sits, as a fraction of the frame's height: a
#: little more room above the head than below the feet, where the shadow lies.
LOWER = 0.03
#: The key sun: elevation above the ground, azimuth relative to the camera (negative: from the camera's left,
#: toward the beak), angular diameter (soft shadow edges), strength (W/m^2, Blender's sun irradiance) and
#: colour (warm, about 4800 K, linear Rec.709).
SUN_ELEVATION_DEG = 40.0
SUN_AZIMUTH_FROM_CAMERA_DEG = -45.0
SUN_ANGLE_DEG = 4.0
SUN_STRENGTH = 3.0
SUN_RGB = (1.0, 0.87, 0.74)
#: The sky (world) gradient, linear Rec.709, and its strength: a cool fill about 1/3 of the sun on the ground.
SKY_HORIZON_RGB = (0.80, 0.82, 0.85)
SKY_ZENITH_RGB = (0.42, 0.55, 0.80)
SKY_STRENGTH = 0.45
#: Neutral grey ground: albedo, and the radius of its cyclorama in multiples of the farthest camera's distance.
GROUND_ALBEDO = 0.30
GROUND_RADIUS = 3.0
#: Seconds before a Cycles beauty render is given up (and drawn with GL): the 768 x 512, 32-sample pair took
#: 513 s + 891 s of Cycles on the 2 shared cores at a load average of 13-19 (measured; done.json's render_s).
TIMEOUT_S = 3600
#: AgX look and exposure (stops) of the Cycles picture.
LOOK = "AgX - Medium High Contrast"
EXPOSURE = 0.0


def _points(scene, limit: int = 40000) -> np.ndarray:
    """World positions of every part (a strided subset of at most ``limit``), metres."""
    pts = np.concatenate([p.positions_m for p in scene.parts]).astype(np.float64)
    return pts[:: max(1, len(pts) // limit)]


def frame(points, azimuth_deg: float, elevation_deg: float, width: int, height: int) -> np.ndarray:
    """Camera-to-world (OpenGL) of a camera at ``azimuth_deg``/``elevation_deg`` that frames every point: its
    projection spans at most :data:`FILL` of the frame's height and width, centred across and :data:`LOWER` of
    the height below the middle."""
    pts = np.asarray(points, np.float64)
    d = direction(azimuth_deg, elevation_deg)
    ty = math.tan(math.radians(YFOV_DEG) / 2)
    tx = ty * width / height
    target = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    for _ in range(3):  # distance to fit, then re-centre the projection; converges in two or three rounds
        c2w = look_at(target + d, target)
        right, up = c2w[:3, 0], c2w[:3, 1]
        q = pts - target
        x, y, z = q @ right, q @ up, q @ d
        dist = float(np.max(z + np.maximum(np.abs(x) / (FILL * tx), np.abs(y) / (FILL * ty))))
        depth = dist - z
        sx, sy = x / depth, y / depth
        cx, cy = 0.5 * (sx.max() + sx.min()), 0.5 * (sy.max() + sy.min()) + 2 * LOWER * ty
        target = target + dist * (cx * right + cy * up)
    return look_at(target + dist * d, target)


def beauty_views(scene, width: int, height: int) -> list[View]:
    """The 3/4 and side views (:data:`VIEWS`) of ``scene``, ``width`` x ``height`` px, each with its key sun
    (``light_direction``, toward the sun; ``light_rgb`` = :data:`SUN_RGB` x :data:`SUN_STRENGTH`)."""
    pts = _points(scene)
    return [View(name, frame(pts, az, el, width, height), math.radians(YFOV_DEG), width, height,
                 direction(az + SUN_AZIMUTH_FROM_CAMERA_DEG, SUN_ELEVATION_DEG),
                 np.asarray(SUN_RGB) * SUN_STRENGTH) for name, az, el in VIEWS]


def ground_y_m(scene) -> float:
    """Height of the ground: the lowest point of the bird (its toes), metres."""
    return float(scene.bounds_m[0, 1])


def cyclorama(scene, views, segments: int = 96) -> tuple[np.ndarray, np.ndarray]:
    """The ground both renderers draw, a photo studio's cyclorama as a bowl under the bird: a flat floor at
    :func:`ground_y_m` to 0.7 of its radius (:data:`GROUND_RADIUS` x the farthest camera's distance) curving up into
    a wall 0.6 x the radius high (top 31 degrees above the bird, below the sun), so no horizon line crosses the
    picture. ``(vertices (V, 3) metres, quads (F, 4))``, counter-clockwise seen from inside."""
    centre = scene.bounds_m.mean(axis=0)
    big = GROUND_RADIUS * max(float(np.linalg.norm(v.eye_m - centre)) for v in views)
    a = np.linspace(0.0, 0.5 * math.pi, 9)
    r = np.concatenate([[0.0], 0.7 * big + 0.3 * big * np.sin(a), [big]])
    y = np.concatenate([[0.0], 0.3 * big * (1 - np.cos(a)), [0.6 * big]]) + ground_y_m(scene)
    phi = 2 * math.pi * np.arange(segments) / segments
    verts = np.stack([np.outer(r, np.sin(phi)) + centre[0], np.repeat(y[:, None], segments, 1),
                      np.outer(r, np.cos(phi)) + centre[2]], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(len(r) - 1), np.arange(segments), indexing="ij")
    k = (j + 1) % segments
    quads = np.stack([i * segments + j, (i + 1) * segments + j, (i + 1) * segments + k, i * segments + k], -1)
    return verts, quads.reshape(-1, 4)


def settings(overrides=None) -> dict:
    """The ``[beauty]`` settings: the schema's defaults (schemas/config.schema.json) under ``overrides``, checked
    against its ranges (ValueError naming the key)."""
    from ..config import defaults, limits

    out = {**defaults()["beauty"], **{k: v for k, v in (overrides or {}).items() if v is not None}}
    if out["renderer"] not in RENDERERS:
        raise UsageError(f"beauty.renderer: {out['renderer']!r} is not one of {', '.join(RENDERERS)}")
    for key in ("width", "height", "samples", "animation_frames"):
        lo, hi = limits(f"beauty.{key}")
        if not isinstance(out[key], int) or isinstance(out[key], bool) or not lo <= out[key] <= hi:
            raise UsageError(f"beauty.{key}: {out[key]!r} is not an integer from {lo} to {hi}")
    return out

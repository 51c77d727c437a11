"""The report's animation of the shimmer: the light turns once round the bird while a still camera looks at the head
and neck from the 3/4 front, as the paper turns its light and watches the colour move. Each frame is the paper's
shading (:mod:`rockdove.render.gl`) under one D65-white directional light, multisampled with alpha-to-coverage, into
an animated WebP (:func:`rockdove.render.images.write_webp`)."""

from __future__ import annotations

import math
import os
import time

import numpy as np

from ..errors import UsageError
from .views import View, direction

#: File name of the animation in the report folder.
FILE = "light_turn.webp"
#: The camera (azimuth from the beak toward the bird's left, elevation; degrees) and the light's elevation (high:
#: the neck stays lit while the light is behind the bird).
CAMERA_AZIMUTH_DEG, CAMERA_ELEVATION_DEG = 40.0, 12.0
LIGHT_ELEVATION_DEG = 60.0
#: Frames per second of the WebP (24 frames: one turn in 3 s).
FPS = 8
#: Linear grey behind the bird (the light behind it leaves a silhouette against it).
BACKGROUND = 0.03
#: Parts framed with the neck's feathers when present: the head's.
HEAD_PARTS = ("Beak", "Cere", "Eyes", "EyeRings", "HeadFeathers")


def light_turn_views(scene, frames: int, size: int) -> list[View]:
    """``frames`` square views of ``size`` px, one camera framing the neck's feathers and the head, the light at
    :data:`LIGHT_ELEVATION_DEG` turning a full circle about the vertical from the camera's side (frame 0),
    named ``light_turn_<k>``."""
    from .beauty import YFOV_DEG, frame

    if int(frames) != frames or frames < 2 or int(size) != size or size < 16:
        raise UsageError(f"frames must be an integer >= 2 and size >= 16 px, got {frames!r} and {size!r}")
    neck = [p.positions_m for p in scene.parts if p.is_feather or p.name in HEAD_PARTS]
    pts = np.concatenate(neck or [p.positions_m for p in scene.parts])
    low = pts[:, 1].min()  # and every other part's points as high as those (the head's shell)
    pts = np.concatenate([pts] + [p.positions_m[p.positions_m[:, 1] >= low] for p in scene.parts])
    c2w = frame(pts, CAMERA_AZIMUTH_DEG, CAMERA_ELEVATION_DEG, size, size)
    return [View(f"light_turn_{k:03d}", c2w, math.radians(YFOV_DEG), size, size,
                 direction(CAMERA_AZIMUTH_DEG - 30.0 + 360.0 * k / frames, LIGHT_ELEVATION_DEG), (1.0, 1.0, 1.0))
            for k in range(int(frames))]


def frame_image(renderer, view) -> np.ndarray:
    """One frame of a report's animation: ``view`` by ``renderer`` (a ``GLRenderer(..., mipmaps=True)``), 4x MSAA
    with the cards' cut-out by alpha-to-coverage, over :data:`BACKGROUND`; sRGB 8-bit."""
    from ..srgb import linear_to_srgb8

    rgb, coverage = renderer.render_radiance(view, samples=4)
    return linear_to_srgb8(rgb + (1.0 - coverage[..., None]) * BACKGROUND)


def render_light_turn(scene, path, frames: int = 24, size: int = 256, lut=None) -> dict:
    """Render :func:`light_turn_views` and write them to ``path`` as an animated WebP; the report's entry: ``{"files":
    {"light_turn": name}, "frames", "fps", "size", "bytes", "seconds", "caption"}``. ``lut``: the film's LUT
    (default the asset's)."""
    from .gl import GLRenderer
    from .images import write_webp

    t = time.perf_counter()
    views = light_turn_views(scene, frames, size)
    with GLRenderer(scene, lut=lut, width=size, height=size, mipmaps=True) as r:
        images = [frame_image(r, v) for v in views]
    write_webp(images, path, FPS)
    seconds = time.perf_counter() - t
    caption = (f"The light turns round the bird ({frames} frames, {frames / FPS:g} s a turn, {size} x {size} px): "
               f"the paper's shading of the neck's film (the exact LUT colour at the light/view half-angle, our GLSL) "
               f"under one white light {LIGHT_ELEVATION_DEG:g} degrees high; {seconds:.1f} s to render")
    return {"files": {"light_turn": os.path.basename(path)}, "frames": int(frames), "fps": FPS,
            "size": [size, size], "bytes": os.path.getsize(path), "seconds": seconds, "caption": caption}


def for_report(scene, out_dir, settings: dict, *, lut=None) -> tuple:
    """The animation as the verification report takes it (``[beauty]`` ``settings``: ``animation_frames``, square
    frames half of ``height``; none with ``renderer = "off"``): ``(entry or None, note or None)``. Not a
    measurement: a failure is a note."""
    if not settings.get("animation_frames") or settings.get("renderer") == "off":
        return None, None
    try:
        return render_light_turn(scene, os.path.join(out_dir, FILE), settings["animation_frames"],
                                 max(16, settings["height"] // 2), lut=lut), None
    except Exception as exc:  # noqa: BLE001 - any renderer's error: the report goes on without it
        return None, f"no light-turning animation: {type(exc).__name__}: {exc}"

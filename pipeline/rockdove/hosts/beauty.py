"""The beauty render's choice of renderer (:mod:`rockdove.render.beauty` sets the scene up; this module renders
it): Cycles through the rockdove add-on (:mod:`rockdove.hosts.blender_beauty_job`, run by the Blender host's job
runner) or the GL path (:mod:`rockdove.render.beauty_gl`), and the entry the verification report takes."""

from __future__ import annotations

import importlib.util
import os
import time

import numpy as np

from ..errors import UsageError
from ..png import save_png
from ..render import beauty as setup
from . import bpy_runner as runner
from .base import HostError
from .blender import NAME, cycles_job
from .jobs import BeautyJob


def render_cycles(layer: str, scene, views, out_dir: str, samples: int) -> dict:
    """``{view name: (H, W, 3) uint8}`` (AgX) rendered with Cycles through the add-on; HostError when it cannot."""
    work = runner.work_folder("beauty_cycles", views, out_dir, "png")
    verts, quads = setup.cyclorama(scene, views)
    job = cycles_job(
        BeautyJob, os.path.abspath(layer), runner.job_views(views, sun=True), work, samples,
        ground_vertices_m=np.round(verts, 6).tolist(), ground_quads=quads.tolist(), ground_albedo=setup.GROUND_ALBEDO,
        sky_horizon_rgb=setup.SKY_HORIZON_RGB, sky_zenith_rgb=setup.SKY_ZENITH_RGB, sky_strength=setup.SKY_STRENGTH,
        sun_strength=setup.SUN_STRENGTH, sun_rgb=setup.SUN_RGB, sun_angle_deg=setup.SUN_ANGLE_DEG, look=setup.LOOK,
        exposure=setup.EXPOSURE)
    runner.run_job(job, work, importlib.util.find_spec("rockdove.hosts.blender_beauty_job").origin, setup.TIMEOUT_S)
    return runner.read_views(NAME, "Blender", views, work, "png")


def render_beauty(layer: str, scene, out_dir: str, *, renderer: str = "auto", width: int = 768,
                  height: int = 512, samples: int = 32, cycles_ok: bool = True, lut=None) -> dict | None:
    """Render the beauty views of ``scene`` (the asset at ``layer``) into ``out_dir`` and describe them; None for
    ``renderer="off"``. ``cycles_ok``: whether ``auto`` may take Cycles (the verification runs Blender)."""
    if renderer not in setup.RENDERERS:
        raise UsageError(f"beauty renderer {renderer!r} is not one of {', '.join(setup.RENDERERS)}")
    if renderer == "off":
        return None
    views = setup.beauty_views(scene, int(width), int(height))
    t = time.perf_counter()
    fallback, images, used = None, None, "gl"
    if renderer == "cycles" or (renderer == "auto" and cycles_ok):
        if (fallback := runner.unavailable()) is None:
            try:
                images, used = render_cycles(layer, scene, views, out_dir, samples), "cycles"
            except HostError as exc:
                fallback = str(exc)
    elif renderer == "auto":
        fallback = "the Blender host was not named (--hosts blender or --beauty cycles renders with Cycles)"
    if images is None:
        from ..render.beauty_gl import render_gl

        images = render_gl(scene, views, setup.ground_y_m(scene), lut=lut)
    seconds = time.perf_counter() - t
    files = {name: os.path.basename(save_png(img, os.path.join(out_dir, f"{name}.png")))
             for name, img in images.items()}
    if used == "cycles":
        caption = (f"Cycles (Blender, through the rockdove add-on), {samples} samples per pixel, adaptive, "
                   f"OpenImageDenoise, AgX; sky light and a {setup.SUN_ANGLE_DEG:g} degree warm sun at "
                   f"{setup.SUN_ELEVATION_DEG:g} degrees; {width} x {height} px, {seconds:.1f} s")
    else:
        caption = (f"GL (the verification's GLSL shaders in pyrender): the sun's shadow from a shadow map, sky "
                   f"fill lights, filmic curve; {width} x {height} px, {seconds:.1f} s"
                   + (f"; not Cycles: {fallback}" if fallback else ""))
    return {"renderer": used, "files": files, "caption": caption, "seconds": seconds, "size": [width, height],
            "samples": samples if used == "cycles" else None, "fallback": fallback}


def for_report(layer: str, scene, out_dir: str, settings: dict, *, cycles_ok: bool, lut=None) -> tuple:
    """:func:`render_beauty` for the report: ``(entry or None, note or None)``. The picture is not a measurement, so a
    renderer that fails leaves a note, never a failed verification; Cycles wanted (asked for, or ``auto`` where the
    Blender host runs) and GL got is noted too."""
    try:
        entry = render_beauty(layer, scene, out_dir, cycles_ok=cycles_ok, lut=lut, **{
            k: settings[k] for k in ("renderer", "width", "height", "samples") if k in settings})
    except Exception as exc:  # noqa: BLE001 - any renderer's error: the report goes on without the picture
        return None, f"no beauty render: {type(exc).__name__}: {exc}"
    renderer = settings.get("renderer", "auto")
    wanted = ("Cycles was asked for" if renderer == "cycles" else
              "auto takes Cycles where the Blender host runs" if renderer == "auto" and cycles_ok else None)
    if entry is not None and wanted and entry["renderer"] != "cycles":  # a note: the cache does not keep it
        return entry, f"beauty render: {wanted}, drawn with GL instead ({entry['fallback']})"
    return entry, None

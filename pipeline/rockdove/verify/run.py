"""One verification view, checked: its GL render against the exact CPU reference, compared
(:mod:`rockdove.verify.compare`), the hue histogram and boundary shape of a light-sweep view, and its images."""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import compare, report
from .boundary import boundary_shape, class_shape
from .gl_renders import GLRenderError, GLRenders
from .results import ViewResult

_log = logging.getLogger(__name__)


def render_and_check(scene, lut, views, out: str, *, surfaces=None) -> tuple[dict[str, ViewResult], list, dict]:
    """Render ``views`` (GL and reference), compare, write each view's images into ``out/<view>/``: ``({name:
    ViewResult}, the references, {name: GL radiance})``. ``surfaces``: ready-made reference surfaces by camera."""
    from ..png import save_png
    from ..srgb import linear_to_srgb8
    from .reference_image import render_reference

    failures_all: dict[str, None] = {}  # the GL renders' failures, each once, in order
    # the largest views first (the hero): GL-rendered while the reference integrates, so no view waits for long
    order = sorted(range(len(views)), key=lambda i: -views[i].width * views[i].height)
    gl = GLRenders(scene, [views[i] for i in order], lut)
    t = time.perf_counter()
    ref_results = render_reference(scene, views, surfaces=surfaces)
    t_ref = (time.perf_counter() - t) / len(views)
    _log.info("comparing")
    results, gl_images = {}, {}
    # The images are encoded in a writer thread (zlib runs outside the GIL) while this one compares the next
    # view; every write is waited for, and its error raised, before the results are returned.
    with ThreadPoolExecutor(1, thread_name_prefix="rockdove-png") as writer:
        writes = []

        def write(files: dict, folder: str, key: str, fn, **args):  # fn(path=<folder>/<view>_<key>.png, **args)
            files[key] = f"{os.path.basename(folder)}_{key}.png"
            writes.append(writer.submit(fn, path=os.path.join(folder, files[key]), **args))

        for k, i in enumerate(order):
            v = views[i]
            try:
                gl_result, t_gl = gl.result(k)
            except GLRenderError as exc:
                gl_result, t_gl = None, 0.0
                failures_all[f"GL renders (rockdove.render.gl) failed: {exc}"] = None
            gl_rgb = None if gl_result is None else np.asarray(gl_result.radiance_rgb)
            if gl_rgb is not None:
                gl_images[v.name] = gl_rgb
            t = time.perf_counter()
            folder = os.path.join(out, v.name)
            os.makedirs(folder, exist_ok=True)
            m = compare.compare(gl_result, ref_results[i], scene) if gl_result is not None else None
            sweep = v.name.startswith("sweep_")
            hue = boundary = None
            if sweep and m is not None:  # the comparison classified the pixels: its classes and histogram
                # (that of the GL colours themselves when they are finite, which the comparison reads as 0)
                hue = m.hue if m.finite else compare.hue_histogram(gl_rgb.astype(np.float64)[m.cls >= 0])
                boundary = class_shape(m.strict, m.cls)
            elif sweep:
                cls = compare.reference_classes(ref_results[i], scene)
                rgb = np.asarray(ref_results[i].rgb, np.float64)
                hue = compare.hue_histogram(rgb[cls >= 0])
                boundary = boundary_shape(rgb, cls >= 0)  # the same sides classes as cls
            files, rows = {}, []
            ref_png = linear_to_srgb8(ref_results[i].rgb)
            write(files, folder, "reference", save_png, image=ref_png)
            if gl_rgb is not None:
                gl_png = linear_to_srgb8(gl_rgb)
                write(files, folder, "gl", save_png, image=gl_png)
                rows.append(gl_png)
            rows.append(ref_png)
            if m is not None:
                write(files, folder, "dE", report.de_map_png, de_map=m.de_map,
                      title=f"{v.name}: dE2000 median {m.de_median:.2f}, p95 {m.de_p95:.2f}, max {m.de_max:.2f}")
                rows.append(report.de_colour(m.de_map))
            results[v.name] = ViewResult(
                view=v.name, setup=v.to_dict(), sweep=sweep,  # the metrics without their images
                metrics=None if m is None else dataclasses.replace(m, de_map=None, cls=None, strict=None),
                failures=(*failures_all, *(m.failures if m is not None else ())),
                reference={"view": ref_results[i].view, "timings_s": ref_results[i].timings_s,
                           "stats": ref_results[i].stats},
                hue=hue, boundary=boundary, files=files,
                timings_s={"gl": t_gl, "reference": t_ref, "compare": time.perf_counter() - t},
                folder=os.path.abspath(folder), sheet_row=tuple(rows))
        for w in writes:
            w.result()
    return {v.name: results[v.name] for v in views}, ref_results, gl_images  # in the views' order

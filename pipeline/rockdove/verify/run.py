"""Verify a written asset by looking at it: validation, GL renders, the exact CPU reference, checks, report.

:func:`verify_asset` is what ``rockdove verify`` runs (issue 5):

1. validation with :func:`rockdove.usd.validate.validate_asset`; a validator that raises is a failure, not a pass;
2. the asset is read back from disk (:func:`rockdove.render.scene.load_scene`);
3. views: :func:`rockdove.render.views.default_views` (2 turntable frames, the light sweep at 60 and 120 deg)
   plus the sweep at the flip itself (:data:`rockdove.verify.inputs.BOUNDARY_SWEEP_ANGLE_DEG`), where the green/purple boundary
   crosses the neck;
4. GL renders (:func:`rockdove.render.gl.render_views`) and the reference
   (:func:`rockdove.verify.reference_image.render_reference`), timed;
5. per view :func:`rockdove.verify.compare.compare` (dE2000 goals, NaN/Inf, black holes), the hue histogram
   over the sweep views (both green and purple must appear), and the boundary straightness of every sweep view
   (reported: the paper preset keeps the boundary straight, the measured one bends it);
6. the verdict and the report (:mod:`rockdove.verify.verdict`, :mod:`rockdove.verify.report`).

Pass: validation clean, every view within the dE goals with no NaN/Inf and no black holes, and both hues in
the sweep.

Per view, for incremental builds: :func:`rockdove.verify.inputs.plan_views` names the views and what each reads
(its camera, light and size, and the digest of the scene content it renders); :func:`verify_views` renders and
checks any subset in one call (shared GL context, shared reference rays) and returns per-view results that can be cached;
:func:`report_from_views` validates and joins them into the report. ``verify_asset(views=[...])`` does both for
a subset; a subset without a light-sweep view cannot run the hue check, and the report's ``notes`` say so.

Assets without a LUT (``shading.variant = "physical"``): the renderers here draw the paper's LUT method (the
GLSL shaders) and the exact spectra (the reference); neither is a renderer's thin-film BSDF. Rather than skip
the GL/reference comparison, :func:`rockdove.verify.inputs.verification_scene` bakes a *verification-only* LUT
in memory from the film the asset records (RockDoveThinFilmAPI), at the build's default size
(:meth:`rockdove.render.scene.RenderScene.load_lut`); every check then runs (geometry, textures, thickness
primvar, film against the exact reference) and the report's ``notes`` say that the asset's own physical
MaterialX network was only validated, not rendered. Nothing is written into the asset.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import compare, report
from .gl_renders import GLRenderError, GLRenders
from .boundary import boundary_shape, class_shape
from .inputs import DEFAULT_SIZE, DEFAULT_VIEWS, check_size, select_views, verification_scene, verification_views
from .verdict import combine, default_out_dir


def render_and_check(scene, lut, views, out: str, *, subfolders: bool, say, hits=None, surfaces=None, refs=None,
                      gl_images=None) -> dict:
    """Render ``views`` (GL and reference), compare, write each view's images; ``{name: view result}``.

    ``refs``: the half-angle references of ``views`` when already rendered (:func:`verify_asset` renders every
    lobe the hosts need in one call, sharing the ray casts); ``gl_images``: a dict that receives each view's
    GL radiance (the ``glsl`` host's images); ``hits``: cached ray casts (:func:`rockdove.verify.rays.cast_hits`);
    ``surfaces``: cached shading inputs at those hits (:func:`rockdove.verify.reference_image.cast_surfaces`)."""
    from ..render.images import save_png
    from ..spectral import linear_to_srgb8
    from .reference_image import render_reference

    failures_all = []
    # The GL renders run in a thread of their own (rockdove.verify.gl_renders), one result per view: this thread
    # computes the reference, then compares each view as soon as it is rendered, while the next one is drawn.
    say(f"GL renders and CPU reference ({len(views)} views)")
    # the largest views first (the hero): rendered while the reference integrates, so no view waits for long
    order = sorted(range(len(views)), key=lambda i: -views[i].width * views[i].height)
    gl = GLRenders(scene, [views[i] for i in order], lut)
    t = time.perf_counter()
    ref_results = render_reference(scene, views, hits=hits, surfaces=surfaces) if refs is None else refs
    t_ref = (time.perf_counter() - t) / len(views)
    say("comparing")
    results = {}
    # The images are encoded in a writer thread (zlib runs outside the GIL) while this one compares the next
    # view; every write is waited for, and its error raised, before the results are returned.
    with ThreadPoolExecutor(1, thread_name_prefix="rockdove-png") as writer:
        writes = []

        def write(files: dict, key: str, path: str, fn, *args):
            files[key] = os.path.basename(path)
            writes.append(writer.submit(fn, *args))

        for k, i in enumerate(order):
            v = views[i]
            try:
                gl_result, t_gl = gl.result(k)
            except GLRenderError as exc:
                gl_result, t_gl = None, 0.0
                failure = f"GL renders (rockdove.render.gl) failed: {exc}"
                if failure not in failures_all:
                    failures_all.append(failure)
            if gl_images is not None and gl_result is not None:
                gl_images[v.name] = compare.gl_arrays(gl_result)["rgb"]
            t = time.perf_counter()
            folder = os.path.join(out, v.name) if subfolders else out
            os.makedirs(folder, exist_ok=True)
            m = compare.compare(gl_result, ref_results[i], scene) if gl_result is not None else None
            sweep = v.name.startswith("sweep_")
            hue = boundary = None
            if sweep and m is not None:  # the comparison classified the pixels: its classes and histogram
                # (that of the GL colours themselves when they are finite, which the comparison reads as 0)
                hue = m.hue if m.finite else compare.hue_histogram(
                    np.asarray(compare.gl_arrays(gl_result)["rgb"], np.float64)[m.cls >= 0])
                boundary = {**compare.boundary_straightness(m.cls), **class_shape(m.strict, m.cls)}
            elif sweep:
                cls = compare.reference_classes(ref_results[i], scene)
                rgb = np.asarray(ref_results[i].rgb, np.float64)
                hue = compare.hue_histogram(rgb[cls >= 0])
                boundary = {**compare.boundary_straightness(cls), **boundary_shape(rgb, cls >= 0)}
            files, rows = {}, []
            ref_png = linear_to_srgb8(ref_results[i].rgb)
            path = os.path.join(folder, f"{v.name}_reference.png")
            write(files, "reference", path, save_png, ref_png, path)
            if gl_result is not None:
                gl_png = linear_to_srgb8(compare.gl_arrays(gl_result)["rgb"])
                path = os.path.join(folder, f"{v.name}_gl.png")
                write(files, "gl", path, save_png, gl_png, path)
                rows.append(gl_png)
            rows.append(ref_png)
            if m is not None:
                path = os.path.join(folder, f"{v.name}_dE.png")
                write(files, "dE", path, report.de_map_png, path, m.de_map,
                      f"{v.name}: dE2000 median {m.de_median:.2f}, p95 {m.de_p95:.2f}, max {m.de_max:.2f}")
                rows.append(report.de_colour(m.de_map))
            results[v.name] = {
                "view": v.name, "setup": v.to_dict(), "sweep": sweep,
                "metrics": m.summary() if m is not None else None,
                "failures": list(failures_all) + (list(m.failures) if m is not None else []),
                "reference": {"view": ref_results[i].view, "timings_s": ref_results[i].timings_s,
                              "stats": ref_results[i].stats},
                "hue": hue, "boundary": boundary, "files": files, "dir": os.path.abspath(folder),
                "timings_s": {"gl": t_gl, "reference": t_ref, "compare": time.perf_counter() - t},
                "sheet_row": rows,
            }
        for w in writes:
            w.result()
    return {v.name: results[v.name] for v in views}  # in the views' order


def verify_views(asset, views=None, out_dir=None, width: int = DEFAULT_SIZE, height: int = DEFAULT_SIZE,
                 n_views: int = DEFAULT_VIEWS, subfolders: bool = False, progress=None, hits=None,
                 surfaces=None) -> dict:
    """Render and check a subset of the verification views; results that can be cached and combined.

    Parameters
    ----------
    asset : path
        The asset folder or its root layer.
    views : list of str, optional
        View names (:func:`rockdove.verify.inputs.plan_views` lists them); default all.
    out_dir : path, optional
        Where the images go (default ``verify/`` beside the root layer).
    width, height : int
        Render size, pixels (>= 16).
    n_views : int
        Turntable + sweep views of :func:`verification_views` (the boundary sweep view is added).
    subfolders : bool
        Write each view's images into ``out_dir/<view>/`` (one cacheable folder per view).
    progress : callable, optional
    hits : mapping, optional
        Ready-made reference ray casts (:func:`rockdove.verify.rays.cast_hits`, e.g. cached by the build
        keyed by :func:`rockdove.verify.rays.ray_digest` and the camera); the results do not change.
    surfaces : mapping, optional
        Ready-made reference surfaces (:func:`rockdove.verify.reference_image.cast_surfaces`, e.g. cached by the
        build keyed by :func:`rockdove.verify.reference_image.surface_digest` and the camera); the results do not
        change.

    Returns
    -------
    dict
        View name -> result: ``view``, ``setup`` (View.to_dict), ``sweep`` (bool), ``metrics``
        (ViewMetrics.summary or None without GL), ``failures``, ``reference`` (timings, stats), ``hue``
        (hue_histogram counts of a sweep view's compared pixels, else None), ``boundary`` (sweep views),
        ``files`` (image file names), ``dir`` (their folder), ``timings_s``, ``notes``, and ``sheet_row`` (the
        contact-sheet images, uint8 arrays: not JSON). Combine them with :func:`report_from_views`.
    """
    check_size(width, height)
    say = progress or (lambda msg: None)
    layer, scene, lut, notes = verification_scene(asset)
    out = os.path.abspath(os.fspath(out_dir)) if out_dir else default_out_dir(layer)
    os.makedirs(out, exist_ok=True)
    chosen = select_views(verification_views(scene, int(width), int(height), n_views), views)
    results = render_and_check(scene, lut, chosen, out, subfolders=subfolders, say=say, hits=hits,
                               surfaces=surfaces)
    for r in results.values():
        r["notes"] = list(notes)
    return results


def report_from_views(asset, view_results: dict, out_dir=None, width: int = DEFAULT_SIZE,
                      height: int = DEFAULT_SIZE, bench_dir=None, progress=None, *, reused=(),
                      published_asset=None, beauty=None) -> dict:
    """Validate the asset and combine per-view results (:func:`verify_views`, possibly from a cache) into the
    report (``report.json``, ``report.html`` and the images in ``out_dir``); returns the report dict.

    ``reused`` names the views whose results came from a cache (recorded in the report).
    ``published_asset``: the root layer's path once published (the build verifies a staging folder), which the
    report names instead of the layer read. ``beauty``: the ``[beauty]`` settings of the picture the report
    opens with (:mod:`rockdove.render.beauty`; ``auto`` is GL here: no Blender host runs); None: none.
    """
    layer, scene, lut, notes = verification_scene(asset)
    return combine(layer, scene, lut, notes, view_results, out_dir, width, height, bench_dir,
                    progress or (lambda msg: None), reused=reused, t_start=time.perf_counter(),
                    published_asset=published_asset, beauty=beauty)


def verify_asset(asset, out_dir=None, width: int = DEFAULT_SIZE, height: int = DEFAULT_SIZE,
                 bench_dir=None, progress=None, views=None, n_views: int = DEFAULT_VIEWS, hosts=("glsl",),
                 beauty=None) -> dict:
    """Validate, render and check an asset; write the report into ``out_dir``; return the report dict.

    Parameters
    ----------
    asset : path
        The asset folder or its root layer.
    out_dir : path, optional
        Default ``verify/`` beside the root layer.
    width, height : int
        Render size, pixels (>= 16).
    bench_dir : path, optional
        Folder of benchmark plots (``*.png``) to show in the report; default none (the report reads no folder it
        is not given).
    progress : callable, optional
        ``progress(message)`` for each step.
    views : list of str, optional
        Check only these views (names as in :func:`rockdove.verify.inputs.plan_views`); default all. With a subset that holds no
        light-sweep view the hue check cannot run: the report says so in ``notes`` (it is not counted as met).
    n_views : int
        Turntable + sweep views (:func:`rockdove.render.views.default_views`), plus the boundary sweep view.
    hosts : iterable of str or None
        Hosts (:data:`rockdove.hosts.HOSTS`) that render the same views, each compared with the reference of
        its lobe (:mod:`rockdove.verify.host_check`); None: every registered host available here. ``glsl``
        always runs. Unavailable hosts are reported as skipped with their reason; a host that fails or misses
        its goals fails the verification.
    beauty : dict, optional
        ``[beauty]`` settings (renderer, width, height, samples) of the picture the report opens with
        (:mod:`rockdove.render.beauty`; ``auto`` takes Cycles when ``hosts`` names the blender host and it is
        available, else GL); default the schema's defaults; ``{"renderer": "off"}``: none.

    Returns
    -------
    dict: the content of report.json (``report["hosts"]``: one entry per host); ``report["passed"]`` says whether verification passed,
    ``report["failures"]`` why not, ``report["notes"]`` what was not or differently checked (e.g. a
    physical-only asset's verification-only LUT).
    """
    from ..hosts import select
    from .host_check import check_hosts
    from .reference_image import render_reference_lobes

    check_size(width, height)
    say = progress or (lambda msg: None)
    t_start = time.perf_counter()
    selection = select(hosts)  # unknown names: ValueError before any work
    layer, scene, lut, notes = verification_scene(asset)
    out = os.path.abspath(os.fspath(out_dir)) if out_dir else default_out_dir(layer)
    os.makedirs(out, exist_ok=True)
    chosen = select_views(verification_views(scene, int(width), int(height), n_views), views)
    lobes = ("half_angle", *(m.LOBE for m in selection.available))
    say(f"CPU reference ({len(chosen)} views, lobes {', '.join(dict.fromkeys(lobes))})")
    t = time.perf_counter()
    refs = render_reference_lobes(scene, chosen, lobes)
    t_ref = time.perf_counter() - t
    gl_images = {}
    results = render_and_check(scene, lut, chosen, out, subfolders=False, say=say, refs=refs["half_angle"],
                                gl_images=gl_images)
    for r in results.values():
        r["timings_s"]["reference"] = t_ref / len(chosen)
    t = time.perf_counter()
    host_entries, host_images = check_hosts(layer, scene, chosen, selection, refs, out,
                                            rendered={"glsl": gl_images} if gl_images else None, say=say)
    from ..render.beauty import settings

    # auto takes Cycles only when the blender host was named (--hosts blender): a default verification would
    # otherwise spend minutes of CPU path tracing (768 x 512 x 2 views at 32 samples: 2-4 min on 2 idle cores)
    named = hosts is not None and "blender" in hosts
    beauty = {**settings(beauty), "cycles_ok": named and any(m.NAME == "blender" for m in selection.available)}
    return combine(layer, scene, lut, notes, results, out, width, height, bench_dir, say, t_start=t_start,
                    hosts=(host_entries, host_images, time.perf_counter() - t), beauty=beauty)

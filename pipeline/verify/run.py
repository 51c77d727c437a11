"""Verify a written asset by looking at it: validation, GL renders, the exact CPU reference, checks, report.

:func:`verify_asset` is what ``rockdove verify`` runs (issue 5):

1. validation with :func:`pipeline.usd.validate.validate_asset`; a missing validator is a failure, not a pass;
2. the asset is read back from disk (:func:`pipeline.render.scene.load_scene`);
3. views: :func:`pipeline.render.views.default_views` (2 turntable frames, the light sweep at 60 and 120 deg)
   plus the sweep at the flip itself (:data:`BOUNDARY_SWEEP_ANGLE_DEG`), where the green/purple boundary
   crosses the neck;
4. GL renders (:func:`pipeline.render.gl.render_views`) and the reference
   (:func:`pipeline.verify.reference_image.render_reference`), timed;
5. per view :func:`pipeline.verify.compare.compare` (dE2000 goals, NaN/Inf, black holes), the hue histogram
   over the sweep views (both green and purple must appear), and the boundary straightness of every sweep view
   (reported: the paper preset keeps the boundary straight, the measured one bends it);
6. the report (:mod:`pipeline.verify.report`).

Pass: validation clean, every view within the dE goals with no NaN/Inf and no black holes, and both hues in
the sweep.

Per view, for incremental builds: :func:`plan_views` names the views and what each reads (its camera, light and
size, and :func:`scene_digest` of the scene content it renders); :func:`verify_views` renders and checks any
subset in one call (shared GL context, shared reference rays) and returns per-view results that can be cached;
:func:`report_from_views` validates and joins them into the report. ``verify_asset(views=[...])`` does both for
a subset; a subset without a light-sweep view cannot run the hue check, and the report's ``notes`` say so.

Assets without a LUT (``shading.variant = "physical"``): the renderers here draw the paper's LUT method (the
GLSL shaders) and the exact spectra (the reference); neither is a renderer's thin-film BSDF. Rather than skip
the GL/reference comparison, :func:`verification_scene` bakes a *verification-only* LUT in memory from the film
the asset records (RockDoveThinFilmAPI), at the build's default size
(:meth:`pipeline.render.scene.RenderScene.load_lut`); every check then runs (geometry, textures, thickness
primvar, film against the exact reference) and the report's ``notes`` say that the asset's own physical
MaterialX network was only validated, not rendered. Nothing is written into the asset.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import platform
import shutil
import sys
import time

import numpy as np

from ..usd.layout import MARKER
from . import compare as cmp
from .boundary import boundary_note, boundary_shape

#: The light-view angle (deg) of the extra sweep view: 90 deg is the paper's green/purple flip.
BOUNDARY_SWEEP_ANGLE_DEG = 90.0
#: Each of green and purple must hold at least this fraction of the chromatic sweep pixels.
MIN_HUE_FRACTION = 0.02
DEFAULT_SIZE = 512
#: Turntable + light-sweep views of pipeline.render.views.default_views (the boundary sweep view is added).
DEFAULT_VIEWS = 4
LIBRARIES = ("numpy", "scipy", "colour", "trimesh", "embreex", "pxr", "pyrender", "OpenGL", "PIL",
             "matplotlib", "OpenEXR", "MaterialX")


def library_versions() -> dict:
    """Versions of Python, rockdove and the libraries the verification uses (None when not installed)."""
    from importlib import metadata

    from .. import __version__

    dist = {"colour": "colour-science", "PIL": "pillow", "pxr": "usd-core", "OpenGL": "PyOpenGL"}
    out = {"python": platform.python_version(), "rockdove": __version__}
    for name in LIBRARIES:
        try:
            out[name] = metadata.version(dist.get(name, name))
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


#: The marker a published build leaves in the asset folder (pipeline.build.publish): tool, version,
#: configuration hash, preset, stage keys.
BUILD_MARKER = MARKER


def _asset_configuration(layer_path: str) -> dict:
    """What the asset records about the configuration it was built from: the build marker
    (:data:`BUILD_MARKER`, beside the root layer) and any root-layer ``customLayerData`` or default-prim
    ``assetInfo`` key containing "config"; empty when the asset records nothing (e.g. a bare assembly)."""
    from pxr import Sdf

    found = {}
    marker = os.path.join(os.path.dirname(os.path.abspath(layer_path)), BUILD_MARKER)
    if os.path.isfile(marker):
        try:
            with open(marker, encoding="utf-8") as f:
                found["marker"] = json.load(f)
        except (OSError, ValueError) as exc:
            found["marker_error"] = f"{marker}: {exc}"
    layer = Sdf.Layer.FindOrOpen(layer_path)
    if layer is None:
        return found

    def pick(d, where):
        for k, v in dict(d or {}).items():
            if "config" in k.lower():
                found[f"{where}:{k}"] = v

    pick(layer.customLayerData, "customLayerData")
    prim = layer.GetPrimAtPath(f"/{layer.defaultPrim}") if layer.defaultPrim else None
    if prim:
        pick(prim.assetInfo, "assetInfo")
    return json.loads(json.dumps(found, default=str))


def run_validation(layer_path: str) -> dict:
    """Run the asset validator; returns ``{"passed": bool, "details": ..., "error": str | None}``."""
    try:
        from ..usd.validate import validate_asset
    except ImportError as exc:
        return {"passed": False, "details": None,
                "error": f"the validator pipeline.usd.validate.validate_asset is not available ({exc})"}
    try:
        result = validate_asset(layer_path)
    except ValueError as exc:
        return {"passed": False, "details": None, "error": f"validation raised: {exc}"}
    return {"passed": result.clean, "details": json.loads(json.dumps(result.to_dict(), default=str)), "error": None}


def verification_views(scene, width: int, height: int, n_views: int = DEFAULT_VIEWS) -> list:
    """The default views (``n_views`` of them), the light sweep at :data:`BOUNDARY_SWEEP_ANGLE_DEG` (same still
    camera), and the hero 3/4 view at ``HERO_SCALE`` times the size (:func:`pipeline.render.views.hero_view`)."""
    from ..render.views import HERO_SCALE, default_views, hero_view, light_sweep_views

    views = default_views(scene, width, height, n=n_views)
    sweep = [v for v in views if v.name.startswith("sweep_")]
    if sweep:
        s = sweep[0]
        neck = np.asarray(scene.neck_centre_m, np.float64)
        eye = s.camera_to_world[:3, 3]
        dist = float(np.linalg.norm(eye - neck))
        extra = light_sweep_views(neck, 1, width, height, angles_deg=[BOUNDARY_SWEEP_ANGLE_DEG], distance_m=dist,
                                  yfov_deg=float(np.degrees(s.yfov_rad)), camera_direction=(eye - neck) / dist)
        if extra[0].name not in {v.name for v in views}:
            views.append(extra[0])
    views.append(hero_view(scene.bounds_m, HERO_SCALE * width, HERO_SCALE * height))
    return views


def _default_out_dir(layer_path: str) -> str:
    return os.path.join(os.path.dirname(os.path.abspath(layer_path)), "verify")


# -- assets without a LUT (physical-only shading) ------------------------------------------------------------
PHYSICAL_ONLY_NOTE = (
    "physical-only asset (no LUT): its MaterialX shading hands the film to a renderer's own thin-film BSDF, which "
    "no renderer here implements; the GL renderer draws the paper's LUT method, so verification baked a "
    "verification-only LUT ({shape}, {lo:g}-{hi:g} nm, not part of the asset) in memory from the film the asset "
    "records (RockDoveThinFilmAPI) and checked it against the exact spectral reference: geometry, textures, "
    "thickness primvar and film are verified; the physical MaterialX network itself is only validated")


@contextlib.contextmanager
def verification_scene(asset):
    """Read an asset back for verification: ``(root layer, RenderScene, LUT baked in memory or None, notes)``.

    An asset with a LUT is read as it is. For a LUT-less (physical-only) asset the renderers draw a LUT baked in
    memory from the film it records (:meth:`pipeline.render.scene.RenderScene.load_lut`), returned here with
    a note saying so (:data:`PHYSICAL_ONLY_NOTE`). Nothing is written. (A context manager so that callers
    need not change if reading ever holds resources again.)
    """
    from ..render.scene import load_scene

    scene = load_scene(asset)
    if scene.film is None or scene.film.lut_file is not None:
        yield scene.root_layer, scene, None, []
        return
    lut = scene.load_lut()
    lo, hi = lut.thickness_range_nm
    note = PHYSICAL_ONLY_NOTE.format(shape=f"{lut.n_thickness} x {lut.n_angle}", lo=lo, hi=hi)
    yield scene.root_layer, scene, lut, [note]


# -- per-view rendering and checks ---------------------------------------------------------------------------
def scene_digest(scene) -> str:
    """sha256 of what a verification view reads from a scene: every part's arrays, material values and texture
    bytes, the film and the LUT's bytes, the variant selections; not file paths (an asset moved or rebuilt
    with the same content has the same digest)."""
    h = hashlib.sha256()

    def add(label, data: bytes):
        h.update(label.encode() + b"\0" + data + b"\0")

    def add_file(label, path):
        if path:
            with open(path, "rb") as f:
                add(label, f.read())

    for p in scene.parts:
        meta = {"name": p.name, "kind": p.material_kind, "srgb": bool(p.base_colour_srgb),
                "base_colour": np.asarray(p.base_colour, np.float64).tolist(),
                "opacity_threshold": float(p.opacity_threshold)}
        add("part", json.dumps(meta, sort_keys=True).encode())
        for f in ("positions_m", "normals", "triangles", "st", "thickness_nm", "neck_s"):
            a = getattr(p, f)
            if a is not None:
                a = np.ascontiguousarray(a)
                add(f"{p.name}.{f}:{a.dtype.str}:{a.shape}", a.tobytes())
        add_file(f"{p.name}.base", p.base_colour_texture)
        add_file(f"{p.name}.mask", p.mask_texture)
    if scene.film is not None:
        film = {k: v for k, v in scene.film.to_dict().items() if k != "lut_file"}
        add("film", json.dumps(film, sort_keys=True, default=str).encode())
        add_file("lut", scene.film.lut_file)
    add("variants", json.dumps(dict(scene.variants), sort_keys=True).encode())
    return h.hexdigest()


def _select(all_views: list, names) -> list:
    if names is None:
        return list(all_views)
    known = {v.name: v for v in all_views}
    names = list(names)
    unknown = [n for n in names if n not in known]
    if unknown or not names:
        raise ValueError(f"views={names!r}: unknown or none; allowed names: {sorted(known)}")
    return [known[n] for n in dict.fromkeys(names)]


def plan_views(asset, width: int = DEFAULT_SIZE, height: int = DEFAULT_SIZE, n_views: int = DEFAULT_VIEWS) -> dict:
    """What each verification view reads: ``{view name: {"view": View.to_dict(), "scene": scene_digest}}``.

    Two plans are equal exactly when the renders and checks of those views would be the same, so a build can
    key each view by its entry (pipeline.build.stages) and re-render only views whose entry changed.
    """
    _check_size(width, height)
    with verification_scene(asset) as (_, scene, _, _):
        digest = scene_digest(scene)
        return {v.name: {"view": v.to_dict(), "scene": digest}
                for v in verification_views(scene, int(width), int(height), n_views)}


def _check_size(width, height) -> None:
    for key, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or int(v) != v or int(v) < 16:
            raise ValueError(f"{key} must be an integer >= 16, got {v!r}")


def _render_and_check(scene, lut, views, out: str, *, subfolders: bool, say, hits=None, refs=None,
                      gl_images=None) -> dict:
    """Render ``views`` (GL and reference), compare, write each view's images; ``{name: view result}``.

    ``refs``: the half-angle references of ``views`` when already rendered (:func:`verify_asset` renders every
    lobe the hosts need in one call, sharing the ray casts); ``gl_images``: a dict that receives each view's
    GL radiance (the ``glsl`` host's images); ``hits``: cached ray casts (:func:`pipeline.verify.rays.cast_hits`)."""
    from . import report as rep
    from ..render.images import save_png
    from ..spectral import linear_to_srgb8
    from .reference_image import render_reference

    failures_all = []
    say(f"GL renders ({len(views)} views)")
    t = time.perf_counter()
    try:
        from ..render.gl import render_views

        gl_results = render_views(scene, views, lut=lut)
    except ImportError as exc:
        gl_results = None
        failures_all.append(f"GL renderer pipeline.render.gl is not available ({exc})")
    t_gl = (time.perf_counter() - t) / len(views)
    say(f"CPU reference ({len(views)} views)")
    t = time.perf_counter()
    ref_results = render_reference(scene, views, hits=hits) if refs is None else refs
    t_ref = (time.perf_counter() - t) / len(views)
    if gl_images is not None and gl_results is not None:
        gl_images.update({v.name: cmp.gl_arrays(r)["rgb"] for v, r in zip(views, gl_results)})
    say("comparing")
    results = {}
    for i, v in enumerate(views):
        t = time.perf_counter()
        folder = os.path.join(out, v.name) if subfolders else out
        os.makedirs(folder, exist_ok=True)
        m = cmp.compare(gl_results[i], ref_results[i], scene) if gl_results is not None else None
        sweep = v.name.startswith("sweep_")
        hue = boundary = None
        if sweep:
            cls = m.cls if m is not None else _reference_classes(ref_results[i], scene)
            rgb = np.asarray(cmp.gl_arrays(gl_results[i])["rgb"] if m is not None else ref_results[i].rgb, np.float64)
            hue = cmp.hue_histogram(rgb[cls >= 0])
            boundary = {**cmp.boundary_straightness(cls), **boundary_shape(rgb, cls >= 0)}
        files, rows = {}, []
        ref_png = linear_to_srgb8(ref_results[i].rgb)
        files["reference"] = os.path.basename(save_png(ref_png, os.path.join(folder, f"{v.name}_reference.png")))
        if gl_results is not None:
            gl_png = linear_to_srgb8(cmp.gl_arrays(gl_results[i])["rgb"])
            files["gl"] = os.path.basename(save_png(gl_png, os.path.join(folder, f"{v.name}_gl.png")))
            rows.append(gl_png)
        rows.append(ref_png)
        if m is not None:
            files["dE"] = os.path.basename(rep.de_map_png(
                os.path.join(folder, f"{v.name}_dE.png"), m.de_map,
                f"{v.name}: dE2000 median {m.de_median:.2f}, p95 {m.de_p95:.2f}, max {m.de_max:.2f}"))
            rows.append(rep.de_colour(m.de_map))
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
    return results


def verify_views(asset, views=None, out_dir=None, width: int = DEFAULT_SIZE, height: int = DEFAULT_SIZE,
                 n_views: int = DEFAULT_VIEWS, subfolders: bool = False, progress=None, hits=None) -> dict:
    """Render and check a subset of the verification views; results that can be cached and combined.

    Parameters
    ----------
    asset : path
        The asset folder or its root layer.
    views : list of str, optional
        View names (:func:`plan_views` lists them); default all.
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
        Ready-made reference ray casts (:func:`pipeline.verify.rays.cast_hits`, e.g. cached by the build
        keyed by :func:`pipeline.verify.rays.ray_digest` and the camera); the results do not change.

    Returns
    -------
    dict
        View name -> result: ``view``, ``setup`` (View.to_dict), ``sweep`` (bool), ``metrics``
        (ViewMetrics.summary or None without GL), ``failures``, ``reference`` (timings, stats), ``hue``
        (hue_histogram counts of a sweep view's compared pixels, else None), ``boundary`` (sweep views),
        ``files`` (image file names), ``dir`` (their folder), ``timings_s``, ``notes``, and ``sheet_row`` (the
        contact-sheet images, uint8 arrays: not JSON). Combine them with :func:`report_from_views`.
    """
    _check_size(width, height)
    say = progress or (lambda msg: None)
    with verification_scene(asset) as (layer, scene, lut, notes):
        out = os.path.abspath(os.fspath(out_dir)) if out_dir else _default_out_dir(layer)
        os.makedirs(out, exist_ok=True)
        chosen = _select(verification_views(scene, int(width), int(height), n_views), views)
        results = _render_and_check(scene, lut, chosen, out, subfolders=subfolders, say=say, hits=hits)
    for r in results.values():
        r["notes"] = list(notes)
    return results


def report_from_views(asset, view_results: dict, out_dir=None, width: int = DEFAULT_SIZE,
                      height: int = DEFAULT_SIZE, bench_dir=None, progress=None, *, reused=(),
                      published_asset=None) -> dict:
    """Validate the asset and combine per-view results (:func:`verify_views`, possibly from a cache) into the
    report (``report.json``, ``report.html`` and the images in ``out_dir``); returns the report dict.

    ``reused`` names the views whose results came from a cache (recorded in the report).
    ``published_asset``: the root layer's path once published (the build verifies a staging folder), which the
    report names instead of the layer read.
    """
    with verification_scene(asset) as (layer, scene, lut, notes):
        return _combine(layer, scene, lut, notes, view_results, out_dir, width, height, bench_dir,
                        progress or (lambda msg: None), reused=reused, t_start=time.perf_counter(),
                        published_asset=published_asset)


def verify_asset(asset, out_dir=None, width: int = DEFAULT_SIZE, height: int = DEFAULT_SIZE,
                 bench_dir=None, progress=None, views=None, n_views: int = DEFAULT_VIEWS, hosts=("glsl",)) -> dict:
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
        Folder of benchmark plots to include (default ``build/bench`` under the current directory).
    progress : callable, optional
        ``progress(message)`` for each step.
    views : list of str, optional
        Check only these views (names as in :func:`plan_views`); default all. With a subset that holds no
        light-sweep view the hue check cannot run: the report says so in ``notes`` (it is not counted as met).
    n_views : int
        Turntable + sweep views (:func:`pipeline.render.views.default_views`), plus the boundary sweep view.
    hosts : iterable of str or None
        Hosts (:data:`pipeline.hosts.HOSTS`) that render the same views, each compared with the reference of
        its lobe (:mod:`pipeline.verify.host_check`); None: every registered host available here. ``glsl``
        always runs. Unavailable hosts are reported as skipped with their reason; a host that fails or misses
        its goals fails the verification.

    Returns
    -------
    dict: the content of report.json (``report["hosts"]``: one entry per host); ``report["passed"]`` says whether verification passed,
    ``report["failures"]`` why not, ``report["notes"]`` what was not or differently checked (e.g. a
    physical-only asset's verification-only LUT).
    """
    from ..hosts import select
    from .host_check import check_hosts
    from .reference_image import render_reference_lobes

    _check_size(width, height)
    say = progress or (lambda msg: None)
    t_start = time.perf_counter()
    selection = select(hosts)  # unknown names: ValueError before any work
    with verification_scene(asset) as (layer, scene, lut, notes):
        out = os.path.abspath(os.fspath(out_dir)) if out_dir else _default_out_dir(layer)
        os.makedirs(out, exist_ok=True)
        chosen = _select(verification_views(scene, int(width), int(height), n_views), views)
        lobes = ("half_angle", *(m.LOBE for m in selection.available))
        say(f"CPU reference ({len(chosen)} views, lobes {', '.join(dict.fromkeys(lobes))})")
        t = time.perf_counter()
        refs = render_reference_lobes(scene, chosen, lobes)
        t_ref = time.perf_counter() - t
        gl_images = {}
        results = _render_and_check(scene, lut, chosen, out, subfolders=False, say=say, refs=refs["half_angle"],
                                    gl_images=gl_images)
        for r in results.values():
            r["timings_s"]["reference"] = t_ref / len(chosen)
        t = time.perf_counter()
        host_entries, host_images = check_hosts(layer, scene, chosen, selection, refs, out,
                                                rendered={"glsl": gl_images} if gl_images else None, say=say)
        return _combine(layer, scene, lut, notes, results, out, width, height, bench_dir, say, t_start=t_start,
                        hosts=(host_entries, host_images, time.perf_counter() - t))


def _combine(layer, scene, lut, notes, results: dict, out_dir, width, height, bench_dir, say, *, reused=(),
             t_start, hosts=None, published_asset=None) -> dict:
    from . import report as rep

    out = os.path.abspath(os.fspath(out_dir)) if out_dir else _default_out_dir(layer)
    os.makedirs(out, exist_ok=True)
    timings, failures, notes = {}, [], list(notes)
    say("validating")
    t = time.perf_counter()
    validation = run_validation(layer)
    timings["validation"] = time.perf_counter() - t
    if not validation["passed"]:
        failures.append("validation: " + (validation["error"] or "the validator reported problems"))
    results = list(results.values())
    for key in ("gl", "reference", "compare"):
        timings[key] = sum(r["timings_s"][key] for r in results)
    for r in results:
        failures.extend(f for f in r["failures"] if f not in failures)
    metrics = [r["metrics"] for r in results if r["metrics"] is not None]
    if metrics and sum(m["n_pixels"] for m in metrics) == 0:
        failures.append("no view has feather pixels away from silhouette edges to compare")
    sweeps = [r for r in results if r["sweep"]]
    if sweeps:
        hue = {k: v for k, v in sweeps[0]["hue"].items()}
        for r in sweeps[1:]:
            for k in ("grey", "green", "purple", "other"):
                hue[k] += r["hue"][k]
            hue["counts"] = [a + b for a, b in zip(hue["counts"], r["hue"]["counts"])]
        chromatic = hue["green"] + hue["purple"] + hue["other"]
        for name in ("green", "purple"):
            if chromatic == 0 or hue[name] < MIN_HUE_FRACTION * chromatic:
                failures.append(f"hue: the light sweep shows too little {name} ({hue[name]} of {chromatic} "
                                f"chromatic feather pixels, need >= {MIN_HUE_FRACTION:.0%})")
    else:
        hue = cmp.hue_histogram(np.zeros((0, 3)))
        notes.append("hue check not run: no light-sweep view among the views checked "
                     f"({', '.join(r['view'] for r in results)})")

    notes.extend(boundary_note(r["view"], r["boundary"]) for r in sweeps
                 if r["view"] == f"sweep_{int(round(BOUNDARY_SWEEP_ANGLE_DEG)):03d}")
    say("writing the report")
    t = time.perf_counter()
    images = {"views": {}}
    sheet_rows = []
    for r in results:
        if os.path.abspath(r["dir"]) != out:
            for f in r["files"].values():
                shutil.copyfile(os.path.join(r["dir"], f), os.path.join(out, f))
        images["views"][r["view"]] = dict(r["files"])
        sheet_rows.append((r["view"], list(r["sheet_row"])))
    images["contact_sheet"] = os.path.basename(rep.contact_sheet(os.path.join(out, "contact_sheet.png"), sheet_rows))
    lut_info = None
    if scene.film is not None:
        try:
            lut_used = lut if lut is not None else scene.load_lut()
            images["lut"] = os.path.basename(rep.lut_png(os.path.join(out, "lut.png"), lut_used))
            lut_info = {"file": None if lut is not None else scene.film.lut_file,
                        "shape": [lut_used.n_thickness, lut_used.n_angle],
                        "thickness_range_nm": list(lut_used.thickness_range_nm),
                        "angle_warp_gamma": lut_used.angle_warp_gamma, "colour_space": lut_used.colour_space,
                        "metadata": dict(lut_used.metadata), "verification_only": lut is not None}
        except (ValueError, OSError) as exc:
            failures.append(f"LUT {scene.film.lut_file!r} could not be read: {exc}")
        lo, hi = scene.thickness_range_nm
        thicknesses = sorted({lo, 0.5 * (lo + hi), hi})
        images["spectra"] = os.path.basename(rep.spectra_png(os.path.join(out, "spectra.png"), scene.film,
                                                             thickness_nm=thicknesses))
    images["hue"] = os.path.basename(rep.hue_png(os.path.join(out, "hue.png"), hue, "light sweep"))
    host_entries = []
    if hosts is not None:
        host_entries, images["hosts"], timings["hosts"] = hosts
        for h in host_entries:
            if h.get("skipped"):  # reported with its reason (report["hosts"], the CLI's SKIPPED line)
                continue
            if h.get("error"):
                failures.append(f"host {h['name']} failed: {h['error']}")
            elif not h["passed"]:
                failures.append(f"host {h['name']} ({h['variant']}, {h['lobe']} lobe): {'; '.join(h['failures'])}")
    bench = bench_dir if bench_dir is not None else os.path.join(os.getcwd(), "build", "bench")
    images["bench"] = rep.copy_bench_plots(out, bench)
    timings["report"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t_start

    config = _asset_configuration(layer)
    film = scene.film.to_dict() if scene.film is not None else None
    if os.path.isfile(os.path.join(out, "viewer.html")):  # written beside the report (pipeline.web.viewer)
        images["viewer"] = "viewer.html"
    report = {
        "asset": published_asset or layer,
        "asset_sha256": digest(layer),
        "out_dir": out,
        "passed": not failures,
        "failures": failures,
        "notes": notes,
        "goals": {"median_dE": cmp.MEDIAN_DE_GOAL, "p95_dE": cmp.P95_DE_GOAL,
                  "black_fraction": cmp.BLACK_FRACTION_GOAL, "min_hue_fraction": MIN_HUE_FRACTION},
        "validation": validation,
        "views": metrics,
        "views_reused": [n for n in (r["view"] for r in results) if n in set(reused)],
        "view_setup": [r["setup"] for r in results],
        "reference": [r["reference"] for r in results],
        "hue_sweep": hue,
        "hosts": host_entries,
        "boundary": {"per_view": {r["view"]: r["boundary"] for r in sweeps},
                     "method": "TLS line through green/purple boundary points; RMS perpendicular distance (px) "
                               "and RMS / boundary length; coherence and curvature: pipeline.verify.boundary"},
        "film": film,
        "lut": lut_info,
        "variants": dict(scene.variants),
        "configuration": config,
        "configuration_hash": _config_hash(config),
        "render": {"width": int(width), "height": int(height), "erode_px": 1},
        "timings_s": timings,
        "versions": library_versions(),
        "argv": list(sys.argv),
    }
    rep.write_json(os.path.join(out, "report.json"), report)
    rep.write_html(os.path.join(out, "report.html"), report, images)
    return report


def _config_hash(config: dict):
    """The configuration hash the asset records (the build marker's ``config_hash``), else None."""
    marker = config.get("marker")
    if isinstance(marker, dict) and marker.get("config_hash"):
        return marker["config_hash"]
    for k, v in config.items():
        if "hash" in k.lower():
            return v
    return None


def _reference_classes(ref_result, scene) -> np.ndarray:
    """Hue classes of the reference's feather pixels (used when there is no GL render)."""
    feather = np.isin(ref_result.part_id, [i + 1 for i, p in enumerate(scene.parts) if p.is_feather])
    feather &= ref_result.mask >= cmp.STRUCTURAL_MASK
    cls = np.full(feather.shape, -1, np.int8)
    if feather.any():
        cls[feather] = cmp.hue_classes(ref_result.rgb[feather].astype(np.float64), sides=True)[2]
    return cls


def summary(report: dict) -> dict:
    """The short form ``rockdove verify --json`` prints: pass/fail, failures, per-view dE, hue, boundary."""
    return {
        "passed": report["passed"],
        "failures": report["failures"],
        "asset": report["asset"],
        "out_dir": report["out_dir"],
        "validation": report["validation"]["passed"],
        "views": {m["view"]: {k: m[k] for k in ("n_pixels", "de_median", "de_p95", "de_max", "n_black", "passed")}
                  for m in report["views"]},
        "notes": list(report.get("notes", [])),
        "hue_sweep": {k: report["hue_sweep"][k] for k in ("green", "purple", "grey", "other")},
        "boundary_rms_px": {k: v["rms_px"] for k, v in report["boundary"]["per_view"].items()},
        "boundary_shape": {k: {"green_share": v["coherence"]["green"]["largest_share"],
                               "purple_share": v["coherence"]["purple"]["largest_share"],
                               "line_over_curve": v["curvature"]["ratio"]}
                           for k, v in report["boundary"]["per_view"].items() if "coherence" in v},
        "hosts": [{k: v for k, v in h.items() if k not in ("per_view", "failures")} for h in report.get("hosts", [])],
        "timings_s": report["timings_s"],
    }


def digest(path) -> str:
    """sha256 of a file (used to record what was verified)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()

"""Verify a written asset by looking at it: validation, GL renders, the exact CPU reference, checks, report.

:func:`verify_asset` is what ``rockdove verify`` runs (issue 5):

1. validation with :func:`pipeline.usd.validate.validate_asset`; a missing validator is a failure, not a pass;
2. the asset is read back from disk (:func:`pipeline.render.scene.load_scene`);
3. views: :func:`pipeline.render.views.default_views` (2 turntable frames, the light sweep at 60 and 120 deg)
   plus the sweep at the flip itself (:data:`BOUNDARY_SWEEP_ANGLE_DEG`), where the green/purple boundary
   crosses the neck;
4. GL renders (:func:`pipeline.render.gl.render_views`) and the reference
   (:func:`pipeline.render.reference.render_reference`), timed;
5. per view :func:`pipeline.render.compare.compare` (dE2000 goals, NaN/Inf, black holes), the hue histogram
   over the sweep views (both green and purple must appear), and the boundary straightness of every sweep view
   (reported: the paper preset keeps the boundary straight, the measured one bends it);
6. the report (:mod:`pipeline.render.report`).

Pass: validation clean, every view within the dE goals with no NaN/Inf and no black holes, and both hues in
the sweep.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import sys
import time

import numpy as np

from . import compare as cmp

#: The light-view angle (deg) of the extra sweep view: 90 deg is the paper's green/purple flip.
BOUNDARY_SWEEP_ANGLE_DEG = 90.0
#: Each of green and purple must hold at least this fraction of the chromatic sweep pixels.
MIN_HUE_FRACTION = 0.02
DEFAULT_SIZE = 512
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
BUILD_MARKER = ".rockdove-asset.json"


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
    return {"passed": _validation_ok(result), "details": _jsonable(result), "error": None}


def _validation_ok(result) -> bool:
    for attr in ("passed", "ok", "clean", "valid"):
        v = getattr(result, attr, None) if not isinstance(result, dict) else result.get(attr)
        if v is not None:
            return bool(v() if callable(v) else v)
    if isinstance(result, bool):
        return result
    if isinstance(result, (list, tuple)):
        return len(result) == 0
    errors = getattr(result, "errors", None)
    if errors is not None:
        return len(errors) == 0
    raise ValueError(f"validate_asset returned {type(result).__name__}, which has no pass/fail attribute")


def _jsonable(obj):
    for name in ("to_dict", "as_dict", "summary"):
        f = getattr(obj, name, None)
        if callable(f):
            return json.loads(json.dumps(f(), default=str))
    try:
        return json.loads(json.dumps(obj, default=lambda o: getattr(o, "__dict__", str(o))))
    except (TypeError, ValueError):
        return str(obj)


def verification_views(scene, width: int, height: int) -> list:
    """The default views plus the light sweep at :data:`BOUNDARY_SWEEP_ANGLE_DEG` (same still camera)."""
    from .views import default_views, light_sweep_views

    views = default_views(scene, width, height)
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
    return views


def _default_out_dir(layer_path: str) -> str:
    return os.path.join(os.path.dirname(os.path.abspath(layer_path)), "verify")


def verify_asset(asset, out_dir=None, width: int = DEFAULT_SIZE, height: int = DEFAULT_SIZE,
                 bench_dir=None, progress=None) -> dict:
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

    Returns
    -------
    dict: the content of report.json; ``report["passed"]`` says whether verification passed and
    ``report["failures"]`` why not.
    """
    from . import report as rep
    from .reference import render_reference, to_display8
    from .scene import load_scene, resolve_asset_path

    for key, v in (("width", width), ("height", height)):
        if int(v) != v or int(v) < 16:
            raise ValueError(f"{key} must be an integer >= 16, got {v!r}")
    say = progress or (lambda msg: None)
    t_start = time.perf_counter()
    layer = resolve_asset_path(asset)
    out = os.path.abspath(os.fspath(out_dir)) if out_dir else _default_out_dir(layer)
    os.makedirs(out, exist_ok=True)
    timings, failures = {}, []

    say("validating")
    t = time.perf_counter()
    validation = run_validation(layer)
    timings["validation"] = time.perf_counter() - t
    if not validation["passed"]:
        failures.append("validation: " + (validation["error"] or "the validator reported problems"))

    say("reading the asset back")
    t = time.perf_counter()
    scene = load_scene(layer)
    timings["load_scene"] = time.perf_counter() - t
    views = verification_views(scene, int(width), int(height))

    say(f"GL renders ({len(views)} views)")
    t = time.perf_counter()
    try:
        from .gl import render_views

        gl_results = render_views(scene, views)
    except ImportError as exc:
        gl_results = None
        failures.append(f"GL renderer pipeline.render.gl is not available ({exc})")
    timings["gl"] = time.perf_counter() - t

    say(f"CPU reference ({len(views)} views)")
    t = time.perf_counter()
    ref_results = render_reference(scene, views)
    timings["reference"] = time.perf_counter() - t

    say("comparing")
    t = time.perf_counter()
    metrics = []
    if gl_results is not None:
        metrics = [cmp.compare(g, r, scene) for g, r in zip(gl_results, ref_results)]
        for m in metrics:
            failures.extend(m.failures)
        if sum(m.n_pixels for m in metrics) == 0:
            failures.append("no view has feather pixels away from silhouette edges to compare")
    sweep_idx = [i for i, v in enumerate(views) if v.name.startswith("sweep_")]
    sweep_pixels = []
    boundary = {}
    for i in sweep_idx:
        m_cls = metrics[i].cls if metrics else _reference_classes(ref_results[i], scene)
        if metrics:
            mask = m_cls >= 0
            sweep_pixels.append(np.asarray(cmp.gl_arrays(gl_results[i])["rgb"], np.float64)[mask])
        else:
            sweep_pixels.append(ref_results[i].rgb[m_cls >= 0].astype(np.float64))
        boundary[views[i].name] = cmp.boundary_straightness(m_cls)
    hue = cmp.hue_histogram(np.concatenate(sweep_pixels) if sweep_pixels else np.zeros((0, 3)))
    chromatic = hue["green"] + hue["purple"] + hue["other"]
    for name in ("green", "purple"):
        if chromatic == 0 or hue[name] < MIN_HUE_FRACTION * chromatic:
            failures.append(f"hue: the light sweep shows too little {name} ({hue[name]} of {chromatic} chromatic "
                            f"feather pixels, need >= {MIN_HUE_FRACTION:.0%})")
    timings["compare"] = time.perf_counter() - t

    say("writing the report")
    t = time.perf_counter()
    images = {"views": {}}
    sheet_rows = []
    for i, v in enumerate(views):
        files = {}
        ref_png = to_display8(ref_results[i].rgb)
        files["reference"] = os.path.basename(rep.save_png(os.path.join(out, f"{v.name}_reference.png"), ref_png))
        row = []
        if gl_results is not None:
            gl_png = to_display8(cmp.gl_arrays(gl_results[i])["rgb"])
            files["gl"] = os.path.basename(rep.save_png(os.path.join(out, f"{v.name}_gl.png"), gl_png))
            row.append(gl_png)
        row.append(ref_png)
        if metrics:
            m = metrics[i]
            files["dE"] = os.path.basename(rep.de_map_png(
                os.path.join(out, f"{v.name}_dE.png"), m.de_map,
                f"{v.name}: dE2000 median {m.de_median:.2f}, p95 {m.de_p95:.2f}, max {m.de_max:.2f}"))
            row.append(rep.de_colour(m.de_map))
        images["views"][v.name] = files
        sheet_rows.append((v.name, row))
    images["contact_sheet"] = os.path.basename(rep.contact_sheet(os.path.join(out, "contact_sheet.png"), sheet_rows))
    lut_info = None
    if scene.film is not None:
        try:
            lut = scene.load_lut()
            images["lut"] = os.path.basename(rep.lut_png(os.path.join(out, "lut.png"), lut))
            lut_info = {"file": scene.film.lut_file, "shape": [lut.n_thickness, lut.n_angle],
                        "thickness_range_nm": list(lut.thickness_range_nm), "angle_warp_gamma": lut.angle_warp_gamma,
                        "colour_space": lut.colour_space, "metadata": dict(lut.metadata)}
        except (ValueError, OSError) as exc:
            failures.append(f"LUT {scene.film.lut_file!r} could not be read: {exc}")
        lo, hi = scene.film.thickness_range_nm
        thicknesses = sorted({lo, 0.5 * (lo + hi), hi})
        images["spectra"] = os.path.basename(rep.spectra_png(os.path.join(out, "spectra.png"), scene.film,
                                                             thickness_nm=thicknesses))
    images["hue"] = os.path.basename(rep.hue_png(os.path.join(out, "hue.png"), hue, "light sweep"))
    bench = bench_dir if bench_dir is not None else os.path.join(os.getcwd(), "build", "bench")
    images["bench"] = rep.copy_bench_plots(out, bench)
    timings["report"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t_start

    config = _asset_configuration(layer)
    report = {
        "asset": layer,
        "asset_sha256": digest(layer),
        "out_dir": out,
        "passed": not failures,
        "failures": failures,
        "goals": {"median_dE": cmp.MEDIAN_DE_GOAL, "p95_dE": cmp.P95_DE_GOAL,
                  "black_fraction": cmp.BLACK_FRACTION_GOAL, "min_hue_fraction": MIN_HUE_FRACTION},
        "validation": validation,
        "views": [m.summary() for m in metrics],
        "view_setup": [v.to_dict() for v in views],
        "reference": [{"view": r.view, "timings_s": r.timings_s, "stats": r.stats} for r in ref_results],
        "hue_sweep": hue,
        "boundary": {"per_view": boundary, "method": "TLS line through green/purple boundary points; RMS "
                     "perpendicular distance (px) and RMS / boundary length"},
        "film": scene.film.to_dict() if scene.film is not None else None,
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
        "hue_sweep": {k: report["hue_sweep"][k] for k in ("green", "purple", "grey", "other")},
        "boundary_rms_px": {k: v["rms_px"] for k, v in report["boundary"]["per_view"].items()},
        "timings_s": report["timings_s"],
    }


def digest(path) -> str:
    """sha256 of a file (used to record what was verified)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()

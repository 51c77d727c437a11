"""The verdict of a verification and its report: per-view results (fresh or cached) joined with the asset's
validation, the hue check over the light sweep, the boundary notes and the hosts' entries, written as
``report.json`` and ``report.html`` (:mod:`rockdove.verify.report`)."""

from __future__ import annotations

import functools
import logging
import operator
import os
import shutil
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..digest import file_sha256
from . import compare, provenance, report
from .anatomy import measure_scene
from .boundary import Boundary, boundary_note
from .inputs import BOUNDARY_SWEEP_ANGLE_DEG
from .results import Goals, HostResult, ItemsUsed, MotionCheck, Report, ViewResult

_log = logging.getLogger(__name__)
#: Each of green and purple must hold at least this fraction of the chromatic sweep pixels.
MIN_HUE_FRACTION = 0.02


def default_out_dir(layer_path: str) -> str:
    """Where a verification of ``layer_path`` writes by default: ``verify/`` beside the root layer."""
    return os.path.join(os.path.dirname(os.path.abspath(layer_path)), "verify")


@dataclass(frozen=True)
class Checked:
    """What a verification rendered and compared: the asset read back, its views' and hosts' results, the cache
    items used, the views' size, the hosts' seconds and the start (``time.perf_counter``)."""

    layer: str
    scene: Any
    lut: Any
    notes: tuple[str, ...]
    views: tuple[ViewResult, ...]
    hosts: tuple[HostResult, ...]
    items: ItemsUsed
    size: tuple[int, int]
    hosts_seconds: float
    t_start: float
    motion: MotionCheck | None = None


def sweep_hues(views: tuple[ViewResult, ...]) -> tuple[compare.HueHistogram, list[str], list[str]]:
    """The light sweep's hues over its views, the hue check's failures and notes (a run without a sweep view)."""
    sweeps = [r.hue for r in views if r.sweep and r.hue is not None]
    if not sweeps:
        return compare.hue_histogram(np.zeros((0, 3))), [], [
            f"hue check not run: no light-sweep view among the views checked ({', '.join(r.view for r in views)})"]
    hue = functools.reduce(operator.add, sweeps)
    return hue, [f"hue: the light sweep shows too little {name} ({n} of {hue.chromatic} chromatic feather pixels, "
                 f"need >= {MIN_HUE_FRACTION:.0%})" for name, n in (("green", hue.green), ("purple", hue.purple))
                 if hue.chromatic == 0 or n < MIN_HUE_FRACTION * hue.chromatic], []


def host_failures(hosts: tuple[HostResult, ...]) -> list[str]:
    """One line per host that failed or raised (a skipped one is reported with its reason, not failed)."""
    return [f"host {h.name} failed: {h.reason}" if h.status == "error" else
            f"host {h.name} ({h.variant}, {h.lobe} lobe): {'; '.join(h.failures)}" for h in hosts
            if h.status in ("error", "failed")]


def figures(checked: Checked, out: str, hue: compare.HueHistogram) -> tuple[report.Figures, dict | None, list[str]]:
    """The report's images in ``out``: ``(images, the LUT's record or None, failures reading the LUT)``."""
    scene, lut, failures = checked.scene, checked.lut, []
    images = report.Figures()
    for r in checked.views:
        if os.path.abspath(r.folder) != out:
            for f in r.files.values():
                shutil.copyfile(os.path.join(r.folder, f), os.path.join(out, f))
        images.views[r.view] = dict(r.files)
    rows = [(r.view, list(r.sheet_row)) for r in checked.views]
    images.contact_sheet = os.path.basename(report.contact_sheet(os.path.join(out, "contact_sheet.png"), rows))
    lut_info = None
    if scene.film is not None:
        try:
            used = lut if lut is not None else scene.load_lut()
            images.lut = os.path.basename(report.lut_png(os.path.join(out, "lut.png"), used))
            lut_info = {"file": None if lut is not None else scene.film.lut_file,
                        "shape": [used.n_thickness, used.n_angle], "thickness_range_nm": list(used.thickness_range_nm),
                        "angle_warp_gamma": used.angle_warp_gamma, "colour_space": used.colour_space,
                        "metadata": dict(used.metadata), "verification_only": lut is not None}
        except (ValueError, OSError) as exc:
            failures.append(f"LUT {scene.film.lut_file!r} could not be read: {exc}")
        lo, hi = scene.thickness_range_nm
        images.spectra = os.path.basename(report.spectra_png(os.path.join(out, "spectra.png"), scene.film,
                                                             thickness_nm=sorted({lo, 0.5 * (lo + hi), hi})))
    images.hue = os.path.basename(report.hue_png(os.path.join(out, "hue.png"), hue, "light sweep"))
    images.hosts = {h.name: h.files for h in checked.hosts if h.files}
    return images, lut_info, failures


def combine(checked: Checked, out: str, *, bench_dir, pictures, published_asset) -> Report:
    """Validate the asset and join what was checked into the verdict and the report (``report.json``,
    ``report.html`` and their images in ``out``). ``bench_dir``: benchmark plots the report shows (None: none);
    ``pictures``: a callable returning the pictures (``{kind: (entry, note)}``) and the kinds drawn and reused."""
    layer, scene, views = checked.layer, checked.scene, checked.views
    _log.info("validating")
    # in a thread, while this one draws the report (pxr's validators and PNG encoding leave the GIL in parts)
    validating = ThreadPoolExecutor(1, thread_name_prefix="rockdove-validate")
    validation_pending = validating.submit(provenance.run_validation, layer)
    validating.shutdown(wait=False)
    timings = {key: sum(r.timings_s[key] for r in views) for key in ("gl", "reference", "compare")}
    failures = list(dict.fromkeys(f for r in views for f in r.failures))
    metrics = tuple(r.metrics for r in views if r.metrics is not None)
    if metrics and sum(m.n_pixels for m in metrics) == 0:
        failures.append("no view has feather pixels away from silhouette edges to compare")
    hue, hue_failures, notes = sweep_hues(views)
    failures += hue_failures
    boundary_view = f"sweep_{int(round(BOUNDARY_SWEEP_ANGLE_DEG)):03d}"
    notes = [*checked.notes, *notes, *(boundary_note(r.view, r.boundary) for r in views
                                       if r.sweep and r.view == boundary_view)]
    _log.info("writing the report")
    t = time.perf_counter()
    images, lut_info, lut_failures = figures(checked, out, hue)
    failures += lut_failures + host_failures(checked.hosts)
    timings["hosts"] = checked.hosts_seconds
    images.bench = report.copy_bench_plots(out, bench_dir)
    _log.info("beauty render and animation")  # rockdove.verify.verification: cached items
    t_pictures = time.perf_counter()
    drawn, ran, reused = pictures()
    for kind, (entry, note) in drawn.items():
        setattr(images, kind, entry)
        notes.extend([note] if note else [])
        timings[kind] = entry["seconds"] if entry else 0.0
    timings["pictures"] = time.perf_counter() - t_pictures
    items = replace(checked.items, ran=replace(checked.items.ran, pictures=ran),
                    reused=replace(checked.items.reused, pictures=reused))
    timings["report"] = time.perf_counter() - t
    validation, timings["validation"] = validation_pending.result()
    if not validation.passed:
        failures.insert(0, "validation: " + (validation.error or "the validator reported problems"))
    anatomy = measure_scene(scene)  # the bird against its published measures (rockdove.verify.anatomy)
    failures.extend([*anatomy.failures, *(checked.motion.failures if checked.motion else ())])
    timings["total"] = time.perf_counter() - checked.t_start
    config = provenance.asset_configuration(layer)
    if os.path.isfile(os.path.join(out, "viewer.html")):  # written beside the report (rockdove.web.viewer)
        images.viewer = "viewer.html"
    result = Report(
        asset=published_asset or layer, asset_sha256=file_sha256(layer), out_dir=out, passed=not failures,
        failures=tuple(failures), notes=tuple(notes),
        goals=Goals(compare.MEDIAN_DE_GOAL, compare.P95_DE_GOAL, compare.BLACK_FRACTION_GOAL, MIN_HUE_FRACTION),
        validation=validation, views=metrics, views_reused=checked.items.reused.views, cache=items,
        view_setup=tuple(r.setup for r in views), reference=tuple(r.reference for r in views), hue_sweep=hue,
        hosts=checked.hosts, anatomy=anatomy, beauty=images.beauty, animation=images.animation,
        boundary=Boundary({r.view: r.boundary for r in views if r.sweep and r.boundary is not None}),
        film=scene.film.to_dict() if scene.film is not None else None, lut=lut_info, variants=dict(scene.variants),
        # the build marker's rockdove.config.config_hash of the configuration the asset was built from
        configuration=config, configuration_hash=(config.get("marker") or {}).get("config_hash"),
        render={"width": int(checked.size[0]), "height": int(checked.size[1]), "erode_px": 1}, timings_s=timings,
        versions=provenance.library_versions(), argv=tuple(sys.argv), motion=checked.motion)
    shipped = report.portable(result.to_json(), [os.path.dirname(layer), os.path.dirname(published_asset or layer)])
    report.write_json(os.path.join(out, "report.json"), shipped)  # no build machine's path in what ships
    report.write_html(os.path.join(out, "report.html"), Report.from_json(shipped), images)
    return result


def summary(report: Report) -> dict:
    """The short form ``rockdove verify --json`` prints: pass/fail, failures, per-view dE, hue, boundary."""
    per_view, hue = report.boundary.per_view, report.hue_sweep
    return {
        "passed": report.passed,
        "failures": list(report.failures),
        "asset": report.asset,
        "out_dir": report.out_dir,
        "validation": report.validation.passed,
        "views": {m.view: {"n_pixels": m.n_pixels, "de_median": m.de_median, "de_p95": m.de_p95,
                           "de_max": m.de_max, "n_black": m.n_black, "passed": m.passed} for m in report.views},
        "notes": list(report.notes),
        "hue_sweep": {"green": hue.green, "purple": hue.purple, "grey": hue.grey, "other": hue.other},
        "boundary_rms_px": {k: v.rms_px for k, v in per_view.items()},
        "boundary_shape": {k: {"green_share": v.coherence.green.largest_share,
                               "purple_share": v.coherence.purple.largest_share, "line_over_curve": v.curvature.ratio}
                           for k, v in per_view.items()},
        "hosts": [{k: v for k, v in h.to_json().items() if k not in ("per_view", "failures")} for h in report.hosts],
        "anatomy": {m.name: m.value for m in report.anatomy.measures},
        "motion": report.motion and {"motion": report.motion.motion, "times": report.motion.times,
                                     "measures": report.motion.measures, "failures": report.motion.failures},
        "timings_s": report.timings_s,
    }

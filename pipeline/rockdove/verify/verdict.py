"""The verdict of a verification and its report: per-view results (fresh or cached) joined with the asset's
validation, the hue check over the light sweep, the boundary notes and the hosts' entries, written as
``report.json`` and ``report.html`` (:mod:`rockdove.verify.report`)."""

from __future__ import annotations

import os
import shutil
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..digest import file_sha256
from . import compare, provenance, report
from .anatomy import measure_scene
from .boundary import boundary_note
from .inputs import BOUNDARY_SWEEP_ANGLE_DEG

#: Each of green and purple must hold at least this fraction of the chromatic sweep pixels.
MIN_HUE_FRACTION = 0.02


def default_out_dir(layer_path: str) -> str:
    """Where a verification of ``layer_path`` writes by default: ``verify/`` beside the root layer."""
    return os.path.join(os.path.dirname(os.path.abspath(layer_path)), "verify")


def combine(layer, scene, lut, notes, results: dict, out: str, width, height, bench_dir, say, *, reused,
            t_start, hosts, items, published_asset, beauty, motion=None) -> dict:
    """Validate the asset and join the per-view results and the hosts' entries into the verdict and the report
    (``report.json``, ``report.html`` and their images in the folder ``out``); returns the report dict.
    ``bench_dir``: benchmark plots the report shows (None: none; the report reads no folder it is not given)."""
    timings, failures, notes = {}, [], list(notes)
    say("validating")
    # in a thread, while this one draws the report (pxr's validators and the charts' PNG encoding leave the GIL
    # in parts)
    validating = ThreadPoolExecutor(1, thread_name_prefix="rockdove-validate")
    validation_pending = validating.submit(provenance.run_validation, layer)
    validating.shutdown(wait=False)
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
        hue = compare.hue_histogram(np.zeros((0, 3)))
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
    images["contact_sheet"] = os.path.basename(report.contact_sheet(os.path.join(out, "contact_sheet.png"), sheet_rows))
    lut_info = None
    if scene.film is not None:
        try:
            lut_used = lut if lut is not None else scene.load_lut()
            images["lut"] = os.path.basename(report.lut_png(os.path.join(out, "lut.png"), lut_used))
            lut_info = {"file": None if lut is not None else scene.film.lut_file,
                        "shape": [lut_used.n_thickness, lut_used.n_angle],
                        "thickness_range_nm": list(lut_used.thickness_range_nm),
                        "angle_warp_gamma": lut_used.angle_warp_gamma, "colour_space": lut_used.colour_space,
                        "metadata": dict(lut_used.metadata), "verification_only": lut is not None}
        except (ValueError, OSError) as exc:
            failures.append(f"LUT {scene.film.lut_file!r} could not be read: {exc}")
        lo, hi = scene.thickness_range_nm
        thicknesses = sorted({lo, 0.5 * (lo + hi), hi})
        images["spectra"] = os.path.basename(report.spectra_png(os.path.join(out, "spectra.png"), scene.film,
                                                             thickness_nm=thicknesses))
    images["hue"] = os.path.basename(report.hue_png(os.path.join(out, "hue.png"), hue, "light sweep"))
    host_entries, images["hosts"], timings["hosts"] = hosts
    for h in host_entries:
        if h.get("skipped"):  # reported with its reason (report["hosts"], the CLI's SKIPPED line)
            continue
        if h.get("error"):
            failures.append(f"host {h['name']} failed: {h['error']}")
        elif not h["passed"]:
            failures.append(f"host {h['name']} ({h['variant']}, {h['lobe']} lobe): {'; '.join(h['failures'])}")
    images["bench"] = report.copy_bench_plots(out, bench_dir) if bench_dir is not None else []
    if beauty is not None:
        from ..hosts.beauty import for_report

        say("beauty render")
        images["beauty"], note = for_report(layer, scene, out, beauty, cycles_ok=beauty.get("cycles_ok", False),
                                            lut=lut)
        notes.extend([note] if note else [])
        timings["beauty"] = images["beauty"]["seconds"] if images["beauty"] else 0.0
    timings["report"] = time.perf_counter() - t
    validation, timings["validation"] = validation_pending.result()
    if not validation["passed"]:
        failures.insert(0, "validation: " + (validation["error"] or "the validator reported problems"))
    anatomy = measure_scene(scene)  # the bird against its published measures (rockdove.verify.anatomy)
    failures.extend(anatomy["failures"] + (motion["failures"] if motion else []))
    timings["total"] = time.perf_counter() - t_start

    config = provenance.asset_configuration(layer)
    film = scene.film.to_dict() if scene.film is not None else None
    if os.path.isfile(os.path.join(out, "viewer.html")):  # written beside the report (rockdove.web.viewer)
        images["viewer"] = "viewer.html"
    result = {
        "asset": published_asset or layer,
        "asset_sha256": file_sha256(layer),
        "out_dir": out,
        "passed": not failures,
        "failures": failures,
        "notes": notes,
        "goals": {"median_dE": compare.MEDIAN_DE_GOAL, "p95_dE": compare.P95_DE_GOAL,
                  "black_fraction": compare.BLACK_FRACTION_GOAL, "min_hue_fraction": MIN_HUE_FRACTION},
        "validation": validation,
        "views": metrics,
        "views_reused": [n for n in (r["view"] for r in results) if n in set(reused)],
        "cache": items,
        "view_setup": [r["setup"] for r in results],
        "reference": [r["reference"] for r in results],
        "hue_sweep": hue,
        "hosts": host_entries,
        "anatomy": anatomy,
        "motion": motion,
        "beauty": images.get("beauty"),
        "boundary": {"per_view": {r["view"]: r["boundary"] for r in sweeps},
                     "method": "TLS line through green/purple boundary points; RMS perpendicular distance (px) "
                               "and RMS / boundary length; coherence and curvature: rockdove.verify.boundary"},
        "film": film,
        "lut": lut_info,
        "variants": dict(scene.variants),
        "configuration": config,
        # the build marker's rockdove.config.config_hash of the configuration the asset was built from
        "configuration_hash": (config.get("marker") or {}).get("config_hash"),
        "render": {"width": int(width), "height": int(height), "erode_px": 1},
        "timings_s": timings,
        "versions": provenance.library_versions(),
        "argv": list(sys.argv),
    }
    shipped = report.portable(result, [os.path.dirname(layer), os.path.dirname(published_asset or layer)])
    report.write_json(os.path.join(out, "report.json"), shipped)  # no build machine's path in what ships
    report.write_html(os.path.join(out, "report.html"), shipped, images)
    return result


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
        "anatomy": {r["name"]: r["value"] for r in report["anatomy"]["measures"]},
        "motion": report["motion"] and {k: report["motion"][k] for k in ("motion", "times", "measures", "failures")},
        "timings_s": report["timings_s"],
    }

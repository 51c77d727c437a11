"""``rockdove bench viewer``: the frame time of ``verify/viewer.html`` in headless Chromium (WebGL2 on SwiftShader) at
1280 x 720, each shading mode against the same page drawing the same meshes with a plain textured material
(three.js ``MeshBasicMaterial`` with the base colour texture), in one run: the goal is the LUT shading at most
:data:`GOAL_RATIO` x the plain one. Rows: medians over ``--rounds`` rounds of ``--frames`` frames, the modes
interleaved in each round (so a noisy neighbour slows them alike).

Then the film panel's goals, in the same page: ``--films`` random films (:func:`random_films`, seeded) set by
``window.rockdove.setFilm``: the median bake time at the asset's LUT size (goal <= :data:`GOAL_BAKE_MS`); the frame
time while dragging the ``film.cauchy_a`` slider (each input event bakes, uploads and draws) against the frame at
rest, rounds interleaved (goal <= :data:`GOAL_DRAG_RATIO`); and every texel of each film's LUT against the exact
0.1 nm reference (rockdove.lut.reference), max and p99 dE2000 over all (goals <= :data:`GOAL_MAX_DE` and
:data:`GOAL_P99_DE`; ``--films 0`` skips them, the reference of 20 films takes minutes).

The asset: ``--asset``, else ``build/pigeon`` when built (its ``pigeon.glb``, exported when it has none)."""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
from pathlib import Path

from ..errors import UsageError

HELP = "viewer benchmark: frame time of verify/viewer.html at 1280 x 720, LUT shading against a plain texture"
GOAL_RATIO = 1.5
MODES = ("plain", "lut", "physical", "preview")
GOAL_BAKE_MS, GOAL_DRAG_RATIO, GOAL_MAX_DE, GOAL_P99_DE = 50.0, 1.5, 0.1, 0.05
#: Frame time while dragging: the film.cauchy_a slider stepped through this range (one bake per input event).
DRAG_JS = """window.rockdoveBenchDrag = (frames) => {
  const gl = document.getElementById('view').getContext('webgl2'), px = new Uint8Array(4);
  const s = document.querySelector('#film input[type=range][aria-label="film.cauchy_a"]');
  const t0 = performance.now();
  for (let i = 0; i < frames; i++) {
    s.value = String(1.5 + 0.01 * (i % 11));
    s.dispatchEvent(new Event('input'));
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
  }
  return (performance.now() - t0) / frames;
}"""


def random_films(n: int, seed: int = 0) -> list[dict]:
    """``n`` films over the schema's ranges: a third non-dispersive (the others Cauchy B in 0-30000 nm^2), half
    absorbing (k log-uniform in 1e-3..10), half on a substrate of index 1-3, every tenth in an incident medium of
    index 1-1.5; A in 1.05-3; each thickness range [lo, hi] within 100-2000 nm."""
    import numpy as np

    rng = np.random.default_rng(seed)
    films = []
    for i in range(n):
        u = rng.uniform(size=8)
        films.append({"cauchy_a": round(1.05 + 1.95 * u[0], 4), "cauchy_b_nm2": 0.0 if i % 3 == 0 else round(30000 * u[1], 1),
                      "k": 0.0 if i % 2 == 0 else float(f"{10 ** (-3 + 4 * u[2]):.4g}"),
                      "n_substrate": 1.0 if i % 4 < 2 else round(1 + 2 * u[3], 4),
                      "n_incident": round(1 + 0.5 * u[4], 4) if i % 10 == 9 else 1.0,
                      "base_nm": sorted(float(round(v)) for v in 100 + 1900 * rng.uniform(size=2)),
                      "top_nm": sorted(float(round(v)) for v in 100 + 1900 * rng.uniform(size=2))})
    return films


def film_goals(page, n_films: int, rounds: int, frames: int) -> dict:
    """The film panel's three goals (module docstring) in an open viewer page."""
    import base64

    import numpy as np

    from ..films import FilmModel
    from ..lut.reference import delta_E, reference_colour

    bakes, films = [], []
    for film in random_films(n_films):
        r = page.evaluate(f"window.rockdove.setFilm({json.dumps(film)}).then(r => {{ const u = new Uint8Array("
                          "r.rgb.buffer); let s = ''; for (let i = 0; i < u.length; i += 0x8000) s += String."
                          "fromCharCode.apply(null, u.subarray(i, i + 0x8000)); return Object.assign({}, r, "
                          "{rgb: btoa(s)}); })", timeout_s=600, step="setFilm")
        bakes.append(r["ms"])
        films.append((film, r))
    page.evaluate(DRAG_JS)
    page.evaluate("window.rockdove.setFilm({cauchy_a: 1.5, cauchy_b_nm2: 5890, k: 0, n_incident: 1, n_substrate: 1})")
    rest, drag = [], []
    for _ in range(rounds):
        rest.append(page.evaluate(f"window.rockdoveFrameTime('lut', {frames})", timeout_s=600, step="rest"))
        drag.append(page.evaluate(f"window.rockdoveBenchDrag({frames})", timeout_s=600, step="drag"))
    rows = []
    for film, r in films:
        rgb = np.frombuffer(base64.b64decode(r["rgb"]), np.float32).reshape(r["thicknesses"], r["angles"], 3)
        model = FilmModel("bench", **{k: film[k] for k in ("cauchy_a", "cauchy_b_nm2", "k", "n_incident", "n_substrate")})
        lo, hi = r["thicknessRangeNm"]
        cos = np.linspace(0.0, 1.0, r["angles"]) ** r["angleWarpGamma"]
        d = np.linspace(lo, hi, r["thicknesses"]) if r["thicknesses"] > 1 else np.array([lo])
        de = delta_E(rgb, reference_colour(cos[None, :], d[:, None], model))
        rows.append({"film": film, "range_nm": [lo, hi], "ms": r["ms"], "max": float(de.max()),
                     "p99": float(np.percentile(de, 99)), "median": float(np.median(de)), "de": de.ravel()})
    all_de = np.concatenate([row.pop("de") for row in rows]) if rows else np.zeros(1)
    return {"bake_ms": bakes, "bake_median_ms": statistics.median(bakes), "rest_ms": statistics.median(rest),
            "drag_ms": statistics.median(drag), "drag_ratio": statistics.median(drag) / statistics.median(rest),
            "films": rows, "max_de": float(all_de.max()), "p99_de": float(np.percentile(all_de, 99)),
            "median_de": float(np.median(all_de))}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--asset", metavar="PATH", default=os.path.join("build", "pigeon"),
                        help="asset folder or root layer (default build/pigeon)")
    parser.add_argument("--width", type=int, default=1280, help="viewport width, CSS px (default 1280)")
    parser.add_argument("--height", type=int, default=720, help="viewport height, CSS px (default 720)")
    parser.add_argument("--frames", type=int, default=10, help="frames per mode and round (default 10)")
    parser.add_argument("--rounds", type=int, default=5, help="rounds (median; default 5)")
    parser.add_argument("--films", type=int, default=20, help="random films of the film panel's goals (default 20; "
                        "0 skips them)")
    parser.add_argument("--json", metavar="FILE", help="also write the results as JSON to FILE")


def run(args: argparse.Namespace) -> int:
    from ..usd.layout import resolve_root_layer
    from ..web.browser import Browser
    from ..web.gltf import GLB_NAME, export_glb
    from ..web.viewer import write_viewer

    if args.frames < 1 or args.rounds < 1 or not (64 <= args.width <= 8192 and 64 <= args.height <= 8192):
        raise UsageError("--frames and --rounds must be >= 1 and --width/--height in [64, 8192]")
    layer = resolve_root_layer(args.asset)
    times = {m: [] for m in MODES}
    with tempfile.TemporaryDirectory(prefix="rockdove-bench-viewer-") as tmp:
        glb = Path(layer).parent / GLB_NAME
        if not glb.is_file():
            export_glb(layer, Path(tmp) / GLB_NAME)
            glb = Path(tmp) / GLB_NAME
        page_path = write_viewer(layer, glb, Path(tmp) / "verify")
        with Browser() as browser:
            page = browser.open(Path(page_path).as_uri(), args.width, args.height, timeout_s=120)
            page.evaluate("window.rockdoveReady", timeout_s=120, step="load the viewer")
            panel = page.evaluate("document.getElementById('panel').offsetHeight")  # the canvas gets W x H
            browser.call("Emulation.setDeviceMetricsOverride", {"width": args.width, "height": args.height + panel,
                                                                "deviceScaleFactor": 1, "mobile": False},
                         session=page.session, step="set viewport")
            page.evaluate("window.rockdoveFrameTime('lut', 1)", timeout_s=120, step="resize")
            canvas = page.evaluate("[document.getElementById('view').width, document.getElementById('view').height]")
            for _ in range(args.rounds):
                for m in MODES:
                    times[m].append(page.evaluate(f"window.rockdoveFrameTime({json.dumps(m)}, {args.frames})",
                                                  timeout_s=600, step=f"frame time {m}"))
            film = film_goals(page, args.films, args.rounds, args.frames) if args.films > 0 else None
            errors = page.errors
    med = {m: statistics.median(v) for m, v in times.items()}
    ratio = med["lut"] / med["plain"]
    print(f"rockdove bench viewer: {args.asset}, canvas {canvas[0]}x{canvas[1]} px, medians of {args.rounds} rounds "
          f"of {args.frames} frames (Chromium, SwiftShader)")
    for m in MODES:
        print(f"  {m:<10s} {med[m]:9.2f} ms/frame  {med[m] / med['plain']:5.2f} x plain")
    print(f"  LUT / plain = {ratio:.2f} (goal <= {GOAL_RATIO}): {'ok' if ratio <= GOAL_RATIO else 'OVER'}")
    ok = ratio <= GOAL_RATIO
    if film is not None:
        goals = [("LUT bake, median of %d edits" % args.films, film["bake_median_ms"], GOAL_BAKE_MS, "ms"),
                 ("frame dragging / at rest", film["drag_ratio"], GOAL_DRAG_RATIO, "x"),
                 ("max dE2000, every texel", film["max_de"], GOAL_MAX_DE, ""), ("p99 dE2000", film["p99_de"], GOAL_P99_DE, "")]
        print(f"film panel: {args.films} random films (bake max {max(film['bake_ms']):.1f} ms); frame "
              f"{film['rest_ms']:.1f} ms at rest, {film['drag_ms']:.1f} ms dragging film.cauchy_a")
        for i, row in enumerate(film["films"]):
            print(f"  film {i:2d} {json.dumps(row['film'])}: {row['range_nm'][0]:.0f}-{row['range_nm'][1]:.0f} nm, "
                  f"{row['ms']:6.1f} ms, dE2000 max {row['max']:.4f} p99 {row['p99']:.4f} median {row['median']:.5f}")
        for name, value, goal, unit in goals:
            print(f"  {name}: {value:.4g}{unit} (goal <= {goal}{unit}): {'ok' if value <= goal else 'OVER'}")
            ok = ok and value <= goal
    if errors:
        print("  page errors: " + "; ".join(errors[:3]))
    if args.json:
        Path(args.json).write_text(json.dumps({"ms_per_frame": med, "samples_ms": times, "ratio_lut_plain": ratio,
                                               "canvas_px": canvas, "goal_ratio": GOAL_RATIO, "film": film}, indent=2))
    return 0 if ok and not errors else 1

"""``rockdove bench render``: time the verification renders (the goal: 4 views at 512 x 512 with the GL
renderer plus the CPU reference in under 20 s on this machine).

Rows (medians of ``--repeats`` runs, ``time.perf_counter``, all in one process):

- ``load_scene``: reading the asset back from USD (:func:`rockdove.render.scene.load_scene`); the same posed at a
  time code of the walk, and UsdSkel's skinning of every mesh, points and normals, per frame over the walk's 121
  time codes (:func:`rockdove.render.skinning.pose`), when the asset has the walk;
- ``gl cold``: :func:`rockdove.render.gl.render_views` of the 4 default views, i.e. EGL context, shader
  compilation, mesh and float-texture upload, 4 renders and float read-backs, renderer deleted;
- ``gl setup`` and ``gl 4 views warm``: the same split in two, with one :class:`~rockdove.render.gl.GLRenderer`
  (its construction; then the 4 renders on the live renderer);
- ``reference``: :func:`rockdove.verify.reference_image.render_reference` on the same views, when that module exists;
- ``total``: load + gl cold + reference, against the goal.

The asset: ``--asset`` (folder or root layer); by default ``build/pigeon`` when it has been built, else the
default asset built (``rockdove build --no-verify``, the real build graph) into a temporary folder; the output
says which."""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

from ..errors import UsageError

HELP = "render benchmarks: GL views and the CPU reference at 512 x 512 against the 20 s goal"

GOAL_TOTAL_S = 20.0
DEFAULT_ASSET = os.path.join("build", "pigeon")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--asset", metavar="PATH", help=f"asset folder or root layer (default {DEFAULT_ASSET} "
                                                        "if built, else the default asset built into a temporary folder)")
    parser.add_argument("--width", type=int, default=512, help="image width (default 512)")
    parser.add_argument("--height", type=int, default=512, help="image height (default 512)")
    parser.add_argument("--repeats", type=int, default=3, help="repeats per GL row (median; default 3)")
    parser.add_argument("--reference-repeats", type=int, default=1,
                        help="repeats of the CPU reference (median; default 1)")
    parser.add_argument("--no-reference", action="store_true", help="skip the CPU reference")
    parser.add_argument("--json", metavar="FILE", help="also write the results as JSON to FILE")


def _median_time(fn, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def run(args: argparse.Namespace) -> int:
    if args.repeats < 1 or args.reference_repeats < 1:
        raise UsageError(f"--repeats and --reference-repeats must be >= 1, got {args.repeats}, {args.reference_repeats}")
    if not (1 <= args.width <= 8192 and 1 <= args.height <= 8192):
        raise UsageError(f"--width/--height must be in [1, 8192], got {args.width} x {args.height}")
    from ..render.gl import GLRenderer, render_views
    from ..render.scene import load_scene
    from ..render.views import default_views

    tmp = None
    if args.asset:
        asset, label = args.asset, args.asset
    elif os.path.exists(os.path.join(DEFAULT_ASSET, "pigeon.usda")):
        asset, label = DEFAULT_ASSET, DEFAULT_ASSET
    else:
        tmp = tempfile.TemporaryDirectory(prefix="rockdove-bench-render-")
        asset = os.path.join(tmp.name, "pigeon")
        cmd = [sys.executable, "-m", "rockdove.cli", "build", "--out", asset, "--no-verify", "--quiet"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            tmp.cleanup()
            raise RuntimeError(f"building the default asset for the benchmark failed: {proc.stderr.strip()}")
        label = "default asset built into a temporary folder (build/pigeon not built)"
    rows = {}
    try:
        t_load, scene = _median_time(lambda: load_scene(asset), args.repeats)
        rows["load_scene"] = t_load
        from ..render.skinning import pose
        from ..usd.stage import open_asset

        stage = open_asset(scene.root_layer)
        walk = stage.GetDefaultPrim().GetVariantSet("motion")
        if "walk" in walk.GetVariantNames():
            rows["load_scene walk t=21 (skinned)"] = _median_time(lambda: load_scene(asset, {"motion": "walk"}, 21),
                                                                  args.repeats)[0]
            walk.SetVariantSelection("walk")
            rows["UsdSkel skinning per frame"] = _median_time(lambda: pose(stage, range(121)), args.repeats)[0] / 121
        views = default_views(scene, args.width, args.height)
        t_cold, _ = _median_time(lambda: render_views(scene, views), args.repeats)
        rows["gl cold (context + upload + 4 views)"] = t_cold
        setups, warms = [], []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            r = GLRenderer(scene, width=args.width, height=args.height)
            setups.append(time.perf_counter() - t0)
            try:
                t0 = time.perf_counter()
                for v in views:
                    r.render(v)
                warms.append(time.perf_counter() - t0)
            finally:
                r.delete()
        rows["gl setup"] = statistics.median(setups)
        rows["gl 4 views warm"] = statistics.median(warms)
        ref_note = None
        if args.no_reference:
            ref_note = "skipped (--no-reference)"
        else:
            from ..verify.reference_image import render_reference

            t_ref, _ = _median_time(lambda: render_reference(scene, views), args.reference_repeats)
            rows["reference (4 views)"] = t_ref
        total = rows["load_scene"] + rows["gl cold (context + upload + 4 views)"] + rows.get("reference (4 views)", 0.0)
        rows["total"] = total
    finally:
        if tmp is not None:
            tmp.cleanup()

    n_tri = sum(len(p.triangles) for p in scene.parts)
    print(f"rockdove bench render: {label}, {len(scene.parts)} parts, {n_tri} triangles, "
          f"{len(views)} views at {args.width}x{args.height}, medians of {args.repeats} (reference "
          f"{args.reference_repeats})")
    for name, t in rows.items():
        print(f"  {name:<40s} {t:8.3f} s")
    if ref_note:
        print(f"  reference: {ref_note}")
    status = "met" if rows["total"] < GOAL_TOTAL_S else "MISSED"
    what = "GL + reference" if ref_note is None else "GL only"
    print(f"  goal: {what} < {GOAL_TOTAL_S:.0f} s: {status}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"asset": label, "width": args.width, "height": args.height, "views": [v.name for v in views],
                       "repeats": args.repeats, "seconds": rows, "reference": ref_note or "measured",
                       "goal_s": GOAL_TOTAL_S, "goal_met": rows["total"] < GOAL_TOTAL_S}, f, indent=2)
    return 0

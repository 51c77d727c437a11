"""``rockdove bench viewer``: the frame time of ``verify/viewer.html`` in headless Chromium (WebGL2 on SwiftShader) at
1280 x 720, each shading mode against the same page drawing the same meshes with a plain textured material
(three.js ``MeshBasicMaterial`` with the base colour texture), in one run: the goal is the LUT shading at most
:data:`GOAL_RATIO` x the plain one. Rows: medians over ``--rounds`` rounds of ``--frames`` frames, the modes
interleaved in each round (so a noisy neighbour slows them alike).

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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--asset", metavar="PATH", default=os.path.join("build", "pigeon"),
                        help="asset folder or root layer (default build/pigeon)")
    parser.add_argument("--width", type=int, default=1280, help="viewport width, CSS px (default 1280)")
    parser.add_argument("--height", type=int, default=720, help="viewport height, CSS px (default 720)")
    parser.add_argument("--frames", type=int, default=10, help="frames per mode and round (default 10)")
    parser.add_argument("--rounds", type=int, default=5, help="rounds (median; default 5)")
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
            errors = page.errors
    med = {m: statistics.median(v) for m, v in times.items()}
    ratio = med["lut"] / med["plain"]
    print(f"rockdove bench viewer: {args.asset}, canvas {canvas[0]}x{canvas[1]} px, medians of {args.rounds} rounds "
          f"of {args.frames} frames (Chromium, SwiftShader)")
    for m in MODES:
        print(f"  {m:<10s} {med[m]:9.2f} ms/frame  {med[m] / med['plain']:5.2f} x plain")
    print(f"  LUT / plain = {ratio:.2f} (goal <= {GOAL_RATIO}): {'ok' if ratio <= GOAL_RATIO else 'OVER'}")
    if errors:
        print("  page errors: " + "; ".join(errors[:3]))
    if args.json:
        Path(args.json).write_text(json.dumps({"ms_per_frame": med, "samples_ms": times, "ratio_lut_plain": ratio,
                                               "canvas_px": canvas, "goal_ratio": GOAL_RATIO}, indent=2))
    return 0 if ratio <= GOAL_RATIO and not errors else 1

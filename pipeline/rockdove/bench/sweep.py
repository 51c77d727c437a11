"""``rockdove bench sweep``: an 8-point film sweep, serial against ``rockdove sweep`` on the default LocalCluster.

Rows, measured in one run (so the ratio holds on a shared machine), each from a fresh stage cache so every row
pays for the geometry once:

- **serial**: 8 ``rockdove build`` processes one after another, sharing one cache (what a researcher does by
  hand without the sweep): the first builds the body and bird, the others rebuild the film-dependent stages;
- **sweep**: one ``rockdove sweep --grid 'film.cauchy_a=[...]'`` process over the same 8 points on the default
  LocalCluster (one worker process per core), cluster start-up included;
- **growth**: the same sweep over 1, 2, 4 and 8 points: wall time and the marginal cost per added point.

Times are wall-clock of whole processes (interpreter and cluster start included: what a user waits for).
Without ``--verify`` the points are built with ``--no-verify``."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HELP = "sweep benchmark: an 8-point film sweep serial vs the default Dask LocalCluster, and its growth 1 -> 8 points"

FILM_VALUES = ("1.50", "1.51", "1.52", "1.53", "1.54", "1.55", "1.56", "1.57")  # film.cauchy_a, 8 points
QUICK = ["geometry.body_voxel_m=0.008", "textures.body_resolution=64", "textures.feather_resolution=32",
         "lut.angles=64", "lut.thicknesses=16", "usd.usdz=false"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true", help="small points (coarse body, small textures and LUT)")
    parser.add_argument("--verify", action="store_true", help="verify every point (default: --no-verify)")
    parser.add_argument("--no-growth", action="store_true", help="skip the 1/2/4-point rows")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="configuration override applied to every point (repeatable)")
    parser.add_argument("--json", metavar="FILE", help="also write the results as JSON to FILE")


def _timed(cmd: list[str], cwd: Path) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise RuntimeError(f"{' '.join(cmd[3:6])} ... exited {proc.returncode}: {last}")
    return wall


def run(args: argparse.Namespace) -> int:
    try:
        return _run(args)
    except RuntimeError as exc:
        print(f"rockdove bench sweep: {exc}", file=sys.stderr)
        return 1


def _run(args: argparse.Namespace) -> int:
    rd = [sys.executable, "-m", "rockdove.cli"]
    common = [] if args.verify else ["--no-verify"]
    for item in (QUICK if args.quick else []) + list(args.overrides):
        common += ["--set", item]
    results: dict = {"points": len(FILM_VALUES), "quick": bool(args.quick), "verify": bool(args.verify),
                     "swept": "film.cauchy_a", "values": list(FILM_VALUES)}
    with tempfile.TemporaryDirectory(prefix="rockdove-bench-sweep-") as tmp:
        tmp = Path(tmp)

        def sweep(n: int, tag: str) -> float:
            grid = f"film.cauchy_a=[{', '.join(FILM_VALUES[:n])}]"
            return _timed([*rd, "sweep", "--out", f"sweep-{tag}", "--grid", grid, *common], tmp)

        serial = 0.0
        for v in FILM_VALUES:
            serial += _timed([*rd, "build", "--out", f"serial/{v}", "--cache", "serial-cache", "--quiet", *common,
                              "--set", f"film.cauchy_a={v}"], tmp)
        swept = sweep(len(FILM_VALUES), "8")
        results["serial_s"], results["sweep_s"] = serial, swept
        results["speedup"] = serial / swept
        print(f"8-point film sweep: serial {serial:.1f} s, sweep on the default LocalCluster {swept:.1f} s: "
              f"{serial / swept:.2f}x")
        if not args.no_growth:
            rows = [{"points": n, "wall_s": sweep(n, str(n))} for n in (1, 2, 4)]
            rows.append({"points": 8, "wall_s": swept})
            print("points   sweep s   s per point   marginal s per added point")
            prev = None
            for r in rows:
                r["per_point_s"] = r["wall_s"] / r["points"]
                if prev is not None:
                    r["marginal_s"] = (r["wall_s"] - prev["wall_s"]) / (r["points"] - prev["points"])
                print(f"{r['points']:>6d}   {r['wall_s']:>7.1f}   {r['per_point_s']:>11.2f}   "
                      + (f"{r['marginal_s']:>10.2f}" if "marginal_s" in r else f"{'-':>10s}"))
                prev = r
            results["growth"] = rows
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 0

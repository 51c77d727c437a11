"""``rockdove bench memory``: peak resident memory of a build with each size-like configuration key at the end
of its schema range, and of ``rockdove lut`` at its largest size, against the stated budget.

Every row is one ``rockdove`` process (its peak RSS from ``os.wait4``'s resource usage: the largest of the process
and the subprocesses it waited for, not their sum); the rows share one stage cache, warmed by the ``defaults``
row, so each other row runs the stages its key changes (the ``defaults`` row is the rest of a cold build's peak).
Builds skip verification except the verification rows. A row over the budget makes the benchmark exit 1: a
range the schema accepts must build within it (README, "Memory")."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HELP = "memory benchmark: peak RSS of builds at each size key's schema limit, and of the largest rockdove lut"
BUDGET_GIB = 4.0
QUIET = ["usd.usdz=false"]


def _limit(key: str, end: str = "maximum"):
    from ..config import load_schema

    node = load_schema()
    for part in key.split("."):
        node = node["properties"][part]
    return node[end]


def rows() -> list[tuple[str, list[str]]]:
    """(label, rockdove argv) per row; the values are read from the schema (and the LUT baker's limits)."""
    from ..lut.bake import MAX_ANGLES, MAX_THICKNESSES
    from ..render.images import MAX_SIDE_PX

    def build(*sets, verify=False):
        return ["build", "--out", "out", "--cache", "cache", "--quiet", *([] if verify else ["--no-verify"]),
                *[a for s in (*QUIET, *sets) for a in ("--set", s)]]

    lim = {k: _limit(k) for k in ("textures.body_resolution", "textures.feather_resolution", "lut.angles",
                                  "lut.thicknesses", "geometry.card_count", "verify.width", "verify.height",
                                  "verify.views")}
    out = [("defaults", build())]
    out += [(f"{k}={v}", build(f"{k}={v}")) for k, v in lim.items() if k.startswith("textures")]
    side = MAX_SIDE_PX // 2  # the asset just built (4096 px feather textures), at the largest rendered side
    out.append((f"rockdove render {side} px x supersample 2", ["render", "out", "--out", "render", "--views", "1",
                                                               "--width", str(side), "--height", str(side)]))
    out += [(f"{k}={v}", build(f"{k}={v}")) for k, v in lim.items() if k.startswith("geometry")]
    out.append((f"lut.angles={lim['lut.angles']} x lut.thicknesses={lim['lut.thicknesses']}",
                build(f"lut.angles={lim['lut.angles']}", f"lut.thicknesses={lim['lut.thicknesses']}")))
    voxel = _limit("geometry.body_voxel_m", "minimum")
    out.append((f"geometry.body_voxel_m={voxel}", build(f"geometry.body_voxel_m={voxel}")))
    out.append((f"rockdove lut --angles {MAX_ANGLES} --thicknesses {MAX_THICKNESSES}",
                ["lut", "--out", "lut/big.exr", "--angles", str(MAX_ANGLES), "--thicknesses", str(MAX_THICKNESSES)]))
    out.append((f"verify {lim['verify.width']} x {lim['verify.height']} px",
                build(f"verify.width={lim['verify.width']}", f"verify.height={lim['verify.height']}",
                      "verify.views=1", verify=True)))
    out.append((f"verify.views={lim['verify.views']} at {lim['verify.width']} px (the largest verification)",
                build(f"verify.views={lim['verify.views']}", f"verify.width={lim['verify.width']}",
                      f"verify.height={lim['verify.height']}", verify=True)))
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--only", action="append", default=[], metavar="TEXT",
                        help="run only the rows whose label contains TEXT (repeatable; 'defaults' is always run)")
    parser.add_argument("--budget-gib", type=float, default=BUDGET_GIB, help="peak RSS budget per row, GiB")
    parser.add_argument("--json", metavar="FILE", help="also write the rows as JSON to FILE")


def peak_rss(argv: list[str], cwd: Path) -> dict:
    """Run ``rockdove ARGV`` in ``cwd``: its exit status, wall seconds and peak RSS (bytes; Linux ru_maxrss)."""
    env = {**os.environ, "PYOPENGL_PLATFORM": os.environ.get("PYOPENGL_PLATFORM", "egl")}
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "rockdove.cli", *argv], cwd=cwd, env=env,
                                stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        seconds = time.perf_counter() - t0
        err.seek(0)
        last = (err.read().decode(errors="replace").strip().splitlines() or [""])[-1]
    return {"exit": proc.returncode, "seconds": round(seconds, 1), "peak_rss_bytes": usage.ru_maxrss * 1024,
            **({"error": last} if proc.returncode else {})}


def run(args: argparse.Namespace) -> int:
    budget = args.budget_gib * 2**30
    results, status = [], 0
    with tempfile.TemporaryDirectory(prefix="rockdove-bench-memory-") as tmp:
        print(f"{'row':<52} {'peak RSS':>10} {'wall':>8}  (budget {args.budget_gib:g} GiB)")
        for label, argv in rows():
            if args.only and label != "defaults" and not any(o in label for o in args.only):
                continue
            r = {"row": label, "argv": argv, **peak_rss(argv, Path(tmp))}
            over = r["peak_rss_bytes"] > budget
            status = max(status, int(over or r["exit"] != 0))
            print(f"{label:<52} {r['peak_rss_bytes'] / 2**30:>6.2f} GiB {r['seconds']:>6.1f} s"
                  + ("  OVER BUDGET" if over else "") + (f"  exit {r['exit']}: {r['error']}" if r["exit"] else ""),
                  flush=True)
            results.append(r)
    if args.json:
        Path(args.json).write_text(json.dumps({"budget_gib": args.budget_gib, "rows": results}, indent=1) + "\n")
    return status

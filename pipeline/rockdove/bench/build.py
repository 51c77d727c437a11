"""``rockdove bench build``: the incremental build's speed goals, measured through the real CLI.

Rows (each a median of ``--repeats`` runs, ``time.perf_counter``, in the same session so the ratios hold on a
shared machine):

- cold build of the default asset without verification (fresh cache); goal < 5 s;
- no-op rebuild (same configuration, warm cache); goal <= 10 % of the cold build;
- film-only rebuild (``--set film.cauchy_a=...``, no verify; a new value each repeat) as a ratio of the cold
  build; goal <= 10 %; which stages ran (goal: LUT, textures, looks layer and usdz; geometry reused);
  and its floor: a fresh interpreter importing only the libraries a film rebuild must use; and the same
  rebuild in a warm process (the build function called again in one process, as a sweep's worker or a
  notebook does), against the same goal;
- verification after a film-only change as a ratio of a cold verification of the same asset (both: the
  ``verify`` stage seconds of a build's ``--json``); goal <= 30 %; the reference's surface items the film change
  reused (the report's ``cache``); the two builds' whole-process wall times (the
  verification's worker process starts with the build, so part of its work precedes the verify stages); and
  the same verification in a warm process (the build function called again, as a sweep's worker does);
- cold, no-op and film-only builds three ways, in one table: each a new ``rockdove build`` process; through
  :func:`rockdove.api.build` called again in one process (a notebook, a sweep's worker); and through
  ``rockdove build --watch`` (one warm process, its ``--config`` file edited; timed from the write to the
  rebuild's summary line, so its poll interval counts);
- the geometry payload written as usda against usdc at 1,500 and 100k cards: size and write time
  (in process: ``rockdove.usd.stage.author_geometry`` once, then ``Sdf.Layer.Export`` to each format);
- scaling with the card count (1k, 10k, 100k): cold build time and the build process's peak memory
  (``ru_maxrss`` of the child from ``os.wait4``);
- the end-to-end trade-off LUT size x precision (float32, half) against the verification dE2000 and the build
  time, when verification is available (else the row says so).

Times are wall-clock of a whole ``rockdove build`` process (interpreter start included, what a user waits
for); ``inside`` is the build command's own time from its ``--json`` summary."""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HELP = "build benchmarks: cold vs no-op rebuild, film change reuse, card-count scaling, LUT size/precision trade-off"

COLD_GOAL_S = 5.0
QUICK = ["geometry.body_voxel_m=0.008", "textures.body_resolution=64", "textures.feather_resolution=32",
         "lut.angles=64", "lut.thicknesses=16", "usd.usdz=false"]
NOOP_GOAL_RATIO = 0.10
FILM_GOAL_RATIO = 0.10
VERIFY_GOAL_RATIO = 0.30
#: The build stages whose seconds make a verification (ray casts, their surfaces, renders + checks + report).
VERIFY_STAGES = ("verify",)
#: Film indices of the film-only rebuilds (one per repeat; each differs from the last build's).
FILM_VALUES = (1.55, 1.56, 1.57, 1.58, 1.59)
FORMAT_CARDS = (1500, 100000)
SECTIONS = ("cold", "film", "verify", "formats", "scaling", "tradeoff")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true",
                        help="a smoke test: a coarse body, small textures and card counts, one repeat")
    parser.add_argument("--repeats", type=int, default=3, help="repeats per timed row (median; default 3)")
    parser.add_argument("--preset", default="measured", help="preset to build (default measured)")
    parser.add_argument("--json", metavar="FILE", help="also write the results as JSON to FILE")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="configuration override applied to every build of the benchmark (repeatable)")
    parser.add_argument("--sections", default=",".join(SECTIONS),
                        help=f"comma-separated rows to measure (default all: {','.join(SECTIONS)}); the cold build "
                             "is always measured, every ratio against it")


def _env(user_cache: Path | None = None) -> dict:
    """The environment of the benchmark's ``rockdove`` processes: ``$XDG_CACHE_HOME`` = ``user_cache`` (default
    the user's)."""
    env = dict(os.environ)
    if user_cache is not None:
        env["XDG_CACHE_HOME"] = str(user_cache)
    return env


def _build_rss(workdir: Path, *args: str, cache: str = "cache", allow_fail: bool = False,
               user_cache: Path | None = None) -> dict:
    """One ``rockdove build`` process: wall time, peak resident memory (MiB, ``os.wait4``), its --json summary.
    ``user_cache``: the build's ``$XDG_CACHE_HOME`` (rockdove.resources.user_cache_dir), default the user's."""
    cmd = [sys.executable, "-m", "rockdove.cli", "build",
           "--out", str(workdir / "out" / "pigeon"), "--cache", str(workdir / cache), "--json", "--quiet", *args]
    out_path = workdir / "summary.json"
    t0 = time.perf_counter()
    with open(out_path, "w") as out, open(workdir / "stderr.txt", "w") as errf:
        proc = subprocess.Popen(cmd, stdout=out, stderr=errf, env=_env(user_cache))
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    if proc.returncode != 0 and not (allow_fail and proc.returncode == 1):
        raise RuntimeError(f"rockdove build {' '.join(args)} exited {proc.returncode}: "
                           f"{(workdir / 'stderr.txt').read_text().strip()}")
    return {"wall_s": wall, "peak_rss_mib": usage.ru_maxrss / 1024.0, **json.loads(out_path.read_text())}


def _median(rows: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in rows)


def run(args: argparse.Namespace) -> int:
    try:
        return _run(args)
    except RuntimeError as exc:  # a build of the benchmark failed: say which, one line
        print(f"rockdove bench build: {exc}", file=sys.stderr)
        return 1


def _run(args: argparse.Namespace) -> int:
    repeats = 1 if args.quick else max(1, args.repeats)
    sections = [x.strip() for x in args.sections.split(",") if x.strip()]
    unknown = [x for x in sections if x not in SECTIONS]
    if unknown:
        print(f"rockdove bench build: --sections {unknown[0]!r} is unknown; allowed: {', '.join(SECTIONS)}",
              file=sys.stderr)
        return 2
    preset = ["--preset", args.preset, "--no-verify"]
    for item in (QUICK if args.quick else []) + list(args.overrides):
        preset += ["--set", item]
    results: dict = {"preset": args.preset, "repeats": repeats, "quick": bool(args.quick)}
    with tempfile.TemporaryDirectory(prefix="rockdove-bench-build-") as tmp:
        tmp = Path(tmp)
        # cold builds (fresh cache each) and no-op rebuilds (warm cache)
        cold, noop = [], []
        for i in range(repeats):
            cold.append(_build_rss(tmp, *preset, cache=f"cold{i}"))
            noop.append(_build_rss(tmp, *preset, cache=f"cold{i}"))
        cold_s, noop_s = _median(cold, "wall_s"), _median(noop, "wall_s")
        results["cold"] = {"wall_s": cold_s, "inside_s": _median(cold, "seconds"), "goal_s": COLD_GOAL_S,
                           "peak_rss_mib": max(r["peak_rss_mib"] for r in cold)}
        results["noop"] = {"wall_s": noop_s, "inside_s": _median(noop, "seconds"), "ratio": noop_s / cold_s,
                           "goal_ratio": NOOP_GOAL_RATIO, "ran": noop[-1]["ran"]}
        slowest = max(cold[0]["stages"], key=lambda st: st["seconds"])
        results["cold"]["slowest_stage"] = {"name": slowest["name"], "seconds": slowest["seconds"]}
        print(f"cold build ({args.preset}, no verify): {cold_s:.2f} s wall (inside {results['cold']['inside_s']:.2f} s), "
              f"goal < {COLD_GOAL_S:g} s: {'met' if cold_s < COLD_GOAL_S else 'NOT met'}; "
              f"slowest stage {slowest['name']} {slowest['seconds']:.2f} s")
        print(f"no-op rebuild: {noop_s:.3f} s wall (inside {results['noop']['inside_s']:.3f} s) = "
              f"{100 * noop_s / cold_s:.1f} % of cold, goal <= {100 * NOOP_GOAL_RATIO:g} %: "
              f"{'met' if noop_s <= NOOP_GOAL_RATIO * cold_s else 'NOT met'}; stages ran: {noop[-1]['ran'] or 'none'}")

        if "film" in sections:
            results["film_change"] = film = _film_rows(tmp, preset, repeats, cold_s)
            results["api"] = api = _api_table(tmp, preset, repeats)
            watch = film["watch"]
            print("                 new process   API (one process)   --watch")
            for label, key, new in (("cold", "cold_s", cold_s), ("no-op", "noop_s", noop_s),
                                    ("film-only", "film_s", film["wall_s"])):
                print(f"{label:>12s} s   {new:>11.3f}   {api[key]:>17.3f}   {watch[key]:>7.3f}")
        if "verify" in sections:
            results["verify_after_film_change"] = _verify_rows(tmp, preset, args)
        if "formats" in sections:
            results["payload_formats"] = _format_rows((200, 1000) if args.quick else FORMAT_CARDS)

        # scaling with the card count: the body (its UV atlas dominates a cold build and does not depend on the
        # card count) comes from the cache, so the rows show what the card count costs
        counts = ()
        if "scaling" in sections:
            counts = (200, 1000) if args.quick else (1000, 10000, 100000)
        results["scaling"] = []
        if counts:
            print("cards   build s (body cached)   stages ran s   peak RSS MiB")
        for n in counts:
            r = _build_rss(tmp, *preset, "--set", f"geometry.card_count={n}", cache="cold0")
            ran_s = sum(st["seconds"] for st in r["stages"] if st["status"] == "ran")
            row = {"cards": n, "wall_s": r["wall_s"], "inside_s": r["seconds"], "stages_ran_s": ran_s,
                   "ran": r["ran"], "peak_rss_mib": r["peak_rss_mib"]}
            results["scaling"].append(row)
            print(f"{n:>7d}   {r['wall_s']:>18.2f}   {ran_s:>12.2f}   {r['peak_rss_mib']:>12.0f}")

        # LUT size x precision against verification dE2000
        if "tradeoff" in sections:
            results["lut_tradeoff"] = _lut_tradeoff(tmp, args, preset)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 0


def _film_rows(tmp: Path, preset: list[str], repeats: int, cold_s: float) -> dict:
    """Film-only rebuilds on the warm cache of the first cold build (no verify), one new film index each."""
    rows = [_build_rss(tmp, *preset, "--set", f"film.cauchy_a={FILM_VALUES[i % len(FILM_VALUES)]}", cache="cold0")
            for i in range(repeats)]
    wall = _median(rows, "wall_s")
    stages = {st["name"]: st["seconds"] for st in rows[-1]["stages"] if st["status"] == "ran"}
    out = {"wall_s": wall, "inside_s": _median(rows, "seconds"), "ratio": wall / cold_s, "goal_ratio": FILM_GOAL_RATIO,
           "ran": rows[-1]["ran"], "reused": rows[-1]["reused"], "stage_s": stages}
    print(f"film-only rebuild (no verify): {wall:.2f} s wall (inside {out['inside_s']:.2f} s) = "
          f"{100 * out['ratio']:.1f} % of cold, goal <= {100 * FILM_GOAL_RATIO:g} %: "
          f"{'met' if out['ratio'] <= FILM_GOAL_RATIO else 'NOT met'}; ran "
          + ", ".join(f"{k} {v:.2f} s" for k, v in stages.items()))
    floor = statistics.median(_import_floor_s() for _ in range(repeats))
    out.update(floor_s=floor, floor_ratio=floor / cold_s, floor_libraries=list(FILM_FLOOR_IMPORTS))
    print(f"  its floor: a fresh interpreter importing what a film rebuild must use ({', '.join(FILM_FLOOR_IMPORTS)}) "
          f"takes {floor:.2f} s = {100 * out['floor_ratio']:.1f} % of cold")
    warm = _warm_film_s(tmp, preset, repeats)
    out.update(warm_process_s=warm, warm_process_ratio=warm / cold_s)
    print(f"  in a warm process (rockdove.api.build called again, as a sweep's Dask worker or a notebook "
          f"does): {warm:.3f} s = {100 * out['warm_process_ratio']:.1f} % of cold, goal <= {100 * FILM_GOAL_RATIO:g} %: "
          f"{'met' if out['warm_process_ratio'] <= FILM_GOAL_RATIO else 'NOT met'}")
    watch = _watch_rows(tmp, preset, repeats)
    out.update(watch=watch, watch_ratio=watch["film_s"] / cold_s)
    print(f"  through `rockdove build --watch` (one warm process; the --config file edited, timed from the write to "
          f"the rebuild's summary line, poll interval included): film {watch['film_s']:.3f} s = "
          f"{100 * out['watch_ratio']:.1f} % of cold, goal <= {100 * FILM_GOAL_RATIO:g} %: "
          f"{'met' if out['watch_ratio'] <= FILM_GOAL_RATIO else 'NOT met'}; its first (cold) build "
          f"{watch['cold_s']:.2f} s, no-op (the file touched, unchanged) {watch['noop_s']:.3f} s")
    return out


#: One process calling :func:`rockdove.api.build` for each configuration of ``steps`` in turn (``KEY=VALUE``
#: lists over the preset): per step its seconds, stages ran and the seconds of its verification stages.
_API_SCRIPT = """
import json, sys, time
from rockdove import api
out, cache, preset, steps, verify, verify_stages = json.loads(sys.argv[1])
rows = []
for sets in steps:
    t0 = time.perf_counter()
    r = api.build(api.load_config(preset=preset, overrides=sets), out, cache=cache, verify=verify)
    rows.append({"wall_s": time.perf_counter() - t0, "ran": r.ran,
                 "verify_s": sum(s.seconds for s in r.stages if s.name in verify_stages)})
print(json.dumps(rows))
"""


def _api_rows(tmp: Path, spec: dict, steps: list[list[str]], cache: str, user_cache: Path | None = None) -> list:
    """:data:`_API_SCRIPT` in a fresh process: one row per step (see there)."""
    doc = [str(tmp / "out" / "pigeon"), str(tmp / cache), spec["preset"], [[*spec["sets"], *s] for s in steps],
           spec["verify"], list(VERIFY_STAGES)]
    r = subprocess.run([sys.executable, "-c", _API_SCRIPT, json.dumps(doc)], capture_output=True, text=True,
                       env=_env(user_cache))
    if r.returncode != 0:
        raise RuntimeError(f"the API benchmark process exited {r.returncode}: {r.stderr.strip()[-400:]}")
    return json.loads(r.stdout)


def _spec(preset: list[str]) -> dict:
    """The CLI options of :func:`_run`'s ``preset`` list as the API takes them."""
    sets = [preset[i + 1] for i, a in enumerate(preset) if a == "--set"]
    return {"preset": preset[preset.index("--preset") + 1], "sets": sets, "verify": "--no-verify" not in preset}


def _warm_rows(tmp: Path, preset: list[str], repeats: int, cache: str, first_value: float,
               user_cache: Path | None = None) -> list[dict]:
    """Film-only rebuilds inside one process that has rebuilt once already (its imports and per-process caches
    warm), on ``cache``: per timed rebuild ``{"wall_s", "verify_s"}``."""
    values = [first_value + 0.005 * i for i in range(repeats + 1)]  # none of them the last CLI run's value
    return _api_rows(tmp, _spec(preset), [[f"film.cauchy_a={v}"] for v in values], cache, user_cache)[1:]


def _api_table(tmp: Path, preset: list[str], repeats: int) -> dict:
    """Cold, no-op and film-only builds through the API in one fresh process (the cold one pays the imports),
    ``repeats`` processes: medians."""
    rows = [_api_rows(tmp, _spec(preset), [[], [], ["film.cauchy_a=1.57"], ["film.cauchy_a=1.58"]], f"api{i}")
            for i in range(repeats)]
    def med(j):
        return statistics.median(r[j]["wall_s"] for r in rows)

    return {"cold_s": med(0), "noop_s": med(1), "film_s": statistics.median(
        [r[2]["wall_s"] for r in rows] + [r[3]["wall_s"] for r in rows]), "film_ran": rows[-1][3]["ran"]}


def _watch_rows(tmp: Path, preset: list[str], repeats: int) -> dict:
    """``rockdove build --watch --json`` on a --config file of its own: the first build (cold, fresh cache), then
    per repeat the file touched unchanged (a no-op rebuild) and edited with a new film (a film-only rebuild),
    each timed from the write to the rebuild's one-line summary on stdout."""
    config = tmp / "watch.toml"
    config.write_text("[film]\ncauchy_a = 1.54\n")
    cmd = [sys.executable, "-m", "rockdove.cli", "build", "--watch", "--config", str(config), "--out",
           str(tmp / "watch" / "pigeon"), "--cache", str(tmp / "watch-cache"), "--json", "--quiet", *preset]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=_env())
    try:
        def next_summary() -> dict:
            line = proc.stdout.readline()
            if not line:
                raise RuntimeError(f"rockdove build --watch exited {proc.wait()}")
            return json.loads(line)

        next_summary()
        cold = time.perf_counter() - t0
        noops, films = [], []
        for i in range(repeats):
            time.sleep(0.3)
            t = time.perf_counter()
            os.utime(config)
            next_summary()
            noops.append(time.perf_counter() - t)
            t = time.perf_counter()
            config.write_text(f"[film]\ncauchy_a = {FILM_VALUES[i % len(FILM_VALUES)]}\n")
            ran = next_summary()["ran"]
            films.append(time.perf_counter() - t)
    finally:
        proc.terminate()
        proc.wait()
    return {"cold_s": cold, "noop_s": statistics.median(noops), "film_s": statistics.median(films), "film_ran": ran}


def _warm_film_s(tmp: Path, preset: list[str], repeats: int) -> float:
    """Median seconds of a film-only rebuild (no verify) in a warm process, on the cold build's cache."""
    return _median(_warm_rows(tmp, preset, repeats, "cold0", 1.50), "wall_s")


#: The libraries a film-only rebuild cannot avoid: the LUT (numpy, OpenEXR), the looks layer (pxr, MaterialX),
#: the preview and glTF (Pillow, pygltflib), the configuration (jsonschema).
FILM_FLOOR_IMPORTS = ("numpy", "pxr.Usd", "pxr.UsdShade", "OpenEXR", "MaterialX", "PIL.Image", "pygltflib",
                      "jsonschema")


def _import_floor_s() -> float:
    """Wall time of a fresh interpreter that imports :data:`FILM_FLOOR_IMPORTS` and does nothing else."""
    code = "import " + ", ".join(FILM_FLOOR_IMPORTS)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True)
    return time.perf_counter() - t0


def _verify_seconds(summary: dict) -> tuple[float, dict]:
    stages = {st["name"]: st for st in summary["stages"] if st["name"] in VERIFY_STAGES}
    return sum(st["seconds"] for st in stages.values()), stages


def _verify_rows(tmp: Path, preset: list[str], args) -> dict:
    """A cold verification (fresh cache, asset built first without verify) and a verification after a film-only
    change on that cache, each the seconds of the verification stages (:data:`VERIFY_STAGES`) of one build, once
    per repeat (each on a fresh cache); medians. Each repeat runs with a fresh user cache of its own
    (``$XDG_CACHE_HOME``): the cold verification validates meshes never seen before (NVIDIA's mesh rules run and
    are memoised), as a new geometry's first verification does. Then the same film-change verification in a warm
    process, on the last repeat's cache."""
    with_verify = [a for a in preset if a != "--no-verify"]
    size = ["--set", "verify.width=128", "--set", "verify.height=128"] if args.quick else []
    repeats = 1 if args.quick else max(1, args.repeats)
    colds, films, cold_walls, film_walls = [], [], [], []
    for i in range(repeats):
        cache, user = f"verify{i}", tmp / f"user-cache-verify{i}"
        _build_rss(tmp, *preset, *size, cache=cache, user_cache=user)
        cold = _build_rss(tmp, *with_verify, *size, cache=cache, allow_fail=True, user_cache=user)
        film = _build_rss(tmp, *with_verify, *size, "--set", "film.cauchy_a=1.56", cache=cache, allow_fail=True,
                          user_cache=user)
        colds.append(_verify_seconds(cold)[0])
        films.append(_verify_seconds(film)[0])
        cold_walls.append(cold["wall_s"])
        film_walls.append(film["wall_s"])
        last_film = film
    cold_v, film_v = statistics.median(colds), statistics.median(films)
    warm = _median(_warm_rows(tmp, with_verify + size, repeats, cache, 1.60, user_cache=user), "verify_s")
    report = Path(last_film["report"] or "") / "report.json"
    items = json.loads(report.read_text())["cache"] if last_film.get("report") else {}
    ran, reused = items.get("ran", {}), items.get("reused", {})
    out = {"cold_verify_s": cold_v, "film_verify_s": film_v, "ratio": film_v / cold_v, "goal_ratio": VERIFY_GOAL_RATIO,
           "cold_verify_runs_s": colds, "film_verify_runs_s": films,
           "surfaces_reused": reused.get("surfaces", []), "surfaces_ran": ran.get("surfaces", []),
           "views_ran": ran.get("views", []), "verified": [cold["verified"], film["verified"]],
           "warm_process_s": warm, "warm_process_ratio": warm / cold_v,
           "cold_build_wall_s": statistics.median(cold_walls), "film_build_wall_s": statistics.median(film_walls)}
    print(f"verify after a film-only change (median of {repeats}): {film_v:.2f} s against a cold verify of "
          f"{cold_v:.2f} s = {100 * out['ratio']:.1f} %, goal <= {100 * VERIFY_GOAL_RATIO:g} %: "
          f"{'met' if out['ratio'] <= VERIFY_GOAL_RATIO else 'NOT met'}; the reference's surfaces reused for "
          f"{len(out['surfaces_reused'])} cameras, ran for {len(out['surfaces_ran'])}; views re-rendered {len(out['views_ran'])}")
    print(f"  whole processes (the build and its verification, interpreter start to exit): after the film change "
          f"{out['film_build_wall_s']:.2f} s against {out['cold_build_wall_s']:.2f} s for the cold verification's "
          f"build")
    print(f"  in a warm process (as a sweep's Dask worker verifies its next point): {warm:.2f} s = "
          f"{100 * out['warm_process_ratio']:.1f} % of the cold verify, goal <= {100 * VERIFY_GOAL_RATIO:g} %: "
          f"{'met' if out['warm_process_ratio'] <= VERIFY_GOAL_RATIO else 'NOT met'}")
    return out


def _format_rows(counts) -> list[dict]:
    """The geometry payload (rockdove.usd.stage.author_geometry) written as usda and as usdc: size, write time."""
    from ..geometry import build_bird
    from ..geometry.params import BirdParams
    from ..usd.stage import author_geometry, new_stage

    rows = []
    print("cards    usda MB   usda write s   usdc MB   usdc write s")
    with tempfile.TemporaryDirectory(prefix="rockdove-bench-formats-") as tmp:
        for n in counts:
            stage = new_stage()
            author_geometry(stage, build_bird(BirdParams(card_count=n)))
            row = {"cards": n}
            for fmt in ("usda", "usdc"):
                path = os.path.join(tmp, f"geom_{n}.{fmt}")
                t0 = time.perf_counter()
                if not stage.GetRootLayer().Export(path):
                    raise RuntimeError(f"USD could not write {path}")
                row[f"{fmt}_write_s"] = time.perf_counter() - t0
                row[f"{fmt}_mb"] = os.path.getsize(path) / 1e6
            rows.append(row)
            print(f"{n:>7d}   {row['usda_mb']:>7.2f}   {row['usda_write_s']:>12.3f}   {row['usdc_mb']:>7.2f}   "
                  f"{row['usdc_write_s']:>12.3f}")
    return rows


def _lut_tradeoff(tmp: Path, args, preset: list[str]) -> dict | str:
    sizes = ((32, 8), (128, 32)) if args.quick else ((32, 8), (64, 16), (128, 32), (256, 64), (512, 128))
    rows = []
    print("angles x thicknesses  precision  build s   lut s   median dE  p95 dE  max dE  verification")
    for angles, thick in sizes:
        for precision in ("float32", "half"):
            with_verify = [a for a in preset if a != "--no-verify"]
            r = _build_rss(tmp, *with_verify, "--set", f"lut.angles={angles}", "--set", f"lut.thicknesses={thick}",
                           "--set", f"lut.precision={precision}", "--set", "verify.width=256", "--set",
                           "verify.height=256", cache="cold0", allow_fail=True)
            report = _verify_metrics(Path(r["report"])) if r.get("report") else {}
            report["passed"] = bool(r.get("verified"))
            rows.append({"angles": angles, "thicknesses": thick, "precision": precision, "wall_s": r["wall_s"],
                         **report})
            lut_s = sum(st["seconds"] for st in r["stages"] if st["name"] == "lut")
            rows[-1]["lut_s"] = lut_s
            print(f"{angles:>6d} x {thick:<12d} {precision:>9s}  {r['wall_s']:>7.2f}  {lut_s:>6.2f}  "
                  f"{report.get('median_dE', float('nan')):>8.3f}  {report.get('p95_dE', float('nan')):>6.3f}  "
                  f"{report.get('max_dE', float('nan')):>6.3f}  {'pass' if report['passed'] else 'FAIL'}")
    return {"rows": rows}


def _verify_metrics(report_dir: Path) -> dict:
    """Worst median / p95 / max dE2000 over the views of a verification report folder (``report.json``)."""
    path = report_dir / "report.json"
    if not path.exists():
        return {}
    data = json.loads(path.read_text())
    views = data.get("views", {})
    vals = list(views.values()) if isinstance(views, dict) else list(views)
    out = {}
    for key, src in (("median_dE", "de_median"), ("p95_dE", "de_p95"), ("max_dE", "de_max")):
        xs = [v[src] for v in vals if isinstance(v, dict) and isinstance(v.get(src), (int, float))]
        if xs:
            out[key] = max(xs)
    return out

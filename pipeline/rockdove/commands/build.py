"""``rockdove build``: build the pigeon asset incrementally and publish it atomically.

Order of work: configuration checked (exit 2 on any problem, nothing written) -> output checked (a folder
rockdove created, or a new/empty one) -> lock taken (a second build of the same output waits) -> leftovers of
killed builds cleaned -> stages run or reused from the cache -> asset assembled in a staging folder beside
the output, marker written -> verification on the staged asset (unless ``--no-verify``) -> atomic swap into
place. Ctrl-C and SIGTERM remove the staging folder and the cache's temporaries; a failed verification
publishes nothing and exits 1.
"""

from __future__ import annotations

import argparse
import json
import shutil
import signal
import sys
import threading
import time
from pathlib import Path

from ..config import DEFAULT_PRESET, config_hash, load_config
from ..errors import VerificationFailed

DEFAULT_OUT = "build/pigeon"


def add_config_arguments(parser: argparse.ArgumentParser) -> None:
    """The options that choose the configuration (shared with ``rockdove config``)."""
    parser.add_argument("--preset", default=DEFAULT_PRESET, metavar="NAME",
                        help=f"asset recipe assets/pigeon/NAME.toml: measured or paper (default {DEFAULT_PRESET})")
    parser.add_argument("--config", metavar="FILE.toml", help="a TOML file layered over the preset")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override one key (dotted, value a TOML literal), e.g. --set lut.angles=128; repeatable")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_arguments(parser)
    parser.add_argument("--out", default=DEFAULT_OUT, metavar="DIR", help=f"asset folder (default {DEFAULT_OUT})")
    parser.add_argument("--cache", metavar="DIR",
                        help="stage cache folder (default .rockdove-cache beside the output folder)")
    parser.add_argument("--no-verify", action="store_true", help="skip the verification renders")
    parser.add_argument("--lock-timeout", type=float, default=None, metavar="SECONDS",
                        help="give up (exit 2) if another build of the same output holds the lock this long "
                             "(default: wait until it finishes)")
    parser.add_argument("--json", action="store_true", help="print a JSON summary (stages ran and reused) on stdout")
    parser.add_argument("--quiet", action="store_true", help="no progress bar and no summary text")


class BuildFailed(VerificationFailed):
    """Verification failed; ``summary`` is the build summary (what ran, where the report is)."""

    def __init__(self, message: str, summary: dict):
        super().__init__(message)
        self.summary = summary


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


class _Progress:
    """A tqdm bar over the stages on stderr; silent with --quiet or when stderr is not a terminal."""

    def __init__(self, total: int, quiet: bool):
        self.bar = None
        if not quiet and sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, file=sys.stderr, unit="stage", leave=False)
        self.started = False

    def __call__(self, name: str) -> None:
        if self.bar is not None:
            if self.started:
                self.bar.update(1)
            self.started = True
            self.bar.set_description(name)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.update(1 if self.started else 0)
            self.bar.close()


def _summary(graph, args, out, cache_dir, chash, t0, *, verified, report, notes=()) -> dict:
    """The --json summary: which stages ran and which were reused (and, for per-view verification, which views
    were rendered and which reused), keys, timings, the verdict and its notes (what was checked differently)."""
    records = [r.as_dict() for r in graph.records.values()]
    return {
        "out": str(out), "cache": str(cache_dir), "preset": args.preset, "config_hash": chash,
        "ran": [r["name"] for r in records if r["status"] == "ran"],
        "reused": [r["name"] for r in records if r["status"] == "reused"],
        "stages": records, "verified": verified, "report": report, "notes": list(notes),
        "seconds": round(time.perf_counter() - t0, 4),
    }


def _notes(verdicts: dict) -> list:
    return [n for v in verdicts.values() if isinstance(v, dict) for n in v.get("notes", [])]


def parse_args(argv: list[str]) -> argparse.Namespace:
    """``rockdove build``'s options from ``argv`` (e.g. ``["--out", "o/p", "--set", "lut.angles=64"]``), for
    callers of :func:`build` such as ``rockdove sweep``: one parser, the same defaults and checks."""
    parser = argparse.ArgumentParser(prog="rockdove build", add_help=False, exit_on_error=False)
    add_arguments(parser)
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> int:
    try:
        summary = build(args)
    except BuildFailed as exc:
        if args.json:  # the summary still says what ran and where the report is
            print(json.dumps(exc.summary, indent=1))
        raise
    if args.json:
        print(json.dumps(summary, indent=1))
    elif not args.quiet:
        print(f"rockdove build: {summary['out']} ({len(summary['ran'])} stages ran: {', '.join(summary['ran']) or '-'}; "
              f"{len(summary['reused'])} reused) in {summary['seconds']:.2f} s")
        if summary["verified"]:
            print(f"rockdove build: verified: renders match the exact spectral reference; report "
                  f"{Path(summary['out']) / 'verify' / 'report.html'}")
        elif summary["verified"] is None:
            print("rockdove build: not verified (--no-verify)")
        for note in summary["notes"]:
            print(f"rockdove build: note: {note}")
    return 0


def build(args: argparse.Namespace) -> dict:
    """Build, verify and publish the asset ``args`` (:func:`parse_args`) ask for; return the summary that
    ``--json`` prints. Raises :class:`UsageError` for bad configuration or output (nothing written) and
    :class:`BuildFailed` (a :class:`VerificationFailed` carrying the summary) when verification fails.
    Callable from any thread: SIGTERM is handled only when called from the main thread."""
    from ..graph.engine import Cache, Graph
    from ..graph.publish import OutputLock, check_output, make_staging, publish, read_marker, recover, write_marker
    from ..errors import UsageError

    t0 = time.perf_counter()
    config = load_config(preset=args.preset, config_file=args.config, overrides=args.overrides)
    if not args.out.strip():
        raise UsageError("--out is empty; give the asset folder, e.g. --out build/pigeon")
    out = Path(args.out)
    check_output(out)
    cache_dir = Path(args.cache) if args.cache else out.parent / ".rockdove-cache"
    if cache_dir.exists() and not cache_dir.is_dir():
        raise UsageError(f"--cache {str(cache_dir)!r} exists and is not a folder")
    from ..graph import stages as build_stages

    stages = build_stages.make_stages(config, verify=not args.no_verify)
    chash = config_hash(config)
    verified_before = (out / "verify" / "report.json").is_file()
    if not args.no_verify and ((read_marker(out) or {}).get("config_hash") != chash or not verified_before):
        # A new configuration, or one not verified yet, will most likely render: start the verification's worker
        # process now, so that its imports (pyrender, ~2 s) run on the other core while the LUT, textures and
        # layers are built.
        from ..verify import worker

        worker.prestart()

    main_thread = threading.current_thread() is threading.main_thread()
    old_term = signal.signal(signal.SIGTERM, _raise_interrupt) if main_thread else None
    staging = None
    progress = _Progress(len(stages), args.quiet)
    try:
        with OutputLock(out, timeout_s=args.lock_timeout, quiet=args.quiet):
            recover(out)
            cache = Cache(cache_dir)
            cache.clean_temporaries()
            graph = Graph(stages, config, cache, progress=progress)
            graph.run()
            staging = make_staging(out)
            graph.assemble(staging)
            write_marker(staging, {"config_hash": chash, "preset": args.preset,
                                   "stages": {n: r.key for n, r in graph.records.items()}})
            graph.run(asset_dir=staging, needs_asset=True)
            graph.assemble(staging, needs_asset=True)
            # the verdicts of the verification stages: the values with a "passed" key (not the glb or the rays)
            values = {n: graph.value(n) for n, s in graph.stages.items() if s.needs_asset}
            verdicts = {n: v for n, v in values.items() if isinstance(v, dict) and "passed" in v}
            failed = [n for n, v in verdicts.items() if v["passed"] is False]
            if failed:
                raise BuildFailed(
                    f"stage {failed[0]!r} failed ({verdicts[failed[0]].get('reason', 'see its report')}); "
                    f"{out} was left unchanged; report in {graph.entry_dir(failed[0])}",
                    _summary(graph, args, out, cache_dir, chash, t0, verified=False,
                             report=str(graph.entry_dir(failed[0])), notes=_notes(verdicts)))
            publish(staging, out)
            staging = None
    finally:
        progress.close()
        if staging is not None and staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
        if main_thread:
            signal.signal(signal.SIGTERM, old_term)

    return _summary(graph, args, out, cache_dir, chash, t0, verified=bool(verdicts) or None,
                    report=str(out / "verify") if verdicts else None, notes=_notes(verdicts))

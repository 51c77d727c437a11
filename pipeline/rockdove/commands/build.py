"""``rockdove build``: options into :func:`rockdove.api.build`'s arguments, its result into text, and ``--watch``.
A failed verification publishes nothing and exits 1; Ctrl-C and SIGTERM leave the previous asset in place."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from .. import api
from ..api import DEFAULT_OUT
from ..config import DEFAULT_PRESET, preset_path
from ..errors import RockdoveError, VerificationFailed


def add_config_arguments(parser: argparse.ArgumentParser) -> None:
    """The options that choose the configuration (shared with ``config`` and ``sweep``)."""
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
    parser.add_argument("--watch", action="store_true",
                        help="stay running: rebuild (in this warm process) whenever the --config file or the "
                             "preset file changes; a failed rebuild prints its error and keeps watching; Ctrl-C ends")


class _Progress:
    """A tqdm bar over the stages on stderr; silent with --quiet or when stderr is not a terminal."""

    def __init__(self, total: int, quiet: bool):
        from tqdm import tqdm

        self.bar = tqdm(total=total, file=sys.stderr, unit="stage", leave=False,
                        disable=quiet or not sys.stderr.isatty())
        self.started = False

    def __call__(self, name: str) -> None:
        self.bar.update(int(self.started))
        self.started = True
        self.bar.set_description(name)

    def close(self) -> None:
        self.bar.update(int(self.started))
        self.bar.close()


def _print(result, args) -> None:
    if args.json:  # a failed build's summary still says what ran and where the report is
        print(json.dumps({**result.as_dict(), "preset": args.preset}, indent=None if args.watch else 1), flush=True)
    elif not args.quiet and result.verified is not False:
        print(f"rockdove build: {result.out} ({len(result.ran)} stages ran: {', '.join(result.ran) or '-'}; "
              f"{len(result.reused)} reused) in {result.seconds:.2f} s")
        if result.verified:
            print(f"rockdove build: verified: renders match the exact spectral reference; report "
                  f"{result.report_dir / 'report.html'}")
        else:
            print("rockdove build: not verified (--no-verify)")
        for note in result.notes:
            print(f"rockdove build: note: {note}")


def build_once(args: argparse.Namespace):
    """One build of ``args``: its result, printed."""
    config = api.load_config(preset=args.preset, config_file=args.config, overrides=args.overrides)
    from ..graph.stages import make_stages

    progress = _Progress(len(make_stages(config, verify=not args.no_verify)), args.quiet)
    try:
        result = api.build(config, args.out, cache=args.cache, verify=not args.no_verify,
                           lock_timeout=args.lock_timeout, progress=progress)
    except api.BuildFailed as exc:
        progress.close()
        _print(exc.result, args)
        raise
    progress.close()
    _print(result, args)
    return result


def run(args: argparse.Namespace) -> int:
    if args.watch:
        return watch(args)
    build_once(args)
    return 0


#: Seconds between two looks at the watched files' modification times.
POLL_S = 0.1


def _stamp(files: list[Path]) -> tuple:
    def one(p: Path):
        try:
            st = p.stat()
        except OSError:
            return None  # missing: its return is a change too
        return st.st_mtime_ns, st.st_size, st.st_ino
    return tuple(one(p) for p in files)


def watch(args: argparse.Namespace) -> int:
    """``rockdove build --watch``: build now, then again in this warm process each time the preset's or the
    --config file changes (mtime, size or inode). A failed build prints its one-line error (with --json, a
    ``{"error": ...}`` line) and the watch goes on; Ctrl-C ends it."""
    files = [preset_path(args.preset)] + ([Path(args.config)] if args.config else [])
    try:
        while True:
            stamp = _stamp(files)  # before the build: an edit during it starts the next one
            try:
                build_once(args)
            except (RockdoveError, OSError) as exc:
                kind = "failed" if isinstance(exc, VerificationFailed) else "error"
                print(f"rockdove build: {kind}: {exc}", file=sys.stderr, flush=True)
                if args.json:
                    print(json.dumps({"error": str(exc), "kind": kind}), flush=True)
            if not args.quiet:
                print(f"rockdove build: watching {', '.join(map(str, files))} (Ctrl-C ends)", file=sys.stderr,
                      flush=True)
            while _stamp(files) == stamp:
                time.sleep(POLL_S)
            settled = None  # a write in two steps (truncate, then write) must not build the empty file: wait
            while (now := _stamp(files)) != settled:  # until the stamp holds still for one poll
                settled = now
                time.sleep(POLL_S)
    except KeyboardInterrupt:
        print("rockdove build: stopped watching", file=sys.stderr)
    return 0

"""Run the real ``rockdove`` CLI in a fresh interpreter with test doubles patched in from outside.

    python tests/launcher.py [--standin] [--pause-after POINT] [--release FILE] -- ARGS...

- ``--standin`` replaces the build's stages with the stand-in pipeline of ``tests/standins.py``.
- ``--pause-after POINT`` stops the build right after POINT: a stage name, ``assemble`` (the first
  assembly of the staging folder), ``publish-swap`` (the atomic swap done, the old asset not yet removed) or
  ``store:STAGE`` (inside the cache's store of STAGE: its temporary folder filled, not yet renamed). The
  launcher prints ``paused after POINT`` on stderr and waits: until FILE exists when ``--release FILE`` is
  given (so a test releases it when it is ready, with no race against a clock), else until it is killed.

Production code reads no environment variable or file for any of this: the doubles are patched in here, the
way a pytest fixture would, before :func:`rockdove.cli.main` runs.
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import time


def _pause(point: str, release: str | None) -> None:
    print(f"rockdove: paused after {point}", file=sys.stderr, flush=True)
    while release is None or not os.path.exists(release):
        time.sleep(0.02)


def _patch(standin: bool, point: str | None, release: str | None) -> None:
    from rockdove.graph import engine as graph
    from rockdove.graph import publish, stages

    if standin:
        from standins import standin_stages

        stages.make_stages = standin_stages
    if point is None:
        return
    if point == "assemble":
        original = graph.Graph.assemble

        @functools.wraps(original)
        def assemble(self, asset_dir, *, needs_asset=False):
            original(self, asset_dir, needs_asset=needs_asset)
            if not needs_asset:
                _pause(point, release)

        graph.Graph.assemble = assemble
    elif point.startswith("store:"):
        store = graph.Cache.store

        def paused_store(self, stage, key, fill, extra=None):
            def fill_then_pause(folder):
                fill(folder)
                if stage == point[6:]:
                    _pause(point, release)
            return store(self, stage, key, fill_then_pause, extra)

        graph.Cache.store = paused_store
    elif point == "publish-swap":
        exchange = publish._exchange

        def swapped(a, b):
            done = exchange(a, b)
            if not done:
                raise SystemExit("launcher: this file system has no atomic exchange; publish-swap cannot pause")
            _pause(point, release)
            return done

        publish._exchange = swapped
    else:
        run_stage = graph.Graph._run_stage

        @functools.wraps(run_stage)
        def run_then_pause(self, stage, asset_dir):
            record = run_stage(self, stage, asset_dir)
            if stage.name == point:
                _pause(point, release)
            return record

        graph.Graph._run_stage = run_then_pause


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--standin", action="store_true")
    parser.add_argument("--pause-after")
    parser.add_argument("--release")
    parser.add_argument("args", nargs=argparse.REMAINDER)
    ns = parser.parse_args()
    args = ns.args[1:] if ns.args[:1] == ["--"] else ns.args
    _patch(ns.standin, ns.pause_after, ns.release)
    from rockdove.cli import main as cli_main

    return cli_main(args)


if __name__ == "__main__":
    sys.exit(main())

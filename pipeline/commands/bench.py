"""``rockdove bench [TOPIC]``: run the benchmarks of one topic, or all of them."""

from __future__ import annotations

import argparse
import importlib
import os

from ..bench import TOPICS

HELP = "benchmarks: LUT bake speed against error, geometry and build scaling, render time"


def _available() -> list[str]:
    here = os.path.join(os.path.dirname(os.path.dirname(__file__)), "bench")
    return [t for t in TOPICS if os.path.exists(os.path.join(here, f"{t}.py"))]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="topic", metavar="TOPIC")
    for topic in _available():
        mod = importlib.import_module(f"pipeline.bench.{topic}")
        p = sub.add_parser(topic, help=mod.HELP, description=mod.HELP)
        mod.add_arguments(p)


def run(args: argparse.Namespace) -> int:
    topics = [args.topic] if getattr(args, "topic", None) else _available()
    status = 0
    for topic in topics:
        mod = importlib.import_module(f"pipeline.bench.{topic}")
        if not getattr(args, "topic", None):
            # running every topic: each with its own defaults
            p = argparse.ArgumentParser()
            mod.add_arguments(p)
            topic_args = p.parse_args([])
        else:
            topic_args = args
        status = max(status, int(mod.run(topic_args) or 0))
    return status

"""``rockdove bench [TOPIC]``: run the benchmarks of one topic, or all of them."""

from __future__ import annotations

import argparse
import importlib

from ..bench import TOPICS


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="topic", metavar="TOPIC")
    for topic in TOPICS:
        mod = importlib.import_module(f"rockdove.bench.{topic}")
        p = sub.add_parser(topic, help=mod.HELP, description=mod.HELP)
        mod.add_arguments(p)


def run(args: argparse.Namespace) -> int:
    status = 0
    for topic in [args.topic] if args.topic else TOPICS:
        mod = importlib.import_module(f"rockdove.bench.{topic}")
        topic_args = args
        if not args.topic:  # every topic, each with its own defaults
            p = argparse.ArgumentParser()
            mod.add_arguments(p)
            topic_args = p.parse_args([])
        status = max(status, int(mod.run(topic_args) or 0))
    return status

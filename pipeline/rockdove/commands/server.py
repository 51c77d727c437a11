"""``rockdove server start|stop|status``: the build server (:mod:`rockdove.server`).

``start`` runs it in the background for this interpreter and environment and waits until it takes commands
(``--foreground``: in this process, until stopped); later ``rockdove build`` and the other served commands
started with the same interpreter and environment run in it. ``stop`` ends it after the command it runs;
``status`` prints its state (``--json``); it exits 1 when no server runs.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from .. import server


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("start", "stop", "status"), help="what to do")
    parser.add_argument("--idle-minutes", type=float, default=server.IDLE_MINUTES,
                        help=f"start: exit after this many minutes without a command (default {server.IDLE_MINUTES:g})")
    parser.add_argument("--foreground", action="store_true", help="start: serve in this process until stopped")
    parser.add_argument("--json", action="store_true", help="print the server's state as JSON")


def _describe(info: dict) -> str:
    up = time.time() - info["started"]
    if info["busy"]:
        state = "running a command"
    else:
        state = f"idle {info['idle_s']:.0f} s (exits after {info['idle_limit_s']:.0f} s)"
    if info.get("stale"):
        state += "; runs older code than is installed now (it stops at the next command; `start` replaces it)"
    return (f"pid {info['pid']}, up {up:.0f} s, {info['served']} commands served, {state}, peak memory "
            f"{info['peak_rss_mib']:.0f} MiB\n  socket {info['socket']}\n  log    {info['log']}")


def run(args: argparse.Namespace) -> int:
    try:
        if args.action == "start":
            if args.foreground:
                server.exec_foreground(args.idle_minutes)  # does not return
            info = server.start(args.idle_minutes)
            word = "already running" if info.pop("already") else "started"
        elif args.action == "stop":
            info = server.stop()
            word = "stopped"
        else:
            info = server.status()
            word = "running"
    except server.ServerError as exc:
        print(f"rockdove server {args.action}: error: {exc}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps({"running": info is not None and args.action != "stop", **(info or {})}, indent=1))
    elif info is None:
        print("rockdove server: none running for this interpreter and environment")
    else:
        print(f"rockdove server {word}: {_describe(info)}")
    return 0 if info is not None else 1

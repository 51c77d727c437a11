"""``rockdove sweep``: build (and verify) every point of a parameter grid on a Dask cluster.

``--grid 'KEY=[V1, V2, ...]'`` gives one axis (values are TOML literals exactly as ``--set`` takes them, bare
words included); several ``--grid`` make their product. ``--preset``, ``--config`` and ``--set`` are the base
of every point; a point's grid values are applied last. Each point is one call of ``rockdove build``'s
:func:`rockdove.api.build` on a Dask worker, into ``DIR/points/<name>`` (``<name>``: the point's
``KEY=VALUE`` pairs joined by ``__``, stable across runs), all sharing one stage cache (``DIR/.rockdove-cache``
unless ``--cache``): the body and bird are built once per geometry, whichever worker gets there first
(:meth:`rockdove.graph.engine.Cache.entry_lock`), and every point is byte-identical to a serial ``rockdove
build`` with the same overrides.

Dask runs it: a ``distributed.LocalCluster`` of ``--workers`` processes (one thread each) by default, or the
cluster of ``--scheduler tcp://HOST:PORT`` (its workers must have rockdove installed and see ``DIR``). The
local cluster is private: TLS with a certificate made for this sweep and held in memory
(``Security.temporary()``), so another local user who finds its port cannot submit code to run as you. An
external cluster that uses TLS takes ``--security FILE`` (Dask configuration YAML, its
``distributed.comm.tls`` section) or Dask's own configuration. A worker
that dies mid-point has the point rescheduled on another worker by Dask's scheduler (up to its
``distributed.scheduler.allowed-failures``); the killed build leaves no half-written asset and its cache
temporaries are cleaned by the next build.

Outputs, rewritten as each point finishes: ``DIR/sweep.json`` (per point: overrides, values, configuration
hash, asset path, build and verify summary, seconds, worker) and ``DIR/index.html`` (the points' light-sweep
renders and hue histograms laid out by the swept keys, a progress bar and a 2 s refresh while running).

Exit status: 2 for bad usage (grid syntax, unknown key, duplicate value, a base configuration that is invalid,
an unreachable scheduler) before anything runs; 1 when any point failed (an invalid configuration, a failed
verification, an error), after all the others finished; 0 otherwise.
"""

from __future__ import annotations

import argparse
import html
import itertools
import json
import os
import re
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from .build import add_config_arguments
from ..resources import write_atomic

HELP = "build (and verify) every point of a parameter grid on Dask (a local cluster or --scheduler)"
POINTS = "points"
REFRESH_S = 2


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_arguments(parser)
    parser.add_argument("--grid", action="append", default=[], metavar="KEY=[V1, V2, ...]",
                        help="one swept key and its values (TOML literals as --set takes them); several --grid "
                             "make their product, e.g. --grid 'film.cauchy_a=[1.5, 1.55]'")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="sweep folder: DIR/points/<point>/, DIR/sweep.json, DIR/index.html")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="an existing Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: a local cluster)")
    parser.add_argument("--security", metavar="FILE",
                        help="with --scheduler tls://...: Dask configuration YAML with the cluster's TLS files "
                             "(distributed.comm.tls: ca-file, client.cert, client.key); default: Dask's config")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="worker processes of the local cluster (default: the CPU count)")
    parser.add_argument("--cache", metavar="DIR", help="shared stage cache (default DIR/.rockdove-cache)")
    parser.add_argument("--no-verify", action="store_true", help="build only, no verification renders")
    parser.add_argument("--json", action="store_true", help="print sweep.json on stdout at the end")


# ----------------------------------------------------------------------------------------------- the grid
@dataclass(frozen=True)
class Point:
    """One grid point: ``overrides`` (``KEY=LITERAL`` as --set takes them), ``values`` (parsed), ``index``
    (the value index along each axis), and its folder ``name``."""

    name: str
    overrides: tuple[str, ...]
    values: dict
    index: tuple[int, ...]


def split_array(text: str) -> list[str]:
    """The top-level elements of a TOML array literal ``[a, "b, c", [1, 2]]``, as written (quotes and nested
    brackets respected, a trailing comma allowed). Raises ValueError naming what is wrong."""
    text = text.strip()
    if not (text.startswith("[") and text.endswith("]")):
        raise ValueError(f"{text!r} is not a [list] of values")
    items, cur, depth, quote, escaped = [], [], 0, None, False
    for c in text[1:-1]:
        if quote:
            if escaped:
                escaped = False
            elif c == "\\" and quote == '"':
                escaped = True
            elif c == quote:
                quote = None
        elif c in "\"'":
            quote = c
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
            if depth < 0:
                raise ValueError(f"{text!r} has an unmatched {c!r}")
        elif c == "," and depth == 0:
            items.append("".join(cur).strip())
            cur = []
            continue
        cur.append(c)
    if quote or depth:
        raise ValueError(f"{text!r} has an unclosed {quote or 'bracket'}")
    items.append("".join(cur).strip())
    if items and items[-1] == "":
        items.pop()  # trailing comma
    if not items or any(it == "" for it in items):
        raise ValueError(f"{text!r} has an empty value" if items else f"{text!r} is empty; give at least one value")
    return items


def parse_grid(grid: list[str]) -> list[tuple[str, list[tuple[str, object]]]]:
    """``--grid`` items -> ``[(key, [(literal, value), ...]), ...]``. Raises UsageError (exit 2) for bad
    syntax, an unknown key, a key given twice or a value given twice."""
    from ..config import parse_set
    from ..errors import UsageError

    if not grid:
        raise UsageError("no --grid given; e.g. --grid 'film.cauchy_a=[1.5, 1.55]'")
    axes = []
    for item in grid:
        if "=" not in item:
            raise UsageError(f"--grid {item!r} is not KEY=[V1, V2, ...]; e.g. --grid 'film.cauchy_a=[1.5, 1.55]'")
        key, text = (s.strip() for s in item.split("=", 1))
        try:
            literals = split_array(text)
        except ValueError as exc:
            raise UsageError(f"--grid {item!r}: {exc}; e.g. --grid '{key}=[V1, V2]'") from None
        values = [parse_set(f"{key}={lit}")[1] for lit in literals]  # the key's syntax and each literal's
        node = _schema_node(key)
        if node is None:
            raise UsageError(f"--grid {item!r}: unknown key {key!r}; `rockdove config` lists the keys")
        if "properties" in node:
            raise UsageError(f"--grid {item!r}: {key!r} is a section; sweep one of its keys, e.g. {key}.<name>")
        if key in (k for k, _ in axes):
            raise UsageError(f"--grid {key!r} is given twice; put all its values in one list")
        seen = {}
        for lit, v in zip(literals, values):
            canon = json.dumps(v, sort_keys=True, default=str)
            if canon in seen:
                raise UsageError(f"--grid {item!r}: value {lit} is given twice (as {seen[canon]})")
            seen[canon] = lit
        axes.append((key, list(zip(literals, values))))
    return axes


def _schema_node(key: str) -> dict | None:
    """The configuration schema's node for dotted ``key``, or None when the schema has no such key."""
    from ..config import load_schema

    node = load_schema()
    for part in key.split("."):
        node = node.get("properties", {}).get(part)
        if node is None:
            return None
    return node


_UNSAFE = re.compile(r"[^A-Za-z0-9._+=-]+")


def _slug(key: str, literal: str) -> str:
    value = _UNSAFE.sub("_", literal.replace('"', "").replace("'", "")).strip("_")
    return f"{key}={value}"


def grid_points(axes) -> list[Point]:
    """The product of the axes in order (the last key varies fastest), each with a stable, readable folder
    name made of its ``KEY=VALUE`` pairs (a short hash added where two would read the same, or one is long)."""
    import hashlib

    points = []
    for combo in itertools.product(*[list(enumerate(vals)) for _, vals in axes]):
        overrides = tuple(f"{key}={lit}" for (key, _), (_, (lit, _v)) in zip(axes, combo))
        values = {key: v for (key, _), (_, (_lit, v)) in zip(axes, combo)}
        name = "__".join(_slug(key, lit) for (key, _), (_, (lit, _v)) in zip(axes, combo))
        points.append(Point(name, overrides, values, tuple(i for i, _ in combo)))
    counts: dict[str, int] = {}
    for p in points:
        counts[p.name] = counts.get(p.name, 0) + 1
    out = []
    for p in points:
        if counts[p.name] > 1 or len(p.name) > 150:
            h = hashlib.sha256("\n".join(p.overrides).encode()).hexdigest()[:8]
            p = Point(f"{p.name[:150]}-{h}", p.overrides, p.values, p.index)
        out.append(p)
    return out


# ----------------------------------------------------------------------------------------------- a point
# glibc mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3


def _restore_malloc_thresholds() -> None:
    """Undo, for this worker process, what Dask's nanny's ``MALLOC_TRIM_THRESHOLD_=65536`` does to numpy code.

    Setting any malloc threshold freezes glibc's adaptive mmap threshold at 128 KiB, so every numpy temporary
    above that becomes a fresh mmap and its pages fault in again: measured on this machine, the body stage took
    4x the CPU time in a Dask worker (6.0 s against 1.35 s in a plain process). With the mmap threshold at
    glibc's adaptive maximum (32 MiB) and the trim threshold at 64 MiB it took 1.56 s. No-op off glibc.
    """
    import ctypes

    try:
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(_M_MMAP_THRESHOLD, 32 << 20)
        libc.mallopt(_M_TRIM_THRESHOLD, 64 << 20)
    except (OSError, AttributeError):
        pass


_ONE_POINT_AT_A_TIME = threading.Lock()  # a worker with several threads builds one point at a time (GL, memory)


def build_point(name: str, base: dict, overrides: list[str], out: str, verify: bool) -> dict:
    """Build one point on a Dask worker with :func:`rockdove.api.build`: the configuration of ``base``
    (``preset``, ``config_file``, ``overrides``) and the point's ``overrides`` (``KEY=VALUE``), into ``out``
    with ``base["cache"]``. Returns the point's record; a bad configuration, a failed verification or any other
    error is recorded, not raised, so the point fails alone (only a worker's death makes Dask retry it
    elsewhere)."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")  # before anything imports OpenGL
    _restore_malloc_thresholds()
    from .. import api

    record: dict = {"name": name, "pid": os.getpid(), "worker": _worker_address()}
    t0 = time.perf_counter()
    result = None
    with _ONE_POINT_AT_A_TIME:
        try:
            config = api.load_config(preset=base["preset"], config_file=base["config_file"],
                                     overrides=[*base["overrides"], *overrides])
            result = api.build(config, out, cache=base["cache"], verify=verify, quiet=True)
            record["status"] = "ok"
        except api.BuildFailed as exc:
            result = exc.result
            record.update(status="failed", error=str(exc))
        except api.VerificationFailed as exc:
            record.update(status="failed", error=str(exc))
        except (ValueError, OSError) as exc:
            record.update(status="invalid" if isinstance(exc, ValueError) else "error", error=str(exc))
        except Exception as exc:  # noqa: BLE001 - the point fails alone, with its message
            record.update(status="error", error=f"{type(exc).__name__}: {exc}")
    record["seconds"] = round(time.perf_counter() - t0, 3)
    if result is not None:
        summary = result.as_dict()
        record["config_hash"] = summary["config_hash"]
        record["build"] = {k: summary[k] for k in ("ran", "reused", "seconds")}
        record["verify"] = _verify_summary(summary)
        record["images"] = _images(Path(out), summary)
    return record


def _worker_address() -> str | None:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return None


def _verify_summary(summary: dict) -> dict | None:
    """From the build summary and its report.json: verdict, failures, dE2000 over the views, hue counts."""
    if summary.get("verified") is None:
        return None
    out = {"passed": bool(summary["verified"]), "notes": summary.get("notes", [])}
    try:
        report = json.loads((Path(summary["report"]) / "report.json").read_text())
    except (OSError, ValueError, TypeError):
        return out
    views = [v for v in report.get("views", []) if isinstance(v, dict)]
    medians = [v["de_median"] for v in views if v.get("de_median") is not None]
    p95s = [v["de_p95"] for v in views if v.get("de_p95") is not None]
    hue = report.get("hue_sweep") or {}
    out.update(failures=[str(f) for f in report.get("failures", [])],
               median_dE=max(medians) if medians else None, p95_dE=max(p95s) if p95s else None,
               hue={k: hue.get(k) for k in ("green", "purple", "grey", "other")} if hue else None)
    return out


def _images(out: Path, summary: dict) -> dict:
    """Absolute paths of the light-sweep renders and the hue histogram (the published verify/ folder, or the
    failed verification's report folder), or the LUT preview when not verified."""
    report = Path(summary["report"]) if summary.get("report") else None
    if report is not None and report.is_dir():
        return {"sweep": [str(p) for p in sorted(report.glob("sweep_*_gl.png"))],
                "hue": str(report / "hue.png") if (report / "hue.png").is_file() else None}
    preview = out / "textures" / "feather_preview.png"
    return {"preview": str(preview)} if preview.is_file() else {}


# ----------------------------------------------------------------------------------------------- the page
def _rel(path: str | None, root: Path) -> str | None:
    return None if not path else os.path.relpath(path, root)


def write_index(root: Path, doc: dict, axes_keys: list[str], axes_values: list[list[str]]) -> None:
    """``DIR/index.html``: one cell per point, rows = the product of all swept keys but the last, columns =
    the last key's values; a progress bar (and a refresh) while the sweep runs."""
    points = doc["points"]
    by_index = {tuple(p["index"]): p for p in points}
    col_key, col_vals = axes_keys[-1], axes_values[-1]
    row_keys, row_lists = axes_keys[:-1], axes_values[:-1]
    e = html.escape
    running = doc["state"] == "running"
    rows = []
    head = "".join(f"<th>{e(col_key)} = {e(v)}</th>" for v in col_vals)
    for ridx in itertools.product(*[range(len(v)) for v in row_lists]):
        label = "<br>".join(f"{e(k)} = {e(row_lists[i][j])}" for i, (k, j) in enumerate(zip(row_keys, ridx)))
        cells = [f"<th>{label or '&nbsp;'}</th>"]
        for c in range(len(col_vals)):
            cells.append(f"<td>{_cell(by_index.get(ridx + (c,)), root)}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    done, total = doc["done"], doc["total"]
    refresh = f'<meta http-equiv="refresh" content="{REFRESH_S}">' if running else ""
    failed = sum(1 for p in points if p.get("status") not in (None, "pending", "ok"))
    state = (f"running: {done} of {total} points done" if running else
             f"interrupted: {done} of {total} points done" if doc["state"] == "interrupted" else
             f"finished: {total - failed} of {total} points ok" + (f", {failed} failed" if failed else "")
             + f" in {doc['seconds']:.1f} s")
    page = f"""<!doctype html>
<html><head><meta charset="utf-8">{refresh}<title>rockdove sweep</title>
<style>body{{font-family:sans-serif;margin:1em}} table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:4px;vertical-align:top;font-size:12px}} img{{display:block;max-width:220px}}
.ok{{color:#070}} .bad{{color:#a00}} .pending{{color:#888}} progress{{width:30em}}</style></head>
<body><h1>rockdove sweep</h1>
<p><progress value="{done}" max="{total}"></progress> {e(state)}; scheduler {e(str(doc['scheduler']))},
{doc['workers']} workers; <a href="sweep.json">sweep.json</a></p>
<table><tr><th></th>{head}</tr>
{chr(10).join(rows)}
</table></body></html>
"""
    write_atomic(root / "index.html", page)


def _cell(p: dict | None, root: Path) -> str:
    e = html.escape
    if p is None:
        return ""
    status = p.get("status", "pending")
    cls = {"ok": "ok", "pending": "pending"}.get(status, "bad")
    parts = [f'<div class="{cls}"><b>{e(status)}</b> {e(p["name"])}'
             + (f" &middot; {p['seconds']:.1f} s" if "seconds" in p else "") + "</div>"]
    if p.get("error"):
        parts.append(f'<div class="bad">{e(p["error"])}</div>')
    v = p.get("verify") or {}
    if v.get("median_dE") is not None:
        parts.append(f"<div>median dE2000 {v['median_dE']:.2f}, p95 {v['p95_dE']:.2f}</div>")
    imgs = p.get("images") or {}
    for src in imgs.get("sweep", []):
        parts.append(f'<img src="{e(_rel(src, root))}" alt="light sweep">')
    if imgs.get("hue"):
        parts.append(f'<img src="{e(_rel(imgs["hue"], root))}" alt="hue histogram">')
    if imgs.get("preview"):
        parts.append(f'<img src="{e(_rel(imgs["preview"], root))}" alt="LUT preview"><div>LUT preview '
                     "(not verified: no renders)</div>")
    return "".join(parts)


# ----------------------------------------------------------------------------------------------- running
def _security(path: str | None):
    """``--security FILE``: a Dask ``Security`` from the file's ``distributed.comm.tls`` keys over Dask's own
    configuration (None: Dask's configuration alone). Raises UsageError naming what is wrong."""
    import copy

    import dask
    import yaml
    from distributed.security import Security

    from ..errors import UsageError

    if path is None:
        return Security()
    try:
        doc = yaml.safe_load(Path(path).read_text())
        doc["distributed"]["comm"]["tls"].items()
    except (OSError, yaml.YAMLError, KeyError, TypeError, AttributeError) as exc:
        raise UsageError(f"--security {path!r}: not a Dask configuration with distributed.comm.tls "
                         f"({type(exc).__name__}: {exc})") from None
    with dask.config.set(dask.config.update(copy.deepcopy(dask.config.config), doc)):
        return Security()  # its files are read on connecting: a missing one is the connection's error


def _client(args):
    """A Dask client on ``--scheduler`` or on a new private LocalCluster (returned to be closed)."""
    import logging

    from distributed import Client, LocalCluster
    from distributed.security import Security

    from ..errors import UsageError

    if args.scheduler:
        security = _security(args.security)
        if args.scheduler.startswith("tls://") and not security.require_encryption and not security.tls_ca_file:
            raise UsageError(f"--scheduler {args.scheduler!r} uses TLS: give --security FILE with the cluster's "
                             "CA, certificate and key (or set distributed.comm.tls in Dask's configuration)")
        try:
            return Client(args.scheduler, timeout="10s", security=security), None
        except Exception as exc:  # noqa: BLE001 - OSError, TimeoutError, or the TLS handshake's own errors
            raise UsageError(f"--scheduler {args.scheduler!r}: cannot connect to a Dask scheduler there "
                             f"({type(exc).__name__}: {exc})") from None
    if args.security:
        raise UsageError("--security applies to --scheduler only (the local cluster makes its own certificate)")
    cluster = LocalCluster(n_workers=args.workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR, security=Security.temporary())
    return Client(cluster), cluster


def run(args: argparse.Namespace) -> int:
    from ..config import config_hash, load_config
    from ..errors import UsageError

    t0 = time.perf_counter()
    axes = parse_grid(args.grid)
    if args.workers is not None and (args.workers < 1 or args.scheduler):
        raise UsageError(f"--workers {args.workers}: " + ("applies to the local cluster only, not with --scheduler"
                                                          if args.scheduler else "must be >= 1"))
    if args.scheduler and not re.match(r"^(tcp|tls|inproc|ucx|ws|wss)://\S+$", args.scheduler):
        raise UsageError(f"--scheduler {args.scheduler!r} is not a Dask address like tcp://HOST:PORT")
    load_config(preset=args.preset, config_file=args.config, overrides=args.overrides)  # the base: exit 2
    from ..graph.publish import claim_output

    root = claim_output(args.out, "sweep", create=False)  # checked now, made once the cluster is up
    cache = Path(args.cache).resolve() if args.cache else root / ".rockdove-cache"
    points = grid_points(axes)
    base = {"preset": args.preset, "config_file": str(Path(args.config).resolve()) if args.config else None,
            "overrides": list(args.overrides), "cache": str(cache)}

    records = []
    for p in points:
        rec = {"name": p.name, "index": list(p.index), "overrides": list(p.overrides), "values": p.values,
               "asset": str(Path(POINTS) / p.name), "status": "pending"}
        try:
            rec["config_hash"] = config_hash(load_config(preset=args.preset, config_file=args.config,
                                                         overrides=[*args.overrides, *p.overrides]))
        except ValueError as exc:  # this point alone is invalid: it fails, the others run
            rec.update(status="invalid", error=str(exc), seconds=0.0)
        records.append(rec)

    client, cluster = _client(args)  # an unreachable scheduler is bad usage: nothing written yet
    claim_output(root, "sweep")
    (root / POINTS).mkdir(parents=True, exist_ok=True)
    doc = {"tool": "rockdove", "state": "running", "grid": {k: [lit for lit, _ in vals] for k, vals in axes},
           "base": {"preset": args.preset, "config": args.config, "set": list(args.overrides)},
           "verify": not args.no_verify, "cache": str(cache), "scheduler": args.scheduler or "local",
           "workers": 0, "total": len(points), "done": 0, "seconds": 0.0, "points": records}
    keys, labels = [k for k, _ in axes], [[lit for lit, _ in vals] for _, vals in axes]

    def save():
        doc["done"] = sum(1 for r in records if r["status"] != "pending")
        doc["seconds"] = round(time.perf_counter() - t0, 3)
        write_atomic(root / "sweep.json", json.dumps(doc, indent=1, default=str) + "\n")
        write_index(root, doc, keys, labels)

    todo = [(p, r) for p, r in zip(points, records) if r["status"] == "pending"]
    for r in records:
        if r["status"] != "pending":
            print(f"rockdove sweep: {r['name']}: invalid: {r['error']}", file=sys.stderr)
    try:
        from distributed import as_completed

        save()

        doc["scheduler"] = client.scheduler.address
        doc["workers"] = len(client.scheduler_info(n_workers=-1)["workers"]) if args.scheduler else len(cluster.workers)
        save()
        print(f"rockdove sweep: {len(todo)} points on {doc['workers']} Dask workers ({doc['scheduler']}); "
              f"progress in {root / 'index.html'}", file=sys.stderr)
        futures = {}
        for p, r in todo:
            f = client.submit(build_point, p.name, base, list(p.overrides), str(root / POINTS / p.name), not args.no_verify, pure=False,
                              key=f"rockdove-point-{p.name}-{os.urandom(4).hex()}")
            futures[f] = r
        for f in as_completed(list(futures)):
            r = futures[f]
            try:
                r.update(f.result())
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker after too many worker deaths
                r.update(status="error", error=f"{type(exc).__name__}: {exc}")
            r["asset"] = str(Path(POINTS) / r["name"])
            save()
            print(f"rockdove sweep: [{doc['done']}/{doc['total']}] {r['name']}: {r['status']}"
                  + (f" in {r['seconds']:.1f} s" if "seconds" in r else "")
                  + (f": {r['error']}" if r.get("error") else ""), file=sys.stderr)
        doc["state"] = "finished"
    finally:
        if doc["state"] == "running":  # interrupted (Ctrl-C) or the scheduler went away: say so, no refresh
            doc["state"] = "interrupted"
        save()
        client.close()
        if cluster is not None:
            cluster.close()
    failed = [r["name"] for r in records if r["status"] != "ok"]
    if args.json:
        print(json.dumps(doc, indent=1, default=str))
    print(f"rockdove sweep: {len(records) - len(failed)} of {len(records)} points ok in {doc['seconds']:.1f} s"
          + (f"; failed: {', '.join(failed)}" if failed else "") + f"; see {root / 'index.html'}", file=sys.stderr)
    return 1 if failed else 0

"""``rockdove sweep``: build (and verify) every point of a parameter grid on a Dask cluster (docs/python.md).

Each point of the ``--grid`` product is one :func:`rockdove.api.build` on a Dask worker into
``DIR/points/<KEY=VALUE__...>``, all sharing one stage cache (:meth:`rockdove.cache.Cache.entry_lock`), so each
point is byte-identical to a serial build. The private ``LocalCluster`` speaks TLS (``Security.temporary()``).
Exit status 2 for bad usage before anything runs, 1 when any point failed (after all the others finished), else 0."""

from __future__ import annotations

import argparse
import copy
import html
import itertools
import json
import logging
import os
import re
import sys
import threading
import time
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Literal

from .. import api
from ..config import config_hash, load_config
from ..errors import UsageError
from ..resources import write_atomic
from ..verify.records import plain
from ..verify.results import Report
from .build import add_config_arguments
from .sweep_grid import Point, grid_points, parse_grid

POINTS = "points"
REFRESH_S = 2
#: A point's outcome: not run yet, built (and verified), verification failed, bad configuration, or an error.
Status = Literal["pending", "ok", "failed", "invalid", "error"]


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


# ----------------------------------------------------------------------------------------------- a point
def _restore_malloc_thresholds() -> None:
    """Undo what Dask's nanny's ``MALLOC_TRIM_THRESHOLD_=65536`` does to numpy code: setting any malloc threshold
    freezes glibc's mmap threshold at 128 KiB, so every larger numpy temporary is a fresh mmap faulting its pages
    in again (measured: the body stage 6.0 s of CPU in a Dask worker against 1.35 s; with these, 1.56 s)."""
    import contextlib
    import ctypes

    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, 32 << 20)  # M_MMAP_THRESHOLD (glibc's malloc.h), bytes
        libc.mallopt(-1, 64 << 20)  # M_TRIM_THRESHOLD


_ONE_POINT_AT_A_TIME = threading.Lock()  # a worker with several threads builds one point at a time (GL, memory)


@dataclass(frozen=True)
class Base:
    """What every point of a sweep shares: preset, --config file (absolute), --set overrides, stage cache."""

    preset: str
    config_file: str | None
    overrides: tuple[str, ...]
    cache: str


def _json(record, keep: tuple[str, ...] = ()) -> dict:
    """A record's fields in order as JSON data, but those that are None and not in ``keep``."""
    return {f.name: plain(v) for f in fields(record) if (v := getattr(record, f.name)) is not None or f.name in keep}


@dataclass(frozen=True)
class Verified:
    """Verdict and notes, and from report.json (None: unreadable) failures, worst dE2000s, sweep pixels by hue."""

    passed: bool
    notes: tuple[str, ...]
    failures: tuple[str, ...] | None = None
    median_dE: float | None = None
    p95_dE: float | None = None
    hue: dict[str, int] | None = None

    def to_json(self) -> dict:
        return _json(self, ("median_dE", "p95_dE") if self.failures is not None else ())

    @classmethod
    def of(cls, result) -> Verified | None:
        """Of a build's result (None: not verified) and its report."""
        if result.verified is None:
            return None
        passed, notes = bool(result.verified), tuple(result.notes)
        try:
            report = Report.from_json(json.loads((Path(result.report_dir) / "report.json").read_text()))
        except (OSError, ValueError, TypeError, KeyError):
            return cls(passed, notes)
        h, views = report.hue_sweep, report.views
        return cls(passed, notes, tuple(report.failures),
                   max((m.de_median for m in views if m.de_median is not None), default=None),
                   max((m.de_p95 for m in views if m.de_p95 is not None), default=None),
                   {"green": h.green, "purple": h.purple, "grey": h.grey, "other": h.other})


@dataclass(frozen=True)
class Images:
    """A point's pictures: its report's light-sweep renders and hue histogram, else the LUT preview if written."""

    sweep: tuple[str, ...] | None = None  # None: no report folder
    hue: str | None = None
    preview: str | None = None

    def to_json(self) -> dict:
        return _json(self, ("hue",) if self.sweep is not None else ())

    @classmethod
    def of(cls, out: Path, report: Path | None) -> Images:
        """Of the report folder ``report``, or of the asset ``out`` when it has none."""
        if report is not None and report.is_dir():
            return cls(tuple(str(p) for p in sorted(report.glob("sweep_*_gl.png"))),
                       str(report / "hue.png") if (report / "hue.png").is_file() else None)
        preview = out / "textures" / "feather_preview.png"
        return cls(preview=str(preview) if preview.is_file() else None)


@dataclass(frozen=True)
class PointRecord(Point):
    """A point's entry in sweep.json, its keys in order; ``images`` None: not built. ``build`` is only written."""

    asset: str
    status: Status = "pending"
    config_hash: str | None = None
    pid: int | None = None
    worker: str | None = None
    error: str | None = None
    seconds: float | None = None
    verify: Verified | None = None
    build: dict | None = None
    images: Images | None = None

    def to_json(self) -> dict:
        return _json(self, ("verify",) if self.images is not None else ())


def build_point(record: PointRecord, base: Base, out: str, verify: bool) -> PointRecord:
    """Build the point of ``record`` on a Dask worker (``base``: preset, config file, overrides and cache of every
    point) into ``out``; its record. Any error is recorded, not raised: the point fails alone."""
    _restore_malloc_thresholds()
    from distributed import get_worker

    t0 = time.perf_counter()
    result, error = None, None
    status: Status = "ok"
    with _ONE_POINT_AT_A_TIME:
        try:
            config = api.load_config(preset=base.preset, config_file=base.config_file,
                                     overrides=[*base.overrides, *record.overrides])
            result = api.build(config, out, cache=base.cache, verify=verify)
        except api.VerificationFailed as exc:  # a BuildFailed carries what ran
            result, status, error = getattr(exc, "result", None), "failed", str(exc)
        except (UsageError, OSError) as exc:
            status, error = "invalid" if isinstance(exc, UsageError) else "error", str(exc)
        except Exception as exc:  # noqa: BLE001 - the point fails alone, with its message
            status, error = "error", f"{type(exc).__name__}: {exc}"
    record = replace(record, status=status, pid=os.getpid(), worker=get_worker().address, error=error,
                     seconds=round(time.perf_counter() - t0, 3))
    return record if result is None else replace(
        record, config_hash=result.config_hash, verify=Verified.of(result),
        images=Images.of(Path(out), result.report_dir),
        build={"ran": result.ran, "reused": result.reused, "seconds": round(result.seconds, 4)})


# ----------------------------------------------------------------------------------------------- the page
def write_index(root: Path, points: list[PointRecord], axes_keys: list[str], axes_values: list[list[str]], *,
                state: str, done: int, seconds: float, scheduler: str, workers: int) -> None:
    """``DIR/index.html``: a row per value of the keys but the last, a column per value of the last; a progress
    bar (and a refresh) while the sweep runs (``state`` running, else finished or interrupted), ``done`` points."""
    e, running = html.escape, state == "running"
    by_index = {r.index: r for r in points}
    rows = [f"<tr><th></th>{''.join(f'<th>{e(axes_keys[-1])} = {e(v)}</th>' for v in axes_values[-1])}</tr>"]
    for ridx in itertools.product(*[range(len(v)) for v in axes_values[:-1]]):
        label = "<br>".join(f"{e(k)} = {e(axes_values[i][j])}" for i, (k, j) in enumerate(zip(axes_keys, ridx)))
        rows.append(f"<tr><th>{label or '&nbsp;'}</th>" + "".join(
            f"<td>{_cell(by_index.get(ridx + (c,)), root)}</td>" for c in range(len(axes_values[-1]))) + "</tr>")
    total, failed = len(points), sum(r.status not in ("pending", "ok") for r in points)
    line = (f"running: {done} of {total} points done" if running else
            f"interrupted: {done} of {total} points done" if state == "interrupted" else
            f"finished: {total - failed} of {total} points ok" + (f", {failed} failed" if failed else "")
            + f" in {seconds:.1f} s")
    write_atomic(root / "index.html", f"""<!doctype html>
<html><head><meta charset="utf-8">{f'<meta http-equiv="refresh" content="{REFRESH_S}">' if running else ""}
<title>rockdove sweep</title><style>body{{font-family:sans-serif;margin:1em}} table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:4px;vertical-align:top;font-size:12px}} img{{display:block;max-width:220px}}
.ok{{color:#070}} .bad{{color:#a00}} .pending{{color:#888}} progress{{width:30em}}</style></head>
<body><h1>rockdove sweep</h1>
<p><progress value="{done}" max="{total}"></progress> {e(line)}; scheduler {e(str(scheduler))},
{workers} workers; <a href="sweep.json">sweep.json</a></p>
<table>{chr(10).join(rows)}</table></body></html>
""")


def _cell(r: PointRecord | None, root: Path) -> str:
    if r is None:
        return ""
    e, status, v, imgs = html.escape, r.status, r.verify, r.images or Images()
    parts = [f'<div class="{status if status in ("ok", "pending") else "bad"}"><b>{e(status)}</b> {e(r.name)}'
             + (f" &middot; {r.seconds:.1f} s" if r.seconds is not None else "") + "</div>"]
    if r.error:
        parts.append(f'<div class="bad">{e(r.error)}</div>')
    if v and v.median_dE is not None:
        parts.append(f"<div>median dE2000 {v.median_dE:.2f}, p95 {v.p95_dE:.2f}</div>")
    for src, alt in [(s, "light sweep") for s in imgs.sweep or ()] + [(imgs.hue, "hue histogram"),
                                                                     (imgs.preview, "LUT preview")]:
        if src:
            parts.append(f'<img src="{e(os.path.relpath(src, root))}" alt="{alt}">')
    if imgs.preview:
        parts.append("<div>LUT preview (not verified: no renders)</div>")
    return "".join(parts)


# ----------------------------------------------------------------------------------------------- running
def _security(path: str | None):
    """A Dask ``Security`` from ``--security FILE``'s ``distributed.comm.tls`` over Dask's own configuration."""
    import dask
    import yaml
    from distributed.security import Security

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
    from distributed import Client, LocalCluster
    from distributed.security import Security

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
    base = Base(args.preset, str(Path(args.config).resolve()) if args.config else None, tuple(args.overrides),
                str(cache))

    records = []
    for p in grid_points(axes):
        rec = PointRecord(p.name, p.index, p.overrides, p.values, str(Path(POINTS) / p.name))
        try:
            records.append(replace(rec, config_hash=config_hash(load_config(
                preset=args.preset, config_file=args.config, overrides=[*args.overrides, *p.overrides]))))
        except ValueError as exc:  # this point alone is invalid: it fails, the others run
            records.append(replace(rec, status="invalid", error=str(exc), seconds=0.0))
            print(f"rockdove sweep: {p.name}: invalid: {exc}", file=sys.stderr)

    client, cluster = _client(args)  # an unreachable scheduler is bad usage: nothing written yet
    claim_output(root, "sweep")
    (root / POINTS).mkdir(parents=True, exist_ok=True)
    keys, labels = [k for k, _ in axes], [[lit for lit, _ in vals] for _, vals in axes]
    scheduler, workers, seconds, done = args.scheduler or "local", 0, 0.0, 0

    def save(state: str = "running") -> dict:
        nonlocal seconds, done
        seconds, done = round(time.perf_counter() - t0, 3), sum(r.status != "pending" for r in records)
        doc = {"tool": "rockdove", "state": state, "grid": dict(zip(keys, labels)),
               "base": {"preset": args.preset, "config": args.config, "set": list(args.overrides)},
               "verify": not args.no_verify, "cache": str(cache), "scheduler": scheduler, "workers": workers,
               "total": len(records), "done": done, "seconds": seconds, "points": [r.to_json() for r in records]}
        write_atomic(root / "sweep.json", json.dumps(doc, indent=1, default=str) + "\n")
        write_index(root, records, keys, labels, state=state, done=done, seconds=seconds, scheduler=scheduler,
                    workers=workers)
        return doc

    state = "interrupted"  # by Ctrl-C or the scheduler going away, unless the loop ends: say so, no refresh
    try:
        from distributed import as_completed

        scheduler = client.scheduler.address
        workers = len(client.scheduler_info(n_workers=-1)["workers"]) if args.scheduler else len(cluster.workers)
        save()
        todo = [i for i, r in enumerate(records) if r.status == "pending"]
        print(f"rockdove sweep: {len(todo)} points on {workers} Dask workers ({scheduler}); "
              f"progress in {root / 'index.html'}", file=sys.stderr)
        futures = {client.submit(build_point, records[i], base, str(root / POINTS / records[i].name),
                                 not args.no_verify, pure=False,
                                 key=f"rockdove-point-{records[i].name}-{os.urandom(4).hex()}"): i for i in todo}
        for f in as_completed(list(futures)):
            i = futures[f]
            try:
                records[i] = r = f.result()
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker after too many worker deaths
                records[i] = r = replace(records[i], status="error", error=f"{type(exc).__name__}: {exc}")
            save()
            print(f"rockdove sweep: [{done}/{len(records)}] {r.name}: {r.status}"
                  + (f" in {r.seconds:.1f} s" if r.seconds is not None else "")
                  + (f": {r.error}" if r.error else ""), file=sys.stderr)
        state = "finished"
    finally:
        doc = save(state)
        client.close()
        if cluster is not None:
            cluster.close()
    failed = [r.name for r in records if r.status != "ok"]
    if args.json:
        print(json.dumps(doc, indent=1, default=str))
    print(f"rockdove sweep: {len(records) - len(failed)} of {len(records)} points ok in {seconds:.1f} s"
          + (f"; failed: {', '.join(failed)}" if failed else "") + f"; see {root / 'index.html'}", file=sys.stderr)
    return 1 if failed else 0

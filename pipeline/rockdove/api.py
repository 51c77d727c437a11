"""rockdove's library API: configuration, build and verification as values, in any Python process (docs/python.md).

``rockdove build``, ``rockdove verify``, ``rockdove sweep``'s Dask workers, the benchmarks and the tests all call
these functions; the command line only turns options into their arguments and results into text. Errors:
:class:`rockdove.errors.UsageError` (a ``ValueError``) for bad configuration, output or asset, naming what was
wrong, before anything is written; :class:`BuildFailed` when the build's verification fails."""

from __future__ import annotations

import logging
import os
import shutil
import signal
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .config import DEFAULT_PRESET, config_hash, validate
from .config import load_config as _load_config
from .errors import ResourceMissing, UsageError, VerificationFailed, raise_interrupt
from .graph.engine import Cache, Graph, StageRecord
from .verify.results import HostResult, Report

__all__ = ["DEFAULT_OUT", "BuildFailed", "BuildResult", "HostResult", "StageRecord", "UsageError", "Verification",
           "VerificationFailed", "build", "load_config", "verify"]

DEFAULT_OUT = "build/pigeon"


def load_config(preset: str | None = DEFAULT_PRESET, config_file: str | os.PathLike | None = None,
                overrides: Mapping[str, Any] | Iterable[str] = ()) -> dict:
    """The effective, validated build configuration (a plain dict, as ``rockdove config --json`` prints it):
    ``preset`` (None: the schema's defaults), a TOML ``config_file`` over it, then ``overrides`` (``{dotted key:
    value}`` or ``KEY=VALUE`` strings as ``--set`` takes them). :class:`UsageError` naming key, value and range.

    >>> config = load_config(preset="paper", overrides={"lut.angles": 128})
    >>> config["lut"]["angles"], config["film"]["model"]
    (128, 'paper')
    >>> load_config(overrides=["lut.angles=1"])
    Traceback (most recent call last):
    rockdove.errors.UsageError: config key 'lut.angles': value 1 is out of range; allowed: integer >= 2 and <= 4096 texels
    """
    return _load_config(preset=preset, config_file=config_file, overrides=overrides)


# ----------------------------------------------------------------------------------------------- results
@dataclass(frozen=True)
class BuildResult:
    """A finished build. ``verified``: True (passed), None (built with ``verify=False``), False (in
    :class:`BuildFailed`). ``report_dir``: the published ``verify/``, or the failed verification's folder."""

    out: Path
    cache: Path
    config_hash: str
    stages: tuple[StageRecord, ...]
    verified: bool | None
    report_dir: Path | None
    notes: tuple[str, ...]
    seconds: float
    failure: str | None = None

    @property
    def ran(self) -> list[str]:
        return [s.name for s in self.stages if s.status == "ran"]

    @property
    def reused(self) -> list[str]:
        return [s.name for s in self.stages if s.status == "reused"]

    @property
    def keys(self) -> dict[str, str]:
        return {s.name: s.key for s in self.stages}

    def as_dict(self) -> dict:
        """The ``rockdove build --json`` summary."""
        return {"out": str(self.out), "cache": str(self.cache), "config_hash": self.config_hash,
                "ran": self.ran, "reused": self.reused, "stages": [s.as_dict() for s in self.stages],
                "verified": self.verified, "report": None if self.report_dir is None else str(self.report_dir),
                "notes": list(self.notes), "seconds": round(self.seconds, 4)}


class BuildFailed(VerificationFailed):
    """The build's verification failed and nothing was published; ``result``: its :class:`BuildResult` (the report's
    folder included)."""

    def __init__(self, message: str, result: BuildResult):
        super().__init__(message)
        self.result = result


@dataclass(frozen=True)
class Verification:
    """A finished verification: ``passed`` (validation clean, every view and every host that ran within its
    goals), ``failures``, ``notes`` (what was checked differently), each host's :class:`HostResult`, and the
    whole typed ``report`` (``report.json``'s content)."""

    passed: bool
    failures: tuple[str, ...]
    notes: tuple[str, ...]
    hosts: tuple[HostResult, ...]
    report_dir: Path
    report: Report = field(repr=False)


# ----------------------------------------------------------------------------------------------- build
def build(config: dict, out: str | os.PathLike = DEFAULT_OUT, *, cache: str | os.PathLike | None = None,
          verify: bool = True, lock_timeout: float | None = None,
          progress: Callable[[str], None] | None = None) -> BuildResult:
    """Build, verify and publish the asset of ``config`` (:func:`load_config`, validated again here) into ``out`` (new,
    empty, or one rockdove built: anything else is refused before any work), incrementally. ``cache``: the stage cache
    (default ``.rockdove-cache`` beside ``out``), shared with :func:`verify`. ``verify``: run the verification on the
    staged asset; a failure publishes nothing and raises :class:`BuildFailed`. ``lock_timeout``: seconds to wait for
    another build of the same output (default: until it finishes), then UsageError (the wait is logged on the
    ``rockdove`` logger); ``progress(stage_name)`` as each starts. The asset is assembled and verified in a staging
    folder beside ``out``, then swapped into place; Ctrl-C (and SIGTERM, when called from the main thread) removes the
    staging folder."""
    from .graph import stages as build_stages
    from .graph.publish import OutputLock, check_output, make_staging, publish, recover, write_marker

    t0 = time.perf_counter()
    config = validate(config)
    if not str(out).strip():
        raise UsageError("--out is empty; give the asset folder, e.g. --out build/pigeon")
    out = Path(out)
    check_output(out)
    cache_dir = Path(cache) if cache is not None else out.parent / ".rockdove-cache"
    if cache_dir.exists() and not cache_dir.is_dir():
        raise UsageError(f"--cache {str(cache_dir)!r} exists and is not a folder")
    stages = build_stages.make_stages(config, verify=verify)
    chash = config_hash(config)
    main_thread = threading.current_thread() is threading.main_thread()
    old_term = signal.signal(signal.SIGTERM, raise_interrupt) if main_thread else None
    staging = None

    def result(verified: bool | None, report_dir: Path | None, notes=(), failure=None) -> BuildResult:
        return BuildResult(out, cache_dir, chash, tuple(graph.records.values()), verified, report_dir, tuple(notes),
                           time.perf_counter() - t0, failure)

    try:
        with OutputLock(out, timeout_s=lock_timeout):
            recover(out)
            store = Cache(cache_dir)
            store.clean_temporaries()
            graph = Graph(stages, config, store, progress=progress)
            graph.run()
            staging = make_staging(out)
            graph.assemble(staging)
            write_marker(staging, {"config_hash": chash, "stages": {n: r.key for n, r in graph.records.items()}})
            graph.run(asset_dir=staging, needs_asset=True)
            graph.assemble(staging, needs_asset=True)
            verdict = build_stages.verdict(graph)
            if verdict is not None and not verdict.passed:
                report_dir = graph.entry_dir(build_stages.VERIFY)
                message = f"verification failed ({verdict.reason or 'see its report'}); {out} was left unchanged; " \
                          f"report in {report_dir}"
                raise BuildFailed(message, result(False, report_dir, verdict.notes, verdict.reason))
            publish(staging, out)
            staging = None
    finally:
        if staging is not None and staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
        if main_thread:
            signal.signal(signal.SIGTERM, old_term)
    return result(None, None) if verdict is None else result(True, out / "verify", verdict.notes)


# ----------------------------------------------------------------------------------------------- verify
def verify(asset: str | os.PathLike, hosts: Iterable[str] | None = None, *, cache: str | os.PathLike | None = None,
           out: str | os.PathLike | None = None, width: int | None = None, height: int | None = None,
           views: Iterable[str] | None = None, n_views: int | None = None, bench_dir: str | os.PathLike | None = None,
           allow_external: bool = False, beauty: dict | None = None, motion: str | None = None,
           times: Iterable[float] | None = None) -> Verification:
    """Validate an asset (its folder or root layer) and check it in the GLSL shaders and every host in ``hosts``:
    the build's own verification with its cache (:func:`rockdove.verify.verification.verify`, whose arguments these
    are; its progress goes to the ``rockdove`` logger). ``out``: the report folder; ``allow_external``: let the
    asset's layers name files outside its folder; ``motion``, ``times``: also check that motion (its measures, and
    the film at those time codes). Returns :class:`Verification` (a failed check: ``passed`` False). Raises
    :class:`UsageError` for bad usage and :class:`VerificationFailed`, before rendering, when the asset's layers do
    not parse or name files outside it."""
    from .graph.publish import staged_output
    from .usd.dependencies import require_inside
    from .verify import verification
    from .verify.verdict import default_out_dir
    from .web.gltf import GLB_NAME
    from .web.viewer import write_viewer

    root = require_inside(asset, allow_external)  # nothing from elsewhere is read, nothing of the user's overwritten
    # the report is written whole or not at all: in a staging folder, swapped in at the end
    with staged_output(out or default_out_dir(root), "verification report", "report.json") as (staging, final):
        glb = Path(root).parent / GLB_NAME  # viewer.html beside the report when the asset has its glb, as a build's
        try:
            if glb.is_file():
                write_viewer(root, glb, staging)
        except ResourceMissing as exc:  # e.g. no three.js (a wheel install without npm): the report, without it
            logging.getLogger(__name__).info(f"no interactive viewer in the report: {exc}")
        report = verification.verify(os.fspath(root), None if hosts is None else list(hosts), cache=cache,
                                     out_dir=staging, width=width, height=height, n_views=n_views,
                                     views=None if views is None else list(views), bench_dir=bench_dir,
                                     beauty=beauty, motion=motion, times=None if times is None else list(times))
        for name in ("report.json", "report.html"):  # they name the folder they will be in
            f = staging / name
            f.write_text(f.read_text().replace(staging.name, final.name))
    report = replace(report, out_dir=str(final))
    return Verification(report.passed, report.failures, report.notes, report.hosts, Path(report.out_dir), report)

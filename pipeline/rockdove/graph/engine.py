"""The incremental build graph over a cache (:mod:`rockdove.cache`).

A :class:`Stage` is a named pure function of its part of the configuration and its upstream outputs, keyed by
the configuration keys it declares, the code it can execute (:func:`rockdove.sources.digest`) and the *content
digests* of its upstream outputs (early cut-off: a new seed that leaves the thickness range unchanged does not
re-bake the LUT). A stage whose key has an entry is reused, its value loaded only if a stage that runs needs it;
builds sharing a cache compute an entry once (``Cache.entry_lock``)."""

from __future__ import annotations

import dataclasses
import hashlib
import shutil
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .. import sources
from ..cache import CODEC_FILES, FILES, JSON, KEY_VERSION, NPZ, Cache, Codec, folder_digest, load_entry  # noqa: F401
from ..config import Config, canonical_json, subset


@dataclass
class Context:
    """What a stage function receives: its declared ``config`` (``ctx.config.lut.angles``), its ``inputs`` by stage
    name (loaded on first access), an empty ``workdir`` that becomes its cache entry (FILES stages write their files
    there), the assembled ``asset_dir`` for ``needs_asset`` stages."""

    config: Config
    inputs: Any  # the declared inputs by name, ctx.inputs["bird"] or ctx.inputs.bird
    workdir: Path
    asset_dir: Path | None = None
    cache: Cache | None = None  # the build's cache, for a stage that keeps items of its own (verification)


@dataclass(frozen=True)
class Stage:
    """One node of the build graph: ``run(ctx)`` is the pure function; ``config`` the dotted keys it reads; ``deps``
    the upstream stages (earlier in the list); ``data`` the data files or folders whose bytes enter its key;
    ``publish`` (FILES stages) the asset's sub-folder its files go to (``""``: the root)."""

    name: str
    run: Callable[[Context], Any]
    config: tuple[str, ...] = ()
    deps: tuple[str, ...] = ()
    data: tuple[str, ...] = ()
    codec: Codec = JSON
    publish: str | None = None
    needs_asset: bool = False


def source_digest(stage: Stage, inputs: Iterable[Stage] = (), record: bool = False):
    """The digest of the code a stage can execute (its callables, its codecs', the loaders of its ``inputs``),
    of its data, the environment and Python (:func:`rockdove.sources.digest`); with ``record``, what it hashed."""
    fns = [stage.run, stage.codec.save, stage.codec.load, *(s.codec.load for s in inputs)]
    found = sources.digest(fns, stage.data, ("rockdove.graph.engine",))
    return found if record else found[0]


def stage_key(stage: Stage, config: dict, input_digests: Mapping[str, str], source: str) -> str:
    """The content key (sha256 hex) of ``stage``: exactly its config keys, code, inputs."""
    payload = {"graph": KEY_VERSION, "stage": stage.name, "source": source,
               "config": subset(config, stage.config), "inputs": {d: input_digests[d] for d in stage.deps}}
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()


@dataclass
class StageRecord:
    """One stage in a build: ``status`` "ran" or "reused"."""

    name: str
    key: str
    status: str
    seconds: float
    digest: str

    def as_dict(self) -> dict:
        return {**dataclasses.asdict(self), "seconds": round(self.seconds, 4)}


class _LazyInputs(Mapping):
    def __init__(self, graph: Graph, names: Iterable[str]):
        self._graph, self._names = graph, tuple(names)

    def __getitem__(self, name):
        if name not in self._names:
            raise KeyError(f"stage input {name!r} was not declared; declared: {self._names}")
        return self._graph.value(name)

    def __getattr__(self, name: str) -> Any:  # ctx.inputs.bird
        if name.startswith("_"):
            raise AttributeError(name)
        try:
            return self[name]
        except KeyError as exc:
            raise AttributeError(exc.args[0]) from None

    def __iter__(self):
        return iter(self._names)

    def __len__(self):
        return len(self._names)


class Graph:
    """A list of stages (dependencies first) run against a configuration and a :class:`Cache`; ``progress`` is
    called with each stage name as it starts (the CLI drives a progress bar with it)."""

    def __init__(self, stages: list[Stage], config: dict, cache: Cache, progress: Callable[[str], None] | None = None):
        seen: set[str] = set()
        for s in stages:
            if s.name in seen:
                raise ValueError(f"stage name {s.name!r} appears twice")
            missing = [d for d in s.deps if d not in seen]
            if missing:
                raise ValueError(f"stage {s.name!r} depends on {missing}, which are not earlier stages")
            seen.add(s.name)
        self.stages = {s.name: s for s in stages}
        self.config, self.cache, self.progress = config, cache, progress or (lambda name: None)
        self.records: dict[str, StageRecord] = {}
        self._values: dict[str, Any] = {}

    def value(self, name: str) -> Any:
        """A finished stage's value (loaded read-only on first use)."""
        if name not in self._values:
            self._values[name] = load_entry(self.stages[name].codec, self.entry_dir(name))
        return self._values[name]

    def entry_dir(self, name: str) -> Path:
            return self.cache.entry(name, self.records[name].key) / "value"

    def run(self, *, asset_dir: Path | None = None, needs_asset: bool = False) -> list[StageRecord]:
        """Run (or reuse) the stages with ``needs_asset == needs_asset``, in order."""
        done = []
        for stage in self.stages.values():
            if stage.needs_asset == needs_asset and stage.name not in self.records:
                self.progress(stage.name)
                done.append(self._run_stage(stage, asset_dir))
        return done

    def _run_stage(self, stage: Stage, asset_dir) -> StageRecord:
        digests = {d: self.records[d].digest for d in stage.deps}
        source = source_digest(stage, [self.stages[d] for d in stage.deps])
        key = stage_key(stage, self.config, digests, source)
        t0 = time.perf_counter()

        def fill(folder: Path):
            ctx = Context(config=Config(subset(self.config, stage.config)), inputs=_LazyInputs(self, stage.deps),
                          workdir=folder, asset_dir=asset_dir, cache=self.cache)
            stage.codec.save(stage.run(ctx), folder)
            if stage.codec is not FILES:
                self._values[stage.name] = stage.codec.load(folder)

        meta, status = self.cache.lookup(stage.name, key), "reused"
        if meta is None:  # another process sharing the cache may be computing it: wait for it, do not redo it
            with self.cache.entry_lock(stage.name, key):
                meta = self.cache.lookup(stage.name, key)
                if meta is None:
                    meta, status = self.cache.store(stage.name, key, fill), "ran"
        self.records[stage.name] = StageRecord(stage.name, key, status, time.perf_counter() - t0, meta["digest"])
        return self.records[stage.name]

    def assemble(self, asset_dir: Path, *, needs_asset: bool = False) -> None:
        """Copy the files of the publishing stages (those with ``needs_asset == needs_asset``) into
        ``asset_dir``; copies, so the cache stays read-only whatever is done to the asset."""
        for name, stage in self.stages.items():
            if stage.publish is None or name not in self.records or stage.needs_asset != needs_asset:
                continue
            src = self.entry_dir(name)
            for p in sources.files_of(src):
                if p.parent == src and p.name in CODEC_FILES:
                    continue  # the cache's own record of the stage's value, not part of the asset
                target = asset_dir / stage.publish / p.relative_to(src)
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(p, target)

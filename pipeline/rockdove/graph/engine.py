"""The incremental build graph: stages keyed by a content hash of exactly what they read, over a cache
(:mod:`rockdove.graph.cache`).

A :class:`Stage` is a named pure function of its part of the configuration and its upstream outputs, keyed by
the configuration keys it declares, the code it can execute (:func:`rockdove.sources.digest`) and the *content
digests* of its upstream outputs (early cut-off: a new seed that leaves the thickness range unchanged does not
re-bake the LUT). A stage whose key has an entry is reused, its value loaded only if a stage that runs needs it;
builds sharing a cache compute an entry once (``Cache.entry_lock``). Fan-out stages key each named item by its
own configuration (``Stage.items``) or by what ``Stage.item_plan(ctx)`` says it reads, and redo only the items
whose key changed.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

from .. import sources
from ..config import canonical_json, get
from .cache import CODEC_FILES, FILES, JSON, NPZ, Cache, Codec, folder_digest, load_entry, load_npz  # noqa: F401

GRAPH_VERSION = 2  # bump when the key recipe or the entry layout changes


@dataclass
class Context:
    """What a stage function receives: its declared ``config`` (nested as in the full configuration), its
    ``inputs`` by stage name (loaded on first access), an empty ``workdir`` that becomes its cache entry (FILES
    stages write their files there), the assembled ``asset_dir`` for ``needs_asset`` stages, the ``item``
    ``(name, item_config)`` of a fan-out stage, or for a ``batch`` stage every item to redo, ``items`` (name ->
    item config: it writes item ``name``'s files into ``workdir / name`` and returns ``{name: value}``)."""

    config: dict
    inputs: Mapping[str, Any]
    workdir: Path
    asset_dir: Path | None = None
    item: tuple | None = None
    items: dict | None = None
    cache: "Cache | None" = None  # the build's cache, for a stage that keeps items of its own (verification)


@dataclass(frozen=True)
class Stage:
    """One node of the build graph: ``run(ctx)`` is the pure function (once per item for a fan-out stage);
    ``config`` the dotted keys it reads; ``deps`` the upstream stages (earlier in the list); ``data`` the data
    files or folders whose bytes enter its key; ``codec`` how its value is stored; ``publish`` (FILES stages) the
    sub-folder of the asset its files are copied to (``""``: the root); ``needs_asset`` runs it on the assembled
    asset. Fan-out: ``items(config)`` gives item name -> the item's own configuration (in its key), or
    ``item_plan(ctx)`` at run time item name -> everything the item reads (its whole key, so it must be
    complete); ``combine(ctx, values)`` joins the item values; ``batch`` runs the items to redo in one call
    (``ctx.items``); ``item_codec`` stores an item's value."""

    name: str
    run: Callable[[Context], Any]
    config: tuple[str, ...] = ()
    deps: tuple[str, ...] = ()
    data: tuple[str, ...] = ()
    codec: Codec = JSON
    publish: str | None = None
    needs_asset: bool = False
    items: Callable[[dict], dict] | None = None
    combine: Callable[[Context, dict], Any] | None = None
    item_codec: Codec = JSON
    item_plan: Callable[[Context], dict] | None = None
    batch: bool = False


def _nested(config: dict, keys: Iterable[str]) -> dict:
    out: dict = {}
    for key in keys:
        parts = key.split(".")
        node = out
        for p in parts[:-1]:
            node = node.setdefault(p, {})
        node[parts[-1]] = get(config, key)
    return out


def source_digest(stage: Stage, inputs: Iterable[Stage] = (), record: bool = False):
    """The digest of the code a stage can execute (its callables, its codecs', the loaders of its ``inputs``),
    of its data, the environment and Python (:func:`rockdove.sources.digest`); with ``record``, what it hashed."""
    fns = [stage.run, stage.item_plan, stage.items, stage.combine, stage.codec.save, stage.codec.load,
           stage.item_codec.save, stage.item_codec.load, *(s.codec.load for s in inputs)]
    found = sources.digest([f for f in fns if f is not None], stage.data, ("rockdove.graph.engine",))
    return found if record else found[0]


def stage_key(stage: Stage, config: dict | None, input_digests: Mapping[str, str], source: str) -> str:
    """The content key (sha256 hex) of ``stage``: exactly its config keys, code, inputs. ``config=None`` leaves
    the configuration out: the base of a fan-out item's key, to which the item's own configuration is added."""
    payload = {"graph": GRAPH_VERSION, "stage": stage.name, "source": source,
               "config": None if config is None else _nested(config, stage.config),
               "inputs": {d: input_digests[d] for d in stage.deps}}
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()


@dataclass
class StageRecord:
    """One stage in a build: ``status`` "ran" or "reused"."""

    name: str
    key: str
    status: str
    seconds: float
    digest: str
    items_ran: list[str] = field(default_factory=list)
    items_reused: list[str] = field(default_factory=list)

    def as_dict(self) -> dict:
        d = {"name": self.name, "key": self.key, "status": self.status, "seconds": round(self.seconds, 4),
             "digest": self.digest}
        if self.items_ran or self.items_reused:
            d["items_ran"], d["items_reused"] = self.items_ran, self.items_reused
        return d


class _LazyInputs(Mapping):
    def __init__(self, graph: "Graph", names: Iterable[str]):
        self._graph, self._names = graph, tuple(names)

    def __getitem__(self, name):
        if name not in self._names:
            raise KeyError(f"stage input {name!r} was not declared; declared: {self._names}")
        return self._graph.value(name)

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

    def _context(self, stage: Stage, workdir: Path, asset_dir, item=None) -> Context:
        return Context(config=_nested(self.config, stage.config), inputs=_LazyInputs(self, stage.deps),
                       workdir=workdir, asset_dir=asset_dir, item=item, cache=self.cache)

    def _run_stage(self, stage: Stage, asset_dir) -> StageRecord:
        digests = {d: self.records[d].digest for d in stage.deps}
        source = source_digest(stage, [self.stages[d] for d in stage.deps])
        key = stage_key(stage, self.config, digests, source)
        t0 = time.perf_counter()
        meta = self.cache.lookup(stage.name, key)
        if meta is None:  # another process sharing the cache may be computing it: wait for it, do not redo it
            with self.cache.entry_lock(stage.name, key):
                meta = self.cache.lookup(stage.name, key)
                if meta is None:
                    return self._compute_stage(stage, key, digests, source, asset_dir, t0)
        rec = StageRecord(stage.name, key, "reused", time.perf_counter() - t0, meta["digest"],
                          items_reused=meta.get("items", []))
        self.records[stage.name] = rec
        return rec

    def _compute_stage(self, stage: Stage, key: str, digests: dict, source: str, asset_dir, t0: float) -> StageRecord:
        """Run ``stage`` (its entry is missing and this process holds its lock) and store its entry."""
        ran, reused = [], []
        extra = {"items": []}  # filled in by a fan-out stage's fill, before store() writes the metadata
        fan_out = stage.items is not None or stage.item_plan is not None

        def fill(folder: Path):
            ctx = self._context(stage, folder, asset_dir)
            if not fan_out:
                stage.codec.save(stage.run(ctx), folder)
                if stage.codec is not FILES:
                    self._values[stage.name] = stage.codec.load(folder)
                return
            if stage.item_plan is not None:  # the plan holds what each item reads: no upstream digests
                planned = stage.item_plan(ctx)
                base = hashlib.sha256(canonical_json({"graph": GRAPH_VERSION, "stage": stage.name,
                                                      "source": source, "planned": True}).encode()).hexdigest()
            else:
                planned = stage.items(_nested(self.config, stage.config))
                base = stage_key(stage, None, digests, source)
            iname = f"{stage.name}.items"
            keys = {n: hashlib.sha256(canonical_json([base, n, c]).encode()).hexdigest() for n, c in planned.items()}
            todo = {n: c for n, c in planned.items() if self.cache.lookup(iname, keys[n]) is None}
            if stage.batch and todo:
                self._run_batch(stage, iname, keys, todo, asset_dir)
            else:
                for item_name, item_cfg in todo.items():
                    def ifill(ifolder: Path, item=(item_name, item_cfg)):
                        stage.item_codec.save(stage.run(self._context(stage, ifolder, asset_dir, item)), ifolder)
                    self.cache.store(iname, keys[item_name], ifill, {"item": item_name})
            ran.extend(n for n in planned if n in todo)
            reused.extend(n for n in planned if n not in todo)
            extra["items"] = list(planned)
            item_values = {n: stage.item_codec.load(self.cache.entry(iname, keys[n]) / "value") for n in planned}
            stage.codec.save(stage.combine(ctx, item_values), folder)

        meta = self.cache.store(stage.name, key, fill, extra if fan_out else None)
        rec = StageRecord(stage.name, key, "ran", time.perf_counter() - t0, meta["digest"], ran, reused)
        self.records[stage.name] = rec
        return rec

    def _run_batch(self, stage: Stage, iname: str, keys: dict, todo: dict, asset_dir) -> None:
        """Run the ``todo`` items of a batch stage in one call, then store each as its own cache entry."""
        with self.cache.temporary(self.cache.root / iname) as scratch:
            for n in todo:
                (scratch / n).mkdir()
            ctx = self._context(stage, scratch, asset_dir)
            ctx.items = dict(todo)
            values = stage.run(ctx)
            missing = [n for n in todo if n not in values]
            if missing:
                raise ValueError(f"stage {stage.name!r}: its batch run returned no value for items {missing}")
            for n in todo:
                def ifill(ifolder: Path, n=n):
                    for p in (scratch / n).iterdir():
                        os.rename(p, ifolder / p.name)
                    stage.item_codec.save(values[n], ifolder)
                self.cache.store(iname, keys[n], ifill, {"item": n})

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

"""The incremental build graph: stages keyed by a content hash of exactly what they read, and their cache.

A :class:`Stage` is a named pure function of its part of the configuration and its upstream outputs. Its
key is the sha256 of

- the configuration keys it declares (``Stage.config``, dotted, e.g. ``"lut"`` or ``"geometry.seed"``),
- the source of the code it can execute, derived from the source (:mod:`rockdove.graph.code`: what its
  functions, its codecs and its inputs' loaders reach, and the import closure of those modules inside the
  package), and any data files it declares (``Stage.data``), so editing the code invalidates it,
- the versions of the libraries it declares (``Stage.libraries``) and of Python,
- the *content digests* of its upstream outputs (not their keys): a stage whose inputs changed but produced
  the same bytes does not rerun its dependants (early cut-off; e.g. a new seed that leaves the thickness
  range unchanged does not re-bake the LUT).

A stage whose key has an entry in the :class:`Cache` is reused without running, and its value is loaded only
if a stage that runs needs it. Entries are written into a temporary folder and renamed into place (atomic; a
concurrent build that wrote the same entry first wins), their files are made read-only and loaded read-only.
Builds in several processes sharing one cache (``rockdove sweep``'s workers) compute an entry once: the first
to miss it takes an exclusive lock on that entry (``Cache.entry_lock``) and the others wait, then reuse it.

Fan-out stages (``Stage.items``) split their work into named items (e.g. one per verification view), each with
its own key = stage key + the item's own configuration, so only the items whose inputs changed are redone.
When what an item reads is only known once its inputs exist (e.g. a verification view reads the *rendered
content* of the asset, not every byte of it), ``Stage.item_plan(ctx)`` names the items at run time and returns,
per item, everything it reads; the item key is then that plan entry plus the stage's code and libraries, without
the upstream digests, so an upstream change that leaves an item's plan entry unchanged does not redo it.
``Stage.batch`` runs all the items to redo in one call (sharing set-up such as a GL context).
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import importlib.metadata
import json
import os
import shutil
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping


from .. import resources
from ..digest import Digest
from ..config import canonical_json, get
from . import code
from .code import files_of

GRAPH_VERSION = 1  # bump when the key recipe or the entry layout changes


# ----------------------------------------------------------------------------------------------- codecs
@dataclass(frozen=True)
class Codec:
    """How a stage's value is stored in its cache folder: ``save(value, folder)``, ``load(folder) -> value``.

    ``shared``: the loaded value is immutable (frozen dataclasses, tuples, read-only mappings and arrays), so a
    process loads each cache entry once and hands every later build the same value (:func:`load_entry`).
    """

    name: str
    save: Callable[[Any, Path], None]
    load: Callable[[Path], Any]
    shared: bool = False


#: Values of ``shared`` codecs loaded in this process, most recent last: (codec, folder, inode, mtime) -> value.
_LOADED: dict = {}
_LOADED_MAX = 8
_LOADED_LOCK = threading.Lock()


def load_entry(codec: Codec, folder: Path) -> Any:
    """``codec.load(folder)``, once per process for a ``shared`` codec: an entry's files never change once
    written (its folder is named by the content key of everything that made it, filled in a temporary folder,
    renamed into place and made read-only), so a long-lived process (a sweep worker, `rockdove build --watch`) rebuilding
    after a film change does not re-read the unchanged geometry. Keyed by the folder and its inode and mtime,
    so an entry deleted and written again is read again."""
    if not codec.shared:
        return codec.load(folder)
    st = folder.stat()
    key = (codec.name, str(folder), st.st_ino, st.st_mtime_ns)
    with _LOADED_LOCK:  # builds may run in threads of one process (a Dask worker's)
        value = _LOADED.pop(key) if key in _LOADED else codec.load(folder)
        _LOADED[key] = value  # most recent last
        while len(_LOADED) > _LOADED_MAX:
            del _LOADED[next(iter(_LOADED))]
    return value


def _json_save(value, folder: Path) -> None:
    (folder / "value.json").write_text(canonical_json(value))


def _json_load(folder: Path):
    return json.loads((folder / "value.json").read_text())


def _npz_save(value: Mapping[str, np.ndarray], folder: Path) -> None:
    import numpy as np

    np.savez(folder / "value.npz", **{k: np.ascontiguousarray(v) for k, v in value.items()})


def load_npz(path: Path) -> dict:
    """Every array of an ``.npz`` file (no pickles), read-only."""
    import numpy as np

    with np.load(path, allow_pickle=False) as z:
        out = {k: z[k] for k in z.files}
    for a in out.values():
        a.setflags(write=False)
    return out


def _npz_load(folder: Path) -> dict:
    return load_npz(folder / "value.npz")


#: Files a codec writes at the top of a stage's cache folder; never published into the asset.
CODEC_FILES = frozenset({"value.json", "value.npz"})

JSON = Codec("json", _json_save, _json_load)
NPZ = Codec("npz", _npz_save, _npz_load)
# The stage writes files into ctx.workdir itself; its value is that (read-only) folder.
FILES = Codec("files", lambda value, folder: None, lambda folder: folder)


# ----------------------------------------------------------------------------------------------- stages
@dataclass
class Context:
    """What a stage function receives.

    Attributes
    ----------
    config : dict
        The stage's declared configuration, nested as in the full configuration (only those keys).
    inputs : Mapping[str, Any]
        Upstream values by stage name, loaded from the cache on first access.
    workdir : Path
        An empty folder that becomes the stage's cache entry: FILES stages write their files here.
    asset_dir : Path or None
        The assembled (not yet published) asset folder, for stages with ``needs_asset``.
    item : tuple(str, Any) or None
        ``(name, item_config)`` for an item of a fan-out stage.
    items : dict[str, Any] or None
        For a ``batch`` fan-out stage: every item to redo, name -> item config; the function writes item
        ``name``'s files into ``workdir / name`` and returns ``{name: value}``.
    """

    config: dict
    inputs: Mapping[str, Any]
    workdir: Path
    asset_dir: Path | None = None
    item: tuple | None = None
    items: dict | None = None
    cache: "Cache | None" = None  # the build's cache, for a stage that keeps items of its own (verification)


@dataclass(frozen=True)
class Stage:
    """One node of the build graph.

    Parameters
    ----------
    name : str
        Unique name, e.g. ``"lut"``.
    run : callable(Context) -> value
        The pure function. For a fan-out stage it runs once per item (``ctx.item`` set).
    config : tuple of str
        Dotted configuration keys it reads.
    deps : tuple of str
        Names of upstream stages (earlier in the list).
    data : tuple of str
        Data files or folders (relative to the repository root) whose bytes enter the key.
    libraries : tuple of str
        Distribution names whose versions enter the key (e.g. ``"numpy"``).
    codec : Codec
        Storage of the value (:data:`JSON`, :data:`NPZ`, :data:`FILES` or a custom one).
    publish : str or None
        For FILES stages: sub-folder of the asset their files are copied to (``""`` = the asset root).
    needs_asset : bool
        Runs after the asset is assembled (verification), with ``ctx.asset_dir``.
    items : callable(config) -> dict[str, Any] or None
        Fan-out: item name -> the item's own configuration (enters the item's key).
    combine : callable(Context, dict[str, Any]) -> value or None
        Fan-out: joins the item values (``ctx`` as for the stage) into the stage value.
    item_plan : callable(Context) -> dict[str, Any] or None
        Fan-out decided at run time (instead of ``items``): item name -> everything that item reads (enters
        its key *instead of* the upstream digests and the configuration, so it must be complete).
    batch : bool
        Fan-out: run the items to redo in one call (``ctx.items``) rather than one call per item.
    item_codec : Codec
        Storage of an item's value (its files, written into its folder, are kept with it).
    """

    name: str
    run: Callable[[Context], Any]
    config: tuple[str, ...] = ()
    deps: tuple[str, ...] = ()
    data: tuple[str, ...] = ()
    libraries: tuple[str, ...] = ("numpy",)
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


#: source_digest per stage (its callables, the callables of its inputs' codecs, its data, the package and data
#: folders they resolve to) -> (paths, their (mtime, size) when read, digest): valid while none of the files it
#: hashed and none of the folders it listed changed (an edited, added or removed file changes its folder's mtime).
_SOURCE_MEMO: dict = {}


def _state(paths) -> tuple | None:
    try:
        return tuple((st.st_mtime_ns, st.st_size) for st in map(os.stat, paths))
    except OSError:
        return None


def source_digest(stage: Stage, inputs: Iterable[Stage] = ()) -> str:
    """sha256 of the code a stage can execute (:func:`rockdove.graph.code.code_files`: derived from the source of
    its callables and of its ``inputs``' loaders) and of its data files.

    Computed once per process and per state of those files and of the folders listed for them (a warm no-op
    build checks every stage's code with a stat of each file)."""
    inputs = tuple(inputs)
    tops = tuple(resources.path(d) for d in stage.data)
    root = resources.package_root().resolve()
    memo_key = (str(root), tuple(code.callables(stage, inputs)), stage.data, tuple(map(str, tops)))
    hit = _SOURCE_MEMO.get(memo_key)
    if hit is not None and _state(hit[0]) == hit[1]:
        return hit[2]
    seen: dict = {}
    h = Digest()  # source and data files are read once per process (rockdove.graph.code.read)
    for p in code.code_files(stage, inputs, seen):
        h.add(str(p.relative_to(root.parent)) if p.is_relative_to(root.parent) else p.name, code.read(p, seen))
    for d, top in zip(stage.data, tops):
        data_files = files_of(top, seen=seen)
        if not data_files:  # an empty data folder would key the stage on nothing
            raise ValueError(f"stage {stage.name!r} reads data {d!r}, but {top} holds no files; "
                             "the stage cannot be keyed (reinstall rockdove)")
        for p in data_files:
            h.add(f"{d}/{p.relative_to(top)}" if top.is_dir() else d, code.read(p, seen))
    digest = h.hexdigest()
    _SOURCE_MEMO[memo_key] = (tuple(seen), tuple(seen.values()), digest)
    return digest


@functools.lru_cache(maxsize=None)
def _version(name: str) -> str:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "absent"


def library_versions(names: Iterable[str]) -> dict[str, str]:
    """``{"python": x.y.z, name: version or "absent"}`` for installed distributions ``names``."""
    return {"python": "%d.%d.%d" % sys.version_info[:3], **{n: _version(n) for n in names}}


def stage_key(stage: Stage, config: dict | None, input_digests: Mapping[str, str], source: str) -> str:
    """The content key (sha256 hex) of ``stage``: exactly its config keys, code, library versions, inputs.

    ``config=None`` leaves the configuration out: the base of a fan-out item's key, to which the item's own
    configuration is added, so an item is redone only when its own inputs change.
    """
    payload = {
        "graph": GRAPH_VERSION,
        "stage": stage.name,
        "config": None if config is None else _nested(config, stage.config),
        "source": source,
        "libraries": library_versions(stage.libraries),
        "inputs": {d: input_digests[d] for d in stage.deps},
    }
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()


def folder_digest(folder: Path) -> str:
    """sha256 over the relative paths and bytes of every file under ``folder`` (streamed: a long-lived process
    does not keep the assets it built in memory)."""
    h = Digest()
    for p in files_of(folder):
        h.file(str(p.relative_to(folder)), p)
    return h.hexdigest()


# ----------------------------------------------------------------------------------------------- cache
# this process's temporary folders and held entry locks, never opened by its own clean: on NFS, flock is a POSIX
# lock, which does not conflict within a process and is dropped when any of its descriptors closes
_LIVE: set[Path] = set()
_ORPHAN_S = 3600  # a temporary folder with no .owner yet (its writer died in the instant before naming it)


def _owner() -> str:
    """Who writes a temporary folder, for people: host, boot id, PID namespace and pid (a pid alone names no
    process on another machine or in another container)."""
    boot = ns = None
    with contextlib.suppress(OSError):
        boot, ns = Path("/proc/sys/kernel/random/boot_id").read_text().strip(), os.readlink("/proc/self/ns/pid")
    return json.dumps({"host": os.uname().nodename, "boot_id": boot, "pid_ns": ns, "pid": os.getpid()})


def _take(path: Path) -> int | None:
    """A descriptor of ``path`` with an exclusive flock taken without waiting, or None when someone holds it
    (or it cannot be opened)."""
    try:
        fd = os.open(path, os.O_RDWR)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return fd
    except OSError:
        os.close(fd)
        return None


class Cache:
    """Stage values on disk: ``ROOT/<stage>/<key>/{meta.json, value/...}``, written atomically, read-only.

    The folder may be shared by builds on several machines (a sweep's workers over NFS) or in several PID
    namespaces: writers say who they are by holding locks (``fcntl.flock``, which NFSv4 serves across hosts and
    releases when a client's lease lapses), never by a pid a reader would look up in its own process table."""

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)

    def entry(self, stage: str, key: str) -> Path:
        return self.root / stage / key

    def lookup(self, stage: str, key: str) -> dict | None:
        """The entry's metadata (``digest``, ``seconds``...) or None when absent or incomplete."""
        meta = self.entry(stage, key) / "meta.json"
        try:
            return json.loads(meta.read_text())
        except (OSError, ValueError):
            return None

    @contextlib.contextmanager
    def temporary(self, parent: Path):
        """A folder ``parent/.tmp-<host>-<pid>-XXXX`` of this writer's, removed at the end unless renamed away.
        Its ``.owner`` file (:func:`_owner`) is locked before it gets that name and stays locked while the
        writer lives: a cleaner anywhere that can take the lock knows the writer is gone."""
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".tmp-{os.uname().nodename}-{os.getpid()}-", dir=parent))
        _LIVE.add(tmp)
        fd = os.open(tmp / ".owner.new", os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            os.write(fd, _owner().encode())
            os.rename(tmp / ".owner.new", tmp / ".owner")
            yield tmp
        finally:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)
            _LIVE.discard(tmp)
            os.close(fd)

    def store(self, stage: str, key: str, fill: Callable[[Path], Any], extra: dict | None = None) -> dict:
        """Create entry ``(stage, key)`` by ``fill(folder)`` in a temporary folder renamed into place."""
        with self.temporary(self.root / stage) as tmp:
            value_dir = tmp / "value"
            value_dir.mkdir()
            t0 = time.perf_counter()
            fill(value_dir)
            meta = {"stage": stage, "key": key, "digest": folder_digest(value_dir),
                    "seconds": time.perf_counter() - t0, **(extra or {})}
            (tmp / "meta.json").write_text(json.dumps(meta, indent=1, sort_keys=True))
            for p in files_of(tmp):
                p.chmod(0o444)
            try:
                os.rename(tmp, self.entry(stage, key))
            except OSError:  # another build stored the same entry first: same key, same content
                if self.lookup(stage, key) is None:
                    raise
            else:
                os.unlink(self.entry(stage, key) / ".owner")
            return meta

    @contextlib.contextmanager
    def entry_lock(self, stage: str, key: str):
        """Hold the exclusive right to compute entry ``(stage, key)`` among the processes (and threads) sharing
        this cache: ``fcntl.flock`` on ``ROOT/<stage>/.lock-<key>``, waited for without a timeout (a holder that
        dies releases it). The holder removes the file on leaving; a waiter that got the lock of a file removed
        meanwhile (by the holder or by :meth:`clean_temporaries`) tries again on the file now at that path."""
        parent = self.root / stage
        parent.mkdir(parents=True, exist_ok=True)
        path = parent / f".lock-{key}"
        while True:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
            fcntl.flock(fd, fcntl.LOCK_EX)
            with contextlib.suppress(OSError):
                if os.path.samestat(os.fstat(fd), os.stat(path)):
                    break
            os.close(fd)
        _LIVE.add(path)
        try:
            yield
        finally:
            with contextlib.suppress(OSError):
                os.unlink(path)
            _LIVE.discard(path)
            os.close(fd)  # releases the lock

    def clean_temporaries(self) -> None:
        """Remove what killed builds left: temporary folders whose ``.owner`` lock nobody holds (a folder with
        no ``.owner`` once it is an hour old) and ``.lock-*`` files nobody holds. Never a live writer's, on
        whatever machine or PID namespace it runs."""
        for tmp in self.root.glob("*/.tmp-*"):
            if tmp in _LIVE or not tmp.is_dir():
                continue
            fd = _take(tmp / ".owner")
            if fd is None:
                with contextlib.suppress(OSError):
                    if (tmp / ".owner").exists() or time.time() - tmp.stat().st_mtime < _ORPHAN_S:
                        continue
            shutil.rmtree(tmp, ignore_errors=True)
            if fd is not None:
                os.close(fd)
        for lock in self.root.glob("*/.lock-*"):
            fd = None if lock in _LIVE else _take(lock)
            if fd is not None:
                with contextlib.suppress(OSError):
                    if os.path.samestat(os.fstat(fd), os.stat(lock)):
                        os.unlink(lock)
                os.close(fd)


# ----------------------------------------------------------------------------------------------- running
@dataclass
class StageRecord:
    """What happened to one stage in a build."""

    name: str
    key: str
    status: str  # "ran" | "reused"
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
    """A list of stages (dependencies first) run against a configuration and a cache.

    Parameters
    ----------
    stages : list of Stage
    config : dict
        The effective configuration.
    cache : Cache
    progress : callable(str) or None
        Called with each stage name as it starts (the CLI drives a progress bar with it).
    """

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
        """The value of a finished stage (loaded read-only from the cache on first use)."""
        if name not in self._values:
            rec = self.records[name]
            stage = self.stages[name]
            self._values[name] = load_entry(stage.codec, self.cache.entry(name, rec.key) / "value")
        return self._values[name]

    def entry_dir(self, name: str) -> Path:
        """The cache folder holding a finished stage's value files."""
        return self.cache.entry(name, self.records[name].key) / "value"

    def run(self, *, asset_dir: Path | None = None, needs_asset: bool = False) -> list[StageRecord]:
        """Run (or reuse) the stages with ``needs_asset == needs_asset``, in order."""
        done = []
        for stage in self.stages.values():
            if stage.needs_asset != needs_asset or stage.name in self.records:
                continue
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
        if not fan_out:
            def fill(folder: Path):
                value = stage.run(self._context(stage, folder, asset_dir))
                stage.codec.save(value, folder)
                if stage.codec is not FILES:
                    self._values[stage.name] = stage.codec.load(folder)
        else:
            def fill(folder: Path):
                ctx = self._context(stage, folder, asset_dir)
                if stage.item_plan is not None:  # the plan holds what each item reads: no upstream digests
                    planned = stage.item_plan(ctx)
                    base = hashlib.sha256(canonical_json({
                        "graph": GRAPH_VERSION, "stage": stage.name, "source": source, "planned": True,
                        "libraries": library_versions(stage.libraries)}).encode()).hexdigest()
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
                            v = stage.run(self._context(stage, ifolder, asset_dir, item))
                            stage.item_codec.save(v, ifolder)
                        self.cache.store(iname, keys[item_name], ifill, {"item": item_name})
                ran.extend(n for n in planned if n in todo)
                reused.extend(n for n in planned if n not in todo)
                extra["items"] = list(planned)
                item_values = {n: stage.item_codec.load(self.cache.entry(iname, keys[n]) / "value") for n in planned}
                value = stage.combine(ctx, item_values)
                stage.codec.save(value, folder)
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
            dst = asset_dir / stage.publish
            for p in files_of(src):
                if p.parent == src and p.name in CODEC_FILES:
                    continue  # the cache's own record of the stage's value, not part of the asset
                target = dst / p.relative_to(src)
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(p, target)

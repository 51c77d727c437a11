"""The stage cache on disk, ``ROOT/<stage>/<key>/{meta.json, value/...}``, and the codecs that store a value there.

An entry is filled in a temporary folder and renamed into place (atomic; of two builds that wrote the same entry
the first wins); its files are made read-only and loaded read-only. The folder may be shared by builds on
several machines (a sweep's workers over NFS) or in several PID namespaces: writers say who they are by holding
locks (``fcntl.flock``, which NFSv4 serves across hosts and releases when a client's lease lapses), never by a
pid a reader would look up in its own process table."""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .config import canonical_json
from .digest import Digest
from .resources import load_npz
from .sources import files_of

KEY_VERSION = 2  # bump when a key recipe (the graph's stages, the verification's items) or the entry layout changes


# ----------------------------------------------------------------------------------------------- codecs
@dataclass(frozen=True)
class Codec:
    """How a stage's value is stored in its cache folder. ``shared``: the loaded value is immutable, so a process
    loads each entry once and hands every later build the same value (:func:`load_entry`)."""

    name: str
    save: Callable[[Any, Path], None]
    load: Callable[[Path], Any]
    shared: bool = False


#: Values of ``shared`` codecs loaded in this process, most recent last: (codec, folder, inode, mtime) -> value.
_LOADED: dict = {}
_LOADED_MAX = 8
_LOADED_LOCK = threading.Lock()


def load_entry(codec: Codec, folder: Path) -> Any:
    """``codec.load(folder)``, once per process for a ``shared`` codec: a warm rebuild does not re-read the geometry."""
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


def _npz_save(value, folder: Path) -> None:
    import numpy as np

    arrays: dict[str, Any] = {k: np.ascontiguousarray(v) for k, v in value.items()}
    np.savez(folder / "value.npz", **arrays)


#: Files a codec writes at the top of a stage's cache folder; never published into the asset.
CODEC_FILES = frozenset({"value.json", "value.npz"})

def _json_save(value, folder: Path) -> None:
    (folder / "value.json").write_text(canonical_json(value))


JSON = Codec("json", _json_save, lambda folder: json.loads((folder / "value.json").read_text()))
NPZ = Codec("npz", _npz_save, lambda folder: load_npz(folder / "value.npz"))
# The stage writes files into ctx.workdir itself; its value is that (read-only) folder.
FILES = Codec("files", lambda value, folder: None, lambda folder: folder)


def folder_digest(folder: Path) -> str:
    """sha256 over the relative paths and bytes of the files under ``folder``, streamed (not held in memory)."""
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
    """Who writes a temporary folder, for people: host, boot id, PID namespace and pid."""
    boot = ns = None
    with contextlib.suppress(OSError):
        boot, ns = Path("/proc/sys/kernel/random/boot_id").read_text().strip(), os.readlink("/proc/self/ns/pid")
    return json.dumps({"host": os.uname().nodename, "boot_id": boot, "pid_ns": ns, "pid": os.getpid()})


def _take(path: Path) -> int | None:
    """A descriptor of ``path`` holding its exclusive flock, or None when another holds it (or no such file)."""
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
    """Stage values on disk (module docstring)."""
    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)

    def entry(self, stage: str, key: str) -> Path:
        return self.root / stage / key

    def lookup(self, stage: str, key: str) -> dict | None:
        """The entry's metadata (``digest``, ``seconds``...) or None when absent or incomplete."""
        try:
            return json.loads((self.entry(stage, key) / "meta.json").read_text())
        except (OSError, ValueError):
            return None

    @contextlib.contextmanager
    def temporary(self, parent: Path):
        """A folder ``parent/.tmp-<host>-<pid>-XXXX``, removed at the end unless renamed away; its ``.owner`` is
        locked before it gets that name, while the writer lives: a cleaner that can take it knows it is gone."""
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".tmp-{os.uname().nodename}-{os.getpid()}-", dir=parent))
        _LIVE.add(tmp)
        fd = None
        try:
            fd = os.open(tmp / ".owner.new", os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
            fcntl.flock(fd, fcntl.LOCK_EX)
            os.write(fd, _owner().encode())
            os.rename(tmp / ".owner.new", tmp / ".owner")
            yield tmp
        finally:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)
            _LIVE.discard(tmp)
            if fd is not None:
                os.close(fd)

    def store(self, stage: str, key: str, fill: Callable[[Path], Any], extra: dict | None = None) -> dict:
        """Create entry ``(stage, key)`` by ``fill(folder)`` in a temporary folder renamed into place."""
        with self.temporary(self.root / stage) as tmp:
            (tmp / "value").mkdir()
            t0 = time.perf_counter()
            fill(tmp / "value")
            meta = {"stage": stage, "key": key, "digest": folder_digest(tmp / "value"),
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
        """The exclusive right to compute entry ``(stage, key)``: ``fcntl.flock`` on ``ROOT/<stage>/.lock-<key>``,
        waited for (a holder that dies releases it). The holder removes the file on leaving; a waiter that got the
        lock of a file removed meanwhile tries again on the file now at that path."""
        (self.root / stage).mkdir(parents=True, exist_ok=True)
        path = self.root / stage / f".lock-{key}"
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
        """Remove what killed builds left: temporary folders and ``.lock-*`` files whose lock nobody holds (a folder
        without ``.owner`` once an hour old); never a live writer's, wherever it runs."""
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

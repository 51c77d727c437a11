"""The data files rockdove reads at run time, found through :mod:`importlib.resources`.

``materials/``, ``schemas/`` and ``assets/`` live at the top of the repository; ``pyproject.toml`` maps each
into the package as a data sub-package (``rockdove.materials``...), so a wheel carries them and an editable
install reads them from the checkout. Names are relative paths whose first part is the folder, e.g.
``resources.path("materials/glsl/thinfilm.frag")``."""

from __future__ import annotations

import contextlib
import functools
import importlib.resources
import os
import tempfile
from pathlib import Path

from .errors import ResourceMissing, UsageError

#: The data folders and the sub-package each ships as.
FOLDERS = {"materials": "rockdove.materials", "schemas": "rockdove.schemas", "assets": "rockdove.assets"}


@functools.cache
def folder(name: str) -> Path:
    """The directory of data folder ``name`` (one of :data:`FOLDERS`) on disk; :class:`ResourceMissing` when the
    package was installed without it."""
    if name not in FOLDERS:
        raise UsageError(f"data folder must be one of {', '.join(FOLDERS)}, got {name!r}")
    try:
        root = importlib.resources.files(FOLDERS[name])
    except ModuleNotFoundError as exc:
        raise ResourceMissing(f"rockdove data folder {name!r} is missing from the installed package "
                              f"(no module {FOLDERS[name]}); reinstall rockdove") from exc
    path = Path(str(root))
    if not path.is_dir():
        raise ResourceMissing(f"rockdove data folder {name!r} is not a folder on disk ({path}); "
                              "install rockdove from a wheel or a checkout, not a zip")
    return path


def path(name: str) -> Path:
    """The file or folder ``name`` (``"<folder>/<relative path>"``) on disk; :class:`ResourceMissing` naming it
    when it is not in the installed package."""
    top, _, rest = name.partition("/")
    p = folder(top) / rest if rest else folder(top)
    if not p.exists():
        raise ResourceMissing(f"rockdove data file {name!r} is missing from the installed package ({p})")
    return p


def package_root() -> Path:
    """The directory of the ``rockdove`` package's own sources (for hashing code into stage keys)."""
    return Path(str(importlib.resources.files("rockdove")))


def user_cache_dir(*parts: str) -> Path:
    """``$XDG_CACHE_HOME/rockdove/<parts...>`` (``~/.cache`` when unset): values rockdove derives and keeps,
    keyed by what derives them (:func:`rockdove.sources.cache_dir`); all of it can be deleted at any time."""
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(root, "rockdove", *parts)


def spare_full_disk(min_free: int = 64 << 20) -> None:
    """Turn Mesa's shader cache off (``MESA_SHADER_CACHE_DISABLE``, unless set) where the user cache's file system
    has less than ``min_free`` bytes free: Mesa maps its cache index there, and a write into a full disk is then a
    SIGBUS. As for rockdove's own cache, a cache that cannot be kept only costs time."""
    if "MESA_SHADER_CACHE_DISABLE" in os.environ or "MESA_SHADER_CACHE_DIR" in os.environ:
        return
    probe = user_cache_dir()
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    with contextlib.suppress(OSError):
        st = os.statvfs(probe)
        if st.f_bavail * st.f_frsize < min_free:
            os.environ["MESA_SHADER_CACHE_DISABLE"] = "true"


@contextlib.contextmanager
def atomic_path(path):
    """The one atomic write: yields a temporary path beside ``path`` (same folder and suffix, so writers that go by
    the extension work) to write; on success it replaces ``path`` in one ``os.replace`` (mode 0644: a reader
    sees the old file or the whole new one, also with concurrent writers), on error it is removed."""
    path = os.fspath(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(path)}.", suffix=f".tmp{os.path.splitext(path)[1]}",
                               dir=os.path.dirname(os.path.abspath(path)))
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


def write_atomic(path, data: bytes | str) -> str:
    """Write ``data`` (text as UTF-8) to ``path`` through :func:`atomic_path`; returns the path."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)
    return os.fspath(path)


def write_cached(path: Path, data: bytes) -> bool:
    """Write ``data`` to ``path`` in :func:`user_cache_dir` atomically (:func:`write_atomic`). Returns False, and
    writes nothing, where the folder is not writable: a cache that cannot be kept is recomputed next time."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, data)
        return True
    except OSError:
        return False


def load_npz(path: str | os.PathLike) -> dict:
    """An ``.npz`` file's arrays (no pickles), read-only."""
    import numpy as np

    with np.load(path, allow_pickle=False) as z:
        out = {k: z[k] for k in z.files}
    for a in out.values():
        a.setflags(write=False)
    return out

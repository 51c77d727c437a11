"""Publishing an asset folder safely: checks, a lock, a staging folder, an atomic swap and a marker.

- **Marker.** Every published asset folder holds ``.rockdove-asset.json`` (tool, version, configuration hash,
  stage keys). The tool refuses to replace an existing, non-empty folder without it: it did not create it.
- **Lock.** ``fcntl.flock`` on ``.<name>.rockdove.lock`` beside the output. A second build of the same output
  *waits* for the first (it says so once on stderr, naming the holder's pid), then runs and finds the first
  build's stages in the cache. ``timeout_s`` bounds the wait (then a :class:`UsageError`, exit 2). The lock
  file is never deleted (deleting it would let two builds hold locks on different files).
- **Staging and swap.** The new asset is assembled in ``.<name>.rockdove-tmp-XXXX`` beside the output (same file
  system), then exchanged with the old folder in one ``renameat2(RENAME_EXCHANGE)`` call where Linux offers it
  (else: old renamed to ``.<name>.rockdove-old-XXXX``, new renamed into place), and only then is the old one
  removed. A build that fails or is killed at any point leaves the previous asset in place, or (killed
  between the two fallback renames) in the ``-old`` folder, which the next build restores before anything
  else (:func:`recover`). Temporary folders of killed builds are removed by the next build under the lock.
"""

from __future__ import annotations

import ctypes
import errno
import fcntl
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

from .. import __version__
from ..errors import UsageError
from ..usd.layout import MARKER

_TMP = ".rockdove-tmp-"
_OLD = ".rockdove-old-"


def lock_path(out: Path) -> Path:
    return out.parent / f".{out.name}.rockdove.lock"


def check_output(out: Path) -> None:
    """Refuse, before anything is written, an output we may not or cannot replace (:class:`UsageError`)."""
    if str(out) in ("", ".", "/") or out.name in ("", ".", ".."):
        raise UsageError(f"--out {str(out)!r} is not a folder name rockdove can publish to; give e.g. build/pigeon")
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {str(out)!r} exists and is not a folder; allowed: a new folder or one rockdove built")
    if out.is_dir() and not (out / MARKER).is_file() and any(out.iterdir()):
        raise UsageError(f"--out {str(out)!r} is a non-empty folder that rockdove did not create (no {MARKER}); "
                         "refusing to replace it: choose another --out or remove it yourself")
    parent = out.parent
    probe = parent
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise UsageError(f"--out {str(out)!r}: {str(probe)!r} is a file, so the folder cannot be created")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise UsageError(f"--out {str(out)!r}: {str(probe)!r} is not writable")


class OutputLock:
    """Exclusive lock of one output folder for the whole build (context manager)."""

    def __init__(self, out: Path, timeout_s: float | None = None, quiet: bool = False):
        self.out, self.path, self.timeout_s, self.quiet = out, lock_path(out), timeout_s, quiet
        self._fd: int | None = None

    def __enter__(self) -> "OutputLock":
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise UsageError(f"--out {str(self.out)!r}: cannot create the lock "
                             f"file {str(self.path)!r}: {exc.strerror}") from None
        t0 = time.monotonic()
        told = False
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if not told:
                    holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "?"
                    print(f"rockdove build: waiting for another build of {self.out} "
                          f"(pid {holder}) to finish", file=sys.stderr, flush=True)
                    told = True
                if self.timeout_s is not None and time.monotonic() - t0 > self.timeout_s:
                    os.close(fd)
                    raise UsageError(f"another rockdove build holds {str(self.path)!r} for more than "
                                     f"{self.timeout_s:g} s; try again later") from None
                time.sleep(0.1)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        self._fd = fd
        return self

    def __exit__(self, *exc) -> None:
        if self._fd is not None:
            os.ftruncate(self._fd, 0)
            fcntl.flock(self._fd, fcntl.LOCK_UN)
            os.close(self._fd)
            self._fd = None


def recover(out: Path) -> None:
    """Undo what a killed build left beside ``out`` (call while holding its lock).

    Restores ``out`` from a ``-old`` folder if ``out`` is missing; removes staging and ``-old`` folders.
    """
    olds = sorted(out.parent.glob(f".{out.name}{_OLD}*"), key=lambda p: p.stat().st_mtime)
    if not out.exists() and olds:
        os.rename(olds[-1], out)
        olds = olds[:-1]
    for p in olds + list(out.parent.glob(f".{out.name}{_TMP}*")):
        shutil.rmtree(p, ignore_errors=True)


def published_path(path) -> Path:
    """Where ``path`` (inside a staging folder ``.<name>.rockdove-tmp-XXXX``) will be once published; other
    paths unchanged. Reports name the asset by this path, not by the temporary folder."""
    path = Path(path)
    for i, part in enumerate(path.parts):
        if part.startswith(".") and _TMP in part:
            return Path(*path.parts[:i], part[1:part.index(_TMP)], *path.parts[i + 1:])
    return path


def make_staging(out: Path) -> Path:
    """A fresh folder beside ``out`` (same file system) to assemble the new asset in."""
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}{_TMP}", dir=out.parent))
    umask = os.umask(0)
    os.umask(umask)
    staging.chmod(0o777 & ~umask)  # mkdtemp makes 0700; the published folder gets the usual mode
    return staging


def write_marker(folder: Path, info: dict) -> None:
    """Write the marker that says rockdove created ``folder`` (``info``: config hash, stage keys...)."""
    data = {"tool": "rockdove", "version": __version__, **info}
    (folder / MARKER).write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")


def read_marker(folder: Path) -> dict | None:
    try:
        return json.loads((Path(folder) / MARKER).read_text())
    except (OSError, ValueError):
        return None


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Atomically swap two paths with Linux ``renameat2(RENAME_EXCHANGE)``; False where unsupported."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def publish(staging: Path, out: Path) -> None:
    """Put the assembled ``staging`` folder in place of ``out`` atomically; remove the old asset after.

    ``staging`` must hold the marker. ``out`` is re-checked (it may have changed since :func:`check_output`).
    """
    if not (staging / MARKER).is_file():
        raise ValueError(f"staging folder {str(staging)!r} has no {MARKER}")
    check_output(out)
    if out.exists():
        if _exchange(staging, out):
            shutil.rmtree(staging)  # now holds the old asset
            return
        old = out.parent / f".{out.name}{_OLD}{os.getpid()}-{os.urandom(4).hex()}"
        os.rename(out, old)
        os.rename(staging, out)
        shutil.rmtree(old)
    else:
        os.rename(staging, out)

"""Publishing an asset folder safely: a marker, a lock, a staging folder and an atomic swap.

An existing non-empty folder without the marker ``.rockdove-asset.json`` is never replaced. A second build of
the same output waits on ``fcntl.flock`` of ``.<name>.rockdove.lock`` (never deleted: two builds could then lock
different files), then finds the first one's stages in the cache. The asset is assembled in
``.<name>.rockdove-tmp-XXXX`` beside the output and swapped in by one ``renameat2(RENAME_EXCHANGE)`` (else by two
renames through ``.<name>.rockdove-old-XXXX``, which :func:`recover` restores after a kill)."""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import json
import logging
import os
import shutil
import tempfile
import time
from pathlib import Path

from .. import __version__
from ..errors import UsageError
from ..usd.layout import MARKER

_log = logging.getLogger(__name__)
_TMP = ".rockdove-tmp-"
_OLD = ".rockdove-old-"


#: The file that says rockdove created an output folder that is not an asset (``render``, ``verify``, ``sweep``).
OUTPUT_MARKER = ".rockdove-output.json"


def real_output(out) -> Path:
    """``out`` with symlinks resolved (an asset is published inside a symlinked ``--out``'s target)."""
    from ..usd.layout import unusable_path

    why = unusable_path(os.path.abspath(os.fspath(out)))
    if why:
        raise UsageError(f"--out {str(out)!r} {why}")
    try:
        return Path(out).resolve()
    except (RuntimeError, OSError) as exc:  # RuntimeError: a symlink loop (Python 3.11)
        raise UsageError(f"--out {str(out)!r} cannot be resolved: {exc}") from None


def _check_writable(out: Path, real: Path, deep: bool = True) -> None:
    """UsageError unless ``real`` (or its nearest existing parent) is writable, and with ``deep`` its parent and
    every folder inside it."""
    probe = real
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise UsageError(f"--out {str(out)!r}: {str(probe)!r} is a file, so the folder cannot be created")
    folders = [probe] + ([probe.parent] + [Path(d) for d, _, _ in os.walk(real)][1:] if deep and probe == real else [])
    for folder in folders:
        if not os.access(folder, os.W_OK | os.X_OK):
            raise UsageError(f"--out {str(out)!r}: {str(folder)!r} is not writable (read-only), so rockdove cannot "
                             "replace what is there; make it writable or choose another --out")


def check_output(out, what: str | None = None) -> Path:
    """``--out`` resolved, or refused (:class:`UsageError`) when it is a file, not writable, or a non-empty folder
    rockdove did not create (no :data:`MARKER`; for a command's ``what``, no :data:`OUTPUT_MARKER` nor in an asset)."""
    if what is None and (str(out) in ("", ".", "/") or Path(out).name in ("", ".", "..")):
        raise UsageError(f"--out {str(out)!r} is not a folder name rockdove can publish to; give e.g. build/pigeon")
    if what is not None and not str(out).strip():
        raise UsageError(f"--out is empty; give the folder {what} writes into")
    real = real_output(out)
    if real.exists() and not real.is_dir():
        raise UsageError(f"--out {str(out)!r} exists and is not a folder; allowed: a new folder or one rockdove built")
    if real.is_dir() and not _ours(real, what) and any(real.iterdir()):
        raise UsageError(f"--out {str(out)!r} is a non-empty folder that rockdove did not create (no "
                         f"{MARKER if what is None else OUTPUT_MARKER}); refusing to "
                         f"{'replace it' if what is None else f'write the {what} into it'}: choose another --out "
                         "or remove it yourself")
    _check_writable(out, real)
    return real


def _ours(real: Path, what: str | None) -> bool:
    if what is None:
        return (real / MARKER).is_file()
    return any((real / m).is_file() for m in (OUTPUT_MARKER, MARKER)) or (real.parent / MARKER).is_file()


def claim_output(out, what: str, create: bool = True) -> Path:
    """:func:`check_output` of a command's folder; ``create`` makes it and writes :data:`OUTPUT_MARKER`."""
    real = check_output(out, what)
    if create:
        real.mkdir(parents=True, exist_ok=True)
        if not _ours(real, what):
            _write_output_marker(real, what)
    return real


def _write_output_marker(folder: Path, what: str) -> None:
    (folder / OUTPUT_MARKER).write_text(json.dumps({"tool": "rockdove", "version": __version__, "output": what}) + "\n")


def check_output_file(out, ours) -> None:
    """UsageError for an ``--out`` file that exists and ``ours(path)`` does not recognise, or in a read-only folder."""
    path = real_output(out)
    if path.is_dir() or (path.exists() and not ours(path)):
        raise UsageError(f"--out {str(out)!r} exists and rockdove did not write it; refusing to overwrite it: "
                         "choose another --out or remove it yourself")
    _check_writable(out, real_output(path.parent), deep=False)


def starts_like(magic: bytes, tag: bytes = b""):
    """``ours`` for :func:`check_output_file`: the file starts with ``magic`` and holds ``tag`` in its first 64 KiB
    (e.g. an EXR whose header names ``rockdove:``)."""
    def ours(path) -> bool:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
        return head.startswith(magic) and tag in head
    return ours


def _remove(path: Path) -> None:
    """Remove a leftover of ours: a link unlinked (never followed), a folder even where a mode inside is read-only."""
    if path.is_symlink():
        path.unlink()
        return

    def fix(fn, p, _exc):
        with contextlib.suppress(OSError):
            os.chmod(os.path.dirname(p), 0o700)
            fn(p)

    shutil.rmtree(path, onerror=fix)


class OutputLock:
    """Exclusive lock of one output folder for the whole build (context manager)."""

    def __init__(self, out: Path, timeout_s: float | None = None):
        if timeout_s is not None and not (isinstance(timeout_s, (int, float)) and 0 <= timeout_s < float("inf")):
            raise UsageError(f"--lock-timeout must be a finite number of seconds >= 0, got {timeout_s!r}")
        real = real_output(out)
        self.out, self.timeout_s = out, timeout_s
        self.path = real.parent / f".{real.name}.rockdove.lock"
        self._fd: int | None = None

    def __enter__(self) -> OutputLock:
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
                    _log.warning("waiting for another build of %s (pid %s) to finish", self.out, holder)
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
    """Undo what a killed build left beside ``out`` (holding its lock): a missing ``out`` restored from a ``-old``
    folder; staging and ``-old`` folders removed."""
    real = real_output(out)
    olds = sorted(real.parent.glob(f".{real.name}{_OLD}*"), key=lambda p: p.stat().st_mtime)
    if not real.exists() and olds:
        os.rename(olds[-1], real)
        olds = olds[:-1]
    beside = {real.parent, Path(os.path.abspath(out)).parent}
    for p in olds + [p for d in beside for name in {real.name, Path(out).name} for p in d.glob(f".{name}{_TMP}*")]:
        _remove(p)


def published_path(path) -> Path:
    """Where ``path`` inside a staging folder will be once published (reports name the asset by it)."""
    path = Path(path)
    for i, part in enumerate(path.parts):
        if part.startswith(".") and _TMP in part:
            return Path(*path.parts[:i], part[1:part.index(_TMP)], *path.parts[i + 1:])
    return path


def make_staging(out: Path) -> Path:
    """A fresh folder beside ``out`` (same file system) to assemble the new asset in."""
    out = real_output(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}{_TMP}", dir=out.parent))
    umask = os.umask(0)
    os.umask(umask)
    staging.chmod(0o777 & ~umask)  # mkdtemp makes 0700; the published folder gets the usual mode
    return staging


def write_marker(folder: Path, info: dict) -> None:
    """Write the marker that says rockdove created ``folder``."""
    (folder / MARKER).write_text(json.dumps({"tool": "rockdove", "version": __version__, **info}, indent=1,
                                            sort_keys=True) + "\n")


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
    """Swap the assembled ``staging`` folder (holding the marker) in place of ``out``, re-checked, atomically."""
    if not (staging / MARKER).is_file():
        raise ValueError(f"staging folder {str(staging)!r} has no {MARKER}")
    check_output(out)
    _swap(staging, real_output(out))


def _swap(staging: Path, out: Path) -> None:
    if not out.exists():
        os.rename(staging, out)
    elif _exchange(staging, out):
        _remove(staging)  # now holds the old folder
    else:
        old = out.parent / f".{out.name}{_OLD}{os.getpid()}-{os.urandom(4).hex()}"
        os.rename(out, old)
        os.rename(staging, out)
        _remove(old)


@contextlib.contextmanager
def staged_output(out, what: str, holds: str):
    """A command's output folder ``out`` written whole or not at all: the block writes into a staging folder,
    swapped in when it ends without an error, removed otherwise. An existing ``out`` is replaced only when it is
    empty or an earlier output of the same kind (its :data:`OUTPUT_MARKER` names ``what``, or it holds ``holds``;
    no asset). Two commands writing one ``out`` take turns (``flock`` of the parent). Yields (staging, out)."""
    real = check_output(out, what)
    with contextlib.suppress(OSError, ValueError):
        holds = holds if json.loads((real / OUTPUT_MARKER).read_text()).get("output") != what else OUTPUT_MARKER
    if real.is_dir() and any(real.iterdir()) and ((real / MARKER).exists() or not (real / holds).is_file()):
        raise UsageError(f"--out {str(out)!r} holds more than a {what} (an asset, or files of other kinds); "
                         f"the new {what} replaces its folder whole: choose another --out")
    real.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(real.parent, os.O_RDONLY)
    staging = None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        recover(real)
        staging = make_staging(real)
        _write_output_marker(staging, what)
        yield staging, real
        check_output(real, what)
        _swap(staging, real)
    finally:
        if staging is not None and staging.exists():
            _remove(staging)
        os.close(fd)  # releases the lock

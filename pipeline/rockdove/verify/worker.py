"""The verification's worker process: the GL renders and the asset's validation run there, beside the work
of the calling process, started ahead of need.

Why a process: a verification's two halves are the GL renders (:func:`rockdove.render.gl.render_views`) and the
exact CPU reference; its last steps are the validation and the report. A thread of the same process overlaps
them only where both leave Python, but pyrender's import (~2 s: trimesh, scipy, networkx, pyglet, PyOpenGL), its
scene set-up, NVIDIA's validator and matplotlib hold the GIL. A process of its own runs them on the other core
(:func:`rockdove.verify.run.render_and_check` sends the renders, :func:`rockdove.verify.verdict.combine` the
validation while it draws the charts), and the build starts it as soon as it knows a verification will render
(:func:`prestart`), so the GL import is done while the LUT, textures and layers are written. It also keeps a
crash in the GL driver out of the build: the verification reports it as a failure instead of dying with it.

The worker is a plain ``python -c`` child (:data:`_BOOT`: the caller's ``sys.path``, then :func:`_serve`)
holding one end of a socket pair. It is started with ``subprocess``, not ``multiprocessing``: Dask's worker
processes are daemonic, and daemonic processes may not start ``multiprocessing`` children. Its stdout goes to
the caller's stderr, so that ``--json`` output stays clean.

A request names a module-level function by ``"module:function"``. Requests and replies go over a
:class:`multiprocessing.connection.Connection` and are run and answered in order. They are pickled with
protocol 5, and numpy arrays travel out of band, as their raw bytes. The default views' GL results are ~120 MB:
0.2-0.3 s from the end of the renders to the caller's arrays. The worker reads requests in its main thread
(also while its preload imports run in another) and writes replies from a sender thread, so a large request
never waits on a large reply the caller has not read yet, nor on the preload.

:func:`shared` is the process's worker: started on first use (or by :func:`prestart`), reused by every
verification of the process (a sweep's Dask worker, a notebook), restarted if it died, stopped at exit. The
environment (``PYOPENGL_PLATFORM``, ``XDG_CACHE_HOME``) is the parent's at start.
"""

from __future__ import annotations

import atexit
import importlib
import json
import pickle
import queue
import socket
import subprocess
import sys
import threading
import time
import traceback
from multiprocessing.connection import Connection

#: The worker's start: the caller's ``sys.path`` (so it imports the very ``rockdove`` and libraries the caller
#: does, however they were installed), then :func:`_serve` on the socket.
_BOOT = ("import json, sys; sys.path[:] = json.loads(sys.argv[3]); from rockdove.verify.worker import _serve; "
         "_serve(int(sys.argv[1]), [m for m in sys.argv[2].split(',') if m])")

#: What the worker imports before its first request: the GL renders' modules (the first request, the slowest
#: import).
PRELOAD = ("rockdove.render.gl",)


def _pack(obj) -> tuple[bytes, list]:
    """``obj`` pickled (protocol 5) with its contiguous arrays out of band: ``(pickle, raw buffers)``."""
    buffers = []
    meta = pickle.dumps(obj, protocol=5, buffer_callback=buffers.append)
    return meta, [b.raw() for b in buffers]


def _send(conn: Connection, packed) -> None:
    """Send :func:`_pack`'s output: each array's bytes go through the socket as they are, not copied into the
    pickle first."""
    meta, raws = packed
    conn.send((meta, [r.nbytes for r in raws]))
    for r in raws:
        conn.send_bytes(r)


def _recv(conn: Connection):
    """What :func:`_send` sent; arrays come back writable."""
    meta, sizes = conn.recv()
    buffers = []
    for n in sizes:
        b = bytearray(n)
        conn.recv_bytes_into(b)
        buffers.append(b)
    return pickle.loads(meta, buffers=buffers)


class WorkerError(RuntimeError):
    """A request to the worker did not give its result (:class:`WorkerFailed` or :class:`RemoteError`)."""


class WorkerFailed(WorkerError):
    """The worker process exited or could not start; the message says how."""


class RemoteError(WorkerError):
    """A request raised in the worker; the message carries its type and message (the worker prints the
    traceback on its stderr, which is the caller's)."""


class Worker:
    """One worker process (module docstring). Thread-safe: requests are serialised.

    Use :meth:`call` (blocking) or :meth:`submit` (a :class:`Pending` whose ``result()`` blocks), then
    :meth:`close`.
    """

    def __init__(self, preload=PRELOAD):
        parent, child = socket.socketpair()
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-c", _BOOT, str(child.fileno()), ",".join(preload), json.dumps(sys.path)],
                pass_fds=(child.fileno(),), stdin=subprocess.DEVNULL, stdout=2, close_fds=True)
        except OSError as exc:
            parent.close()
            raise WorkerFailed(f"could not start the verification worker process ({exc})") from None
        finally:
            child.close()
        self._conn = Connection(parent.detach())
        self._lock = threading.Lock()  # one request at a time: request order = reply order
        self._pending: list[Pending] = []
        self._closed = False

    @property
    def alive(self) -> bool:
        """The process runs and is this process's child (in a forked child, ``poll()`` finds no child of its own
        and says it exited, so :func:`shared` starts a new worker and :meth:`close` leaves the parent's alone)."""
        return not self._closed and self._proc.poll() is None

    def submit(self, fn: str, *args) -> "Pending":
        """Send ``fn(*args)`` (``fn`` = ``"package.module:function"``) to the worker; returns without waiting for
        it to run (the worker reads requests while it works and writes replies from a thread of their own, so a
        large request never waits on an unread large reply)."""
        packed = _pack((fn, args))
        with self._lock:
            if self._closed:
                raise WorkerFailed("the verification worker is closed")
            pending = Pending(self, fn)
            try:
                _send(self._conn, packed)
            except OSError as exc:
                raise self._failure(exc) from None
            self._pending.append(pending)
            return pending

    def call(self, fn: str, *args):
        """``fn(*args)`` in the worker; its result, or its exception as :class:`RemoteError`."""
        return self.submit(fn, *args).result()

    def _receive_until(self, pending: "Pending") -> None:
        with self._lock:
            while not pending.done:
                self._receive_one()

    def _receive_one(self) -> None:
        """The next reply, for the oldest request (the lock held); if the worker died, every request fails."""
        try:
            status, payload = _recv(self._conn)
        except (EOFError, OSError) as exc:
            failure = self._failure(exc)
            for p in self._pending:
                p._set(False, failure)
            self._pending.clear()
            return
        self._pending.pop(0)._set(status == "ok", payload)

    def _failure(self, exc) -> WorkerFailed:
        try:
            code = self._proc.wait(timeout=1.0)
        except subprocess.TimeoutExpired:
            code = None
        how = f"exited with status {code}" if code is not None else f"stopped answering ({exc})"
        return WorkerFailed(f"the verification worker process (pid {self._proc.pid}) {how}")

    def close(self) -> None:
        """Stop the worker (at once: a request in flight is abandoned)."""
        if self._closed:
            return
        self._closed = True
        try:
            self._conn.close()
        except OSError:
            pass
        if self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()


class Pending:
    """A request sent to a :class:`Worker`; :meth:`result` waits for its reply."""

    def __init__(self, worker: Worker | None, fn: str):
        self._worker, self.fn = worker, fn
        self.done, self._ok, self._value = False, False, None

    @classmethod
    def failed(cls, fn: str, error: WorkerError) -> "Pending":
        """A request that could not be sent: its :meth:`result` raises ``error``."""
        p = cls(None, fn)
        p._set(False, error)
        return p

    def _set(self, ok: bool, value) -> None:
        self.done, self._ok, self._value = True, ok, value

    def result(self):
        if not self.done:
            self._worker._receive_until(self)
        if self._ok:
            return self._value
        if isinstance(self._value, WorkerError):
            raise self._value
        raise RemoteError(f"{self.fn} failed in the verification worker: {self._value}")


# -- the process's worker ----------------------------------------------------------------------------------
_SHARED: Worker | None = None
_SHARED_LOCK = threading.Lock()


def shared() -> Worker:
    """The process's worker, started (or restarted, if it died) now. Raises :class:`WorkerFailed` if it cannot
    start."""
    global _SHARED
    with _SHARED_LOCK:
        if _SHARED is None or not _SHARED.alive:
            _SHARED = Worker()
        return _SHARED


def submit(fn: str, *args) -> Pending:
    """``fn(*args)`` sent to the process's worker (:func:`shared`); if the worker cannot start, a
    :meth:`Pending.failed` that says why. Returns at once; ``result()`` waits."""
    try:
        return shared().submit(fn, *args)
    except WorkerFailed as exc:
        return Pending.failed(fn, exc)


class GLRenders:
    """The GL renders of ``views`` in the process's worker, sent at once, one reply per view
    (:meth:`result`), so the caller can compare a view while the next one renders. The renderer is opened
    for the first view's size and closed after the last, as :func:`rockdove.render.gl.render_views` does, so
    the images are the same."""

    def __init__(self, scene, views, lut=None):
        views = list(views)
        if not views:
            raise ValueError("views must contain at least one View, got none")
        self._open = submit(f"{__name__}:gl_open", scene, lut, views[0].width, views[0].height)
        self._views = [submit(f"{__name__}:gl_render", v) for v in views]
        submit(f"{__name__}:gl_close")

    def result(self, i: int):
        """View ``i``'s ``(RenderResult, seconds)``, the seconds with its share of opening the renderer;
        :class:`WorkerError` if the renderer could not open (its error) or the view failed."""
        open_s = self._open.result()
        image, seconds = self._views[i].result()
        return image, seconds + open_s / len(self._views)


def prestart() -> None:
    """Start the process's worker now, so that its imports run while other work goes on; never raises (if it
    cannot start, :func:`shared` says why when a render needs it)."""
    try:
        shared()
    except WorkerFailed:
        pass


@atexit.register
def _close_shared() -> None:
    if _SHARED is not None:
        _SHARED.close()


# -- the worker side ---------------------------------------------------------------------------------------
_RENDERER = None  # the worker's open GLRenderer (gl_open .. gl_close)


def gl_open(scene, lut, width: int, height: int) -> float:
    """Open the worker's :class:`rockdove.render.gl.GLRenderer` for ``scene`` (closing any open one), as
    :func:`rockdove.render.gl.render_views` does; its seconds (the import too, when not preloaded)."""
    global _RENDERER
    t = time.perf_counter()
    gl_close()
    from ..render.gl import GLRenderer

    _RENDERER = GLRenderer(scene, lut=lut, width=width, height=height)
    return time.perf_counter() - t


def gl_render(view):
    """One view with the open renderer: ``(RenderResult, seconds)``."""
    if _RENDERER is None:
        raise RuntimeError("no GL renderer is open")
    t = time.perf_counter()
    return _RENDERER.render(view), time.perf_counter() - t


def gl_close() -> None:
    global _RENDERER
    if _RENDERER is not None:
        renderer, _RENDERER = _RENDERER, None
        renderer.delete()


def validate_timed(layer_path: str):
    """:func:`rockdove.verify.provenance.run_validation` of ``layer_path`` and its wall seconds."""
    t = time.perf_counter()
    from .provenance import run_validation

    return run_validation(layer_path), time.perf_counter() - t


def _resolve(name: str):
    module, _, attr = name.partition(":")
    return getattr(importlib.import_module(module), attr)


def _preload(modules: list[str]) -> None:
    """Import ``modules`` (the worker's preload thread), pyrender too for the GL renderer."""
    try:
        for module in modules:
            importlib.import_module(module)
        if "rockdove.render.gl" in modules:
            from rockdove._compat import import_pyrender

            import_pyrender()
    except ImportError:  # a request that needs the module raises it again, to the caller
        pass


def _send_replies(conn: Connection, replies: queue.Queue) -> None:
    """The worker's sender thread: writes the packed replies in order while the main thread runs the next
    request (a large reply waits for the caller to read it without holding up the work)."""
    while (packed := replies.get()) is not None:
        try:
            _send(conn, packed)
        except (EOFError, OSError):  # the caller is gone; the main thread sees it on its next read
            return


def _serve(fd: int, preload: list[str]) -> None:
    """The worker's loop. Requests are read by this (main) thread, also while the preload imports run in
    another, so a caller's large request never waits on them; they are run in order, here (one GL context, one
    thread), and the replies written by :func:`_send_replies`."""
    conn = Connection(fd)
    loading = threading.Thread(target=_preload, args=(preload,), name="rockdove-preload", daemon=True)
    loading.start()
    replies: queue.Queue = queue.Queue()
    sender = threading.Thread(target=_send_replies, args=(conn, replies), name="rockdove-reply", daemon=True)
    sender.start()
    while True:
        try:
            fn, args = _recv(conn)
        except (EOFError, OSError):  # the parent closed its end or died
            break
        loading.join()
        try:
            reply = ("ok", _resolve(fn)(*args))
        except BaseException as exc:  # noqa: BLE001 - every failure goes back to the caller
            traceback.print_exc()  # the whole story on stderr (the parent's); the caller gets the one line
            reply = ("error", f"{type(exc).__name__}: {exc}")
        try:
            replies.put(_pack(reply))
        except Exception as exc:  # noqa: BLE001 - a result that cannot be pickled
            replies.put(_pack(("error", f"{fn} returned what cannot be sent back: {type(exc).__name__}: {exc}")))
    replies.put(None)


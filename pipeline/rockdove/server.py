"""The build server: ``rockdove`` commands run in a process that has already imported and warmed up everything.

Why: a film-only rebuild does ~0.4 s of work, but a new ``rockdove`` process first spends ~0.8 s importing pxr,
numpy, jsonschema, pygltflib, OpenEXR and Pillow, and a verification waits for its worker (pyrender, EGL) to
start. A researcher who rebuilds many times pays that each time. With ``rockdove server start``, a long-lived
process keeps those imports and the verification worker warm, and each later ``rockdove build`` (or
:data:`SERVED` command) is handed to it: the same pattern as Gradle's daemon, Bazel's server or mypy's dmypy.
Before it takes commands it imports :data:`PRELOAD`, starts the verification worker and builds a small asset
(:data:`WARM_UP`, ~2.5 s), so that its first command is served as warm as the next.

How a command is served (the client is :func:`forward`, called by :func:`rockdove.cli.main` before anything heavy is
imported; it uses the standard library only):

- The server listens on a Unix socket in a folder only the user can enter (``$XDG_RUNTIME_DIR/rockdove``, else
  ``$TMPDIR/rockdove-<uid>``), named by :func:`server_key`: a digest of the interpreter, the package's folder,
  ``sys.path`` (less its first entry, the script's or working folder) and the environment (less
  :data:`VOLATILE_ENV`). A ``rockdove`` started with another interpreter, install or environment finds no server of
  its own and runs the command itself.
- The client sends its arguments (and ``sys.argv``, which reports record), working folder and whole environment, and
  passes its stdin, stdout and stderr (``SCM_RIGHTS``); the server runs :func:`rockdove.cli.run` with them in place
  of its own (``dup2``), so output, ``--json`` and terminal detection are the client's, and sends back the exit
  status, which the client exits with. Ctrl-C (SIGINT, SIGTERM, SIGHUP) in the client, or the client's death,
  interrupts the command in the server (SIGUSR1 to its main thread, then ``KeyboardInterrupt``: exit status 130,
  as without a server; also in a blocking system call).
- One command at a time: while the server is busy, another client runs its command itself (no queueing, so parallel
  builds stay parallel).
- Staleness: at each request the server takes :func:`source_stamp` again (the package's files and the ``sys.path``
  folders, by size and modification time; the client's ``sys.path`` is the server's, less its first entry). If it
  differs from the one taken at the start, the code on disk changed since the server started (an edit, a ``pip
  install``): the server exits and the client runs the command itself, saying so on stderr.
- The server exits after ``--idle-minutes`` without a command (default :data:`IDLE_MINUTES`), on ``rockdove server
  stop`` and on SIGTERM; its output (and its verification worker's) goes to its log, ``<key>.log`` beside the
  socket.

What persists between served commands is what persists between builds in one process anyway (a Dask sweep's
worker runs many builds): the imports, the verification worker, the memoised validations. The environment,
working folder and standard streams are the client's for the duration of its command.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import socket
import struct
import sys
import time

#: Commands a running server serves; the others (``server``, ``bench``, ``sweep``: they start processes or
#: clusters of their own, and ``render``: an in-process GL context) always run in the calling process.
SERVED = frozenset({"build", "verify", "validate", "lut", "gltf", "config"})
#: Environment variables left out of :func:`server_key`: set per shell or terminal, read by no rockdove code.
VOLATILE_ENV = frozenset({"PWD", "OLDPWD", "SHLVL", "_", "COLUMNS", "LINES", "TERM_SESSION_ID", "WINDOWID"})
#: Minutes without a command after which the server exits.
IDLE_MINUTES = 60.0
#: Modules the server imports before it takes commands: the ones a build and its verification import (rockdove's
#: own import their libraries inside the functions that use them, so the libraries are named too).
PRELOAD = ("numpy", "scipy.ndimage", "jsonschema", "OpenEXR", "PIL.Image", "PIL.PngImagePlugin", "pygltflib",
           "MaterialX", "pxr.Sdf", "pxr.Usd", "pxr.UsdGeom", "pxr.UsdShade", "pxr.UsdUtils", "trimesh",
           "matplotlib.figure", "matplotlib.backends.backend_agg",
           "rockdove.commands.build", "rockdove.graph.stages", "rockdove.lut.bake", "rockdove.lut.reference",
           "rockdove.lut.exr", "rockdove.lut.preview", "rockdove.usd.stage", "rockdove.usd.material",
           "rockdove.usd.textures_io", "rockdove.usd.usdz", "rockdove.web.gltf", "rockdove.render.scene",
           "rockdove.verify.run", "rockdove.verify.verdict", "rockdove.verify.report", "rockdove.commands.verify",
           "rockdove.commands.validate", "rockdove.render.gl")
#: The warm-up: a small asset built (not verified) into a temporary folder before the server takes commands, so
#: that its first command finds what only a first build sets up (MaterialX's libraries, the schema's
#: registration, library versions, colour tables, first calls into numpy and pxr: ~1 s) done, as the next does.
WARM_UP = ("build", "--no-verify", "--quiet", "--set", "geometry.body_voxel_m=0.008",
           "--set", "geometry.card_count=200", "--set", "textures.body_resolution=64",
           "--set", "textures.feather_resolution=32",
           "--set", "lut.angles=32", "--set", "lut.thicknesses=8")
_HEADER = struct.Struct("!I")
_BOOT = ("import json, sys; sys.path[:] = json.loads(sys.argv[1]); from rockdove.cli import run; "
         "from rockdove.server import serve; serve(run, float(sys.argv[2]))")


class ServerError(RuntimeError):
    """The server could not be started, reached or stopped; the message says why."""


class _Stop(BaseException):
    """Raised in the server's main thread by SIGTERM or SIGINT between commands: it exits."""


# -- where a server lives ----------------------------------------------------------------------------------
def _package_dir() -> str:
    return os.path.dirname(os.path.abspath(__file__))


def server_key(env=None) -> str:
    """The server that may run this process's commands: 16 hex digits of a digest of the interpreter, the
    package's folder, ``sys.path[1:]`` and the environment less :data:`VOLATILE_ENV`."""
    from . import __version__

    env = os.environ if env is None else env
    ident = [sys.executable, _package_dir(), __version__, sys.path[1:],
             sorted((k, v) for k, v in env.items() if k not in VOLATILE_ENV)]
    return hashlib.sha256(json.dumps(ident).encode()).hexdigest()[:16]


def _runtime_path() -> str:
    base = os.environ.get("XDG_RUNTIME_DIR")
    return os.path.join(base, "rockdove") if base else os.path.join(os.environ.get("TMPDIR") or "/tmp",
                                                                    f"rockdove-{os.getuid()}")


def runtime_dir(create: bool = True) -> str:
    """The folder of the user's servers: ``$XDG_RUNTIME_DIR/rockdove``, else ``$TMPDIR/rockdove-<uid>`` (``/tmp``
    when unset), created with mode 0700 when ``create``. Raises :class:`ServerError` if it cannot be made, belongs
    to another user or others can enter it (a socket there could be someone else's)."""
    import stat

    path = _runtime_path()
    try:
        if create:
            os.makedirs(path, mode=0o700, exist_ok=True)
        st = os.lstat(path)
    except OSError as exc:
        raise ServerError(f"cannot make the server folder {path}: {exc.strerror}") from None
    if st.st_uid != os.getuid() or st.st_mode & 0o077 or not stat.S_ISDIR(st.st_mode):
        raise ServerError(f"the server folder {path} is not a private folder of this user (owner uid {st.st_uid}, "
                          f"mode {oct(st.st_mode & 0o777)}); remove it or set XDG_RUNTIME_DIR")
    return path


def paths(key: str | None = None, create: bool = True) -> dict[str, str]:
    """The socket and log of the server :func:`server_key` names (:func:`runtime_dir`)."""
    base = os.path.join(runtime_dir(create), key or server_key())
    return {"socket": base + ".sock", "log": base + ".log"}


def source_stamp() -> str:
    """What the server's code is: a digest of the size and modification time of every file of the package (its
    ``.py`` files and data folders: shaders, schemas, node definitions; not ``node_modules``) and of every
    ``sys.path`` folder (a folder's time changes when a ``pip install`` adds or removes a distribution in it)."""
    from pathlib import Path

    from . import resources
    from .graph.engine import files_of

    h = hashlib.sha256()
    for top in (_package_dir(), *(resources.folder(name) for name in resources.FOLDERS)):
        for path in files_of(Path(top)):  # without __pycache__ and node_modules, as the stages' keys
            st = path.stat()
            h.update(f"{path}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    for p in sys.path[1:]:
        try:
            h.update(f"{p}\0{os.stat(p or '.').st_mtime_ns}\n".encode())
        except OSError:
            h.update(f"{p}\0-\n".encode())
    return h.hexdigest()


# -- the wire: 4-byte length + JSON ------------------------------------------------------------------------
def _frame(obj) -> bytes:
    data = json.dumps(obj).encode()
    return _HEADER.pack(len(data)) + data


def _read_exact(sock: socket.socket, n: int, head: bytes = b"") -> bytes:
    buf = bytearray(head)
    while len(buf) < n:
        chunk = sock.recv(n - len(buf))
        if not chunk:
            raise EOFError("connection closed")
        buf += chunk
    return bytes(buf)


def _read_message(sock: socket.socket, head: bytes = b""):
    size = _HEADER.unpack(_read_exact(sock, _HEADER.size, head[:_HEADER.size]))[0]
    return json.loads(_read_exact(sock, size, head[_HEADER.size:]))


def _connect(sock_path: str, timeout: float | None = None) -> socket.socket | None:
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(timeout)
    try:
        s.connect(sock_path)
    except OSError:
        s.close()
        return None
    s.settimeout(None)
    return s


def _control(op: str, key: str | None = None, timeout: float = 10.0):
    """Send ``op`` (``status``, ``stop``) to the server: its reply, or None when none is listening."""
    try:
        sock_path = paths(key, create=False)["socket"]
    except ServerError:
        return None
    s = _connect(sock_path, timeout)
    if s is None:
        return None
    try:
        s.settimeout(timeout)
        s.sendall(_frame({"op": op}))
        return _read_message(s)
    except (OSError, EOFError, ValueError):
        return None
    finally:
        s.close()


# -- the client --------------------------------------------------------------------------------------------
def forward(argv: list[str]) -> int | None:
    """Run ``rockdove argv`` in this user's server for this interpreter and environment, if one is running and
    free: the command's exit status. None when there is none (or it is busy, or its code is stale): the caller
    runs the command itself."""
    if not os.path.isdir(_runtime_path()):
        return None  # no server was ever started here: nothing to create or check
    try:
        sock_path = paths(create=False)["socket"]
    except ServerError:
        return None
    if not os.path.exists(sock_path):
        return None
    s = _connect(sock_path)
    if s is None:
        return None
    with s:
        request = {"op": "run", "argv": argv, "sys_argv": sys.argv, "cwd": os.getcwd(), "env": dict(os.environ)}
        try:
            data = _frame(request)
            sent = socket.send_fds(s, [data], [0, 1, 2])
            if sent < len(data):
                s.sendall(data[sent:])
            reply = _read_message(s)
        except (OSError, EOFError, ValueError):
            return None  # it went away before taking the command: nothing ran there
        if reply.get("status") == "stale":
            print("rockdove: the build server runs older code than is installed now; it has stopped, and this "
                  "command runs here (`rockdove server start` starts a new one)", file=sys.stderr)
            return None
        if reply.get("status") != "running":
            return None  # busy: run here, in parallel
        return _wait(s)


def _wait(s: socket.socket) -> int:
    """Wait for the served command's exit status, passing on SIGINT, SIGTERM and SIGHUP meanwhile."""
    def on_signal(signum, frame):
        try:
            s.sendall(_frame({"signal": signum}))
        except OSError:
            pass

    old = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:
        while True:
            try:
                reply = _read_message(s)  # a signal's handler runs in here; the read resumes (PEP 475)
            except (OSError, EOFError, ValueError):
                print("rockdove: the build server stopped during the command (its log: "
                      f"{paths()['log']}); run it again, or with --no-server", file=sys.stderr)
                return 1
            if reply.get("status") == "exit":
                return int(reply.get("code", 1))
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


# -- starting, stopping, asking ----------------------------------------------------------------------------
def status(key: str | None = None) -> dict | None:
    """The running server's state (pid, started, served, busy, idle seconds, peak memory, log, and ``stale``:
    whether the code installed now differs from the code it runs), or None."""
    return _control("status", key)


def start(idle_minutes: float = IDLE_MINUTES, wait_s: float = 180.0) -> dict:
    """Start this interpreter's and environment's server in the background (unless it runs already, on the code
    installed now: one on older code is stopped and replaced) and wait until it takes commands: its
    :func:`status`. Raises :class:`ServerError` with the log's last lines if it
    exits first."""
    import subprocess

    argv = _boot_argv(idle_minutes)
    running = status()
    if running is not None and not running.get("stale"):
        return {**running, "already": True}
    if running is not None:  # it runs code older than what is installed now: replace it
        stop()
    p = paths()
    with open(p["log"], "ab") as log:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=log, stderr=log, close_fds=True,
                                start_new_session=True, cwd="/")
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        running = status()
        if running is not None and running.get("pid") == proc.pid:
            return {**running, "already": False}
        if proc.poll() is not None:
            raise ServerError(f"the build server exited with status {proc.returncode} before taking commands; "
                              f"its log {p['log']} ends:\n{_tail(p['log'])}")
        time.sleep(0.05)
    proc.terminate()
    raise ServerError(f"the build server did not start within {wait_s:g} s; its log {p['log']} ends:\n"
                      f"{_tail(p['log'])}")


def exec_foreground(idle_minutes: float = IDLE_MINUTES) -> None:
    """Become the server (``exec`` of the same start-up command :func:`start` runs in the background): output on
    this process's stdout and stderr, until stopped, idle or interrupted."""
    os.execv(sys.executable, _boot_argv(idle_minutes))


def _boot_argv(idle_minutes: float) -> list[str]:
    """The server's start-up command (:data:`_BOOT` with this process's ``sys.path``); ``ValueError`` unless
    ``idle_minutes`` is a finite number > 0."""
    import math

    if not math.isfinite(idle_minutes) or idle_minutes <= 0:
        raise ValueError(f"--idle-minutes must be a number > 0, got {idle_minutes:g}")
    return [sys.executable, "-c", _BOOT, json.dumps(sys.path), str(idle_minutes)]


def stop(key: str | None = None, wait_s: float = 30.0) -> dict | None:
    """Stop the running server (after the command it runs, if any): its last :func:`status`, or None if none
    ran."""
    last = _control("stop", key, timeout=wait_s)
    if last is None:
        return None
    p = paths(key)
    deadline = time.monotonic() + wait_s
    while os.path.exists(p["socket"]) and time.monotonic() < deadline:
        time.sleep(0.05)
    return last


def _tail(path: str, lines: int = 12) -> str:
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-lines:]).rstrip()
    except OSError:
        return "(no log)"


# -- the server --------------------------------------------------------------------------------------------
class _Server:
    def __init__(self, run_command, idle_s: float):
        import threading

        self.run_command = run_command
        self.idle_s = idle_s
        self.key = server_key()
        self.paths = paths(self.key)
        self.stamp = source_stamp()
        self.started = time.time()
        self.served = 0
        self.last = time.monotonic()
        self.lock = threading.Lock()
        self.busy = False
        self.stopping = False
        self.in_command = False  # the main thread runs a client's command (signals interrupt it)
        self.wake = threading.Condition(self.lock)
        self.job = None

    def info(self) -> dict:
        import resource

        with self.lock:
            busy, served, idle = self.busy, self.served, time.monotonic() - self.last
        return {"pid": os.getpid(), "key": self.key, "started": self.started, "served": served, "busy": busy,
                "idle_s": 0.0 if busy else round(idle, 1), "idle_limit_s": self.idle_s,
                "peak_rss_mib": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
                "socket": self.paths["socket"], "log": self.paths["log"], "stale": source_stamp() != self.stamp}

    # the acceptor thread: takes connections, answers status/stop/busy/stale itself, hands commands over
    def accept_loop(self, listener: socket.socket) -> None:
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            try:
                self._take(conn)
            except Exception as exc:  # noqa: BLE001 - a bad client must not stop the server
                print(f"rockdove server: a request failed: {exc!r}", file=sys.stderr, flush=True)
                conn.close()

    def _take(self, conn: socket.socket) -> None:
        conn.settimeout(30.0)
        msg, fds, _flags, _addr = socket.recv_fds(conn, 1 << 16, 3)
        try:
            request = _read_message(conn, msg)
        except BaseException:
            for fd in fds:
                os.close(fd)
            raise
        op = request.get("op")
        if op != "run":
            for fd in fds:
                os.close(fd)
            if op == "status":
                conn.sendall(_frame(self.info()))
            elif op == "stop":
                conn.sendall(_frame(self.info()))
                with self.lock:
                    self.stopping = True
                    self.wake.notify_all()
            conn.close()
            return
        with self.lock:
            busy = self.busy or self.stopping
            stale = not busy and source_stamp() != self.stamp  # the same files the client would import
            if not busy and len(fds) == 3:
                self.busy = True
                if stale:
                    self.stopping = True
                else:
                    self.job = (conn, fds, request)
                self.wake.notify_all()
        if busy or stale or len(fds) != 3:
            for fd in fds:
                os.close(fd)
            conn.sendall(_frame({"status": "stale" if stale else "busy"}))
            conn.close()

    # the main thread: runs commands (KeyboardInterrupt reaches only the main thread)
    def main_loop(self) -> None:
        import gc

        while True:
            with self.lock:
                while self.job is None and not self.stopping:
                    left = self.idle_s - (time.monotonic() - self.last)
                    if left <= 0:
                        print("rockdove server: idle, exiting", file=sys.stderr, flush=True)
                        return
                    self.wake.wait(left)
                if self.job is None:
                    return
                job, self.job = self.job, None
            conn = job[0]
            code = 130
            try:
                code = self._run(*job)
            except KeyboardInterrupt:
                pass  # an interrupt that came as the command ended
            finally:
                with self.lock:  # before the reply: a client that asks next sees the command counted
                    self.busy = False
                    self.served += 1
                    self.last = time.monotonic()
            try:
                conn.sendall(_frame({"status": "exit", "code": int(code)}))
                conn.shutdown(socket.SHUT_RDWR)  # also wakes the thread watching the client
            except OSError:
                pass
            conn.close()
            gc.collect()  # after the reply: the client does not wait for it

    def _run(self, conn: socket.socket, fds: list[int], request: dict) -> int:
        """Run the request's command with the client's streams, environment, folder and ``sys.argv``: its exit
        status."""
        import threading

        conn.settimeout(None)
        conn.sendall(_frame({"status": "running"}))
        main = threading.main_thread().ident

        def watch():
            """A signal from the client, or its end, interrupts the command: SIGUSR1 to the main thread, a real
            signal, so that a command blocked in a system call (a lock held by another build, a read) wakes too."""
            while True:
                try:
                    msg = _read_message(conn)
                except (OSError, EOFError, ValueError):
                    msg = None
                if self.in_command:
                    signal.pthread_kill(main, signal.SIGUSR1)
                if msg is None:
                    return

        saved_env, saved_cwd, saved_argv = dict(os.environ), os.getcwd(), sys.argv
        sys.stdout.flush()
        sys.stderr.flush()
        saved_fds = [os.dup(i) for i in range(3)]
        code = 1
        try:
            for i, fd in enumerate(fds):
                os.dup2(fd, i)
            for stream in (sys.stdout, sys.stderr):
                stream.reconfigure(line_buffering=stream.isatty())
            os.environ.clear()
            os.environ.update(request["env"])
            threading.Thread(target=watch, daemon=True, name="rockdove-client-watch").start()
            os.chdir(request["cwd"])
            sys.argv = list(request.get("sys_argv") or ["rockdove", *request["argv"]])
            self.in_command = True  # from here on SIGUSR1 interrupts (_on_client_interrupt)
            try:
                code = self.run_command(list(request["argv"]))
            finally:
                self.in_command = False
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            if not isinstance(exc.code, (int, type(None))):
                print(exc.code, file=sys.stderr)
        except KeyboardInterrupt:
            print("rockdove: interrupted", file=sys.stderr)
            code = 130
        except _Stop:
            raise
        except BaseException:  # noqa: BLE001 - the client gets the traceback and status 1, the server lives
            import traceback

            traceback.print_exc()
            code = 1
        finally:
            try:
                sys.stdout.flush()
                sys.stderr.flush()
            except OSError:
                pass
            for i, fd in enumerate(saved_fds):
                os.dup2(fd, i)
                os.close(fd)
            for fd in fds:
                os.close(fd)
            for stream in (sys.stdout, sys.stderr):
                stream.reconfigure(line_buffering=False)
            os.environ.clear()
            os.environ.update(saved_env)
            os.chdir(saved_cwd)
            sys.argv = saved_argv
        return int(code)


def _warm_up(run_command) -> None:
    """Run :data:`WARM_UP` into a temporary folder (removed after); a failure is logged, not fatal (a command
    that meets the same failure reports it)."""
    import tempfile

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="rockdove-server-warm-up-") as tmp:
        try:
            out, cache = os.path.join(tmp, "pigeon"), os.path.join(tmp, "cache")
            code = run_command([WARM_UP[0], "--out", out, "--cache", cache, *WARM_UP[1:]])
        except BaseException as exc:  # noqa: BLE001 - SystemExit from argparse included
            code = repr(exc)
    sys.stdout.flush()
    print(f"rockdove server: warm-up build {'done' if code == 0 else f'failed ({code})'} in "
          f"{time.perf_counter() - t0:.2f} s", file=sys.stderr, flush=True)


def serve(run_command, idle_minutes: float = IDLE_MINUTES) -> None:
    """The server process (:func:`start` runs it detached; ``rockdove server start --foreground`` here): preload,
    listen, run each command with ``run_command(argv) -> exit status`` (:func:`rockdove.cli.run`) until stopped
    or idle, then remove its socket."""
    import importlib
    import threading

    t0 = time.perf_counter()
    server = _Server(run_command, idle_minutes * 60.0)
    for name in PRELOAD:
        try:
            importlib.import_module(name)
        except Exception as exc:  # noqa: BLE001 - a command that needs it says so when it runs
            print(f"rockdove server: preloading {name} failed: {exc!r}", file=sys.stderr, flush=True)
    from .verify import worker

    worker.set_output(os.dup(2))  # the log, also while a command has the client's stderr on fd 2
    worker.prestart()
    _warm_up(run_command)
    sock_path = server.paths["socket"]
    if os.path.exists(sock_path):
        if _connect(sock_path, 5.0) is not None:
            print(f"rockdove server: another server listens on {sock_path}; exiting", file=sys.stderr, flush=True)
            return
        os.unlink(sock_path)
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(sock_path)
    os.chmod(sock_path, 0o600)
    inode = os.stat(sock_path).st_ino
    listener.listen(16)
    server.last = time.monotonic()  # the idle time counts from here, not from before the preload

    def on_stop(signum, frame):
        """SIGTERM, or Ctrl-C of a foreground server: stop, after interrupting the command that runs, if any."""
        server.stopping = True  # seen by the main loop after the command
        raise KeyboardInterrupt if server.in_command else _Stop()

    def on_client_interrupt(signum, frame):
        """SIGUSR1, sent by the thread that watches the client (Ctrl-C there, or its end)."""
        if server.in_command:  # a late one, after the command, is dropped
            raise KeyboardInterrupt

    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, on_stop)
    signal.signal(signal.SIGUSR1, on_client_interrupt)
    print(f"rockdove server: pid {os.getpid()} serving {sock_path} (key {server.key}), ready in "
          f"{time.perf_counter() - t0:.2f} s", file=sys.stderr, flush=True)
    try:
        threading.Thread(target=server.accept_loop, args=(listener,), daemon=True, name="rockdove-accept").start()
        server.main_loop()
    except (KeyboardInterrupt, _Stop):
        pass  # SIGTERM or SIGINT while idle
    finally:
        try:
            if os.stat(sock_path).st_ino == inode:  # ours, not a newer server's
                os.unlink(sock_path)
        except OSError:
            pass
        listener.close()
        print(f"rockdove server: pid {os.getpid()} stopped after {server.served} commands", file=sys.stderr,
              flush=True)

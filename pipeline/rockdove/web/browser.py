"""Drive headless Chromium over the Chrome DevTools Protocol on ``--remote-debugging-pipe`` (NUL-terminated JSON on
file descriptors 3 and 4: no port, no WebSocket library), WebGL2 on SwiftShader, a fresh temporary profile. A step
that fails or times out raises :class:`BrowserError` naming the step, never hangs."""

from __future__ import annotations

import base64
import contextlib
import json
import os
import select
import shlex
import shutil
import subprocess
import tempfile
import time

from ..errors import RockdoveError

#: Flags for headless WebGL2 on a machine without a GPU or network (measured on Debian 12, Chromium 156).
CHROMIUM_FLAGS = ("--headless=new", "--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--no-first-run", "--no-default-browser-check", "--disable-extensions", "--mute-audio",
                  "--allow-file-access-from-files")
#: Executables tried in order when none is given.
EXECUTABLES = ("chromium", "chromium-browser", "google-chrome")
#: Seconds for the browser to start and answer its first command.
START_TIMEOUT_S = 60.0


class BrowserError(RockdoveError, RuntimeError):
    """The browser could not start, or a step did not finish in time / failed (the message names the step)."""


def find_chromium(executable: str | None = None) -> str:
    """The browser executable: ``executable`` if given, else the first of :data:`EXECUTABLES` on PATH."""
    for name in ([executable] if executable else EXECUTABLES):
        if found := shutil.which(name):
            return found
    raise BrowserError(f"no Chromium found (tried {executable or ', '.join(EXECUTABLES)}); "
                       "apt-get install chromium (make test does)")


class Browser:
    """One headless Chromium process, answering within ``start_timeout_s``; use as a context manager."""

    def __init__(self, executable: str | None = None, start_timeout_s: float = START_TIMEOUT_S):
        self.executable = find_chromium(executable)
        self.profile = tempfile.mkdtemp(prefix="rockdove-chromium-")
        to_child_r, self._to_child = os.pipe()
        self._from_child, from_child_w = os.pipe()
        cmd = f"exec 3<&{to_child_r} 4>&{from_child_w}; exec " + shlex.join([
            self.executable, *CHROMIUM_FLAGS, f"--user-data-dir={self.profile}", "--remote-debugging-pipe",
            "about:blank"])
        self._stderr = tempfile.TemporaryFile()
        try:
            self.process = subprocess.Popen(["bash", "-c", cmd], pass_fds=(to_child_r, from_child_w),
                                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                            stderr=self._stderr, start_new_session=True)
        except OSError as exc:
            self._cleanup()
            raise BrowserError(f"{self.executable} could not start: {exc}") from None
        finally:
            os.close(to_child_r)
            os.close(from_child_w)
        self._buffer = b""
        self._next_id = 0
        self._events: list[dict] = []
        try:
            self.version = self.call("Browser.getVersion", timeout_s=start_timeout_s, step="start")["product"]
        except BrowserError:
            self.close()
            raise

    # -- protocol -------------------------------------------------------------------------------------------
    def _gone(self, step: str) -> BrowserError:
        """The error for a browser whose pipe closed (it exited, or is about to): its exit status if it has one, and
        the last three lines it wrote to stderr."""
        try:
            status = f"exited with status {self.process.wait(timeout=5)}"
        except subprocess.TimeoutExpired:
            status = "closed its DevTools pipe"
        self._stderr.seek(0)
        tail = " | ".join([ln for ln in self._stderr.read().decode(errors="replace").splitlines() if ln.strip()][-3:])
        return BrowserError(f"{os.path.basename(self.executable)} {status} ({step}) {tail}")

    def _read_message(self, deadline: float, step: str) -> dict:
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                raise BrowserError(f"chromium did not answer within the time limit ({step})")
            ready, _, _ = select.select([self._from_child], [], [], min(left, 1.0))
            if not ready:
                if self.process.poll() is not None:
                    raise self._gone(step)
                continue
            if not (chunk := os.read(self._from_child, 1 << 20)):
                raise self._gone(step)
            self._buffer += chunk
        raw, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(raw)

    def call(self, method: str, params: dict | None = None, *, session: str | None = None,
             timeout_s: float = 30.0, step: str | None = None) -> dict:
        """Send one protocol command and wait for its result (events that arrive meanwhile are kept)."""
        self._next_id += 1
        msg = {"id": self._next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        try:
            os.write(self._to_child, json.dumps(msg).encode() + b"\0")
        except OSError:  # a closed pipe: the browser exited (whether a read or this write noticed first)
            raise self._gone(step or method) from None
        deadline = time.monotonic() + timeout_s
        while True:
            reply = self._read_message(deadline, step or method)
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise BrowserError(f"{method} failed ({step or method}): {reply['error'].get('message')}")
                return reply.get("result", {})
            if "method" in reply:
                self._events.append(reply)

    def wait_event(self, method: str, session: str, timeout_s: float, step: str) -> dict:
        deadline = time.monotonic() + timeout_s
        while True:
            for i, ev in enumerate(self._events):
                if ev["method"] == method and ev.get("sessionId") == session:
                    return self._events.pop(i)
            self._events.append(self._read_message(deadline, step))

    def open(self, url: str, width: int, height: int, timeout_s: float = 60.0) -> Page:
        """Open ``url`` in a new tab whose viewport is ``width`` x ``height`` CSS pixels (scale 1)."""
        target = self.call("Target.createTarget", {"url": "about:blank"}, step="open tab")["targetId"]
        session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True},
                            step="attach tab")["sessionId"]
        page = Page(self, session)
        for domain in ("Runtime", "Log", "Page"):
            self.call(f"{domain}.enable", session=session, step=f"enable {domain}")
        self.call("Emulation.setDeviceMetricsOverride", {"width": int(width), "height": int(height),
                                                         "deviceScaleFactor": 1, "mobile": False},
                  session=session, step="set viewport")
        self.call("Page.navigate", {"url": url}, session=session, timeout_s=timeout_s, step=f"navigate {url}")
        self.wait_event("Page.loadEventFired", session, timeout_s, step=f"load {url}")
        return page

    # -- life -------------------------------------------------------------------------------------------------
    def close(self) -> None:
        if self.process.poll() is None:
            with contextlib.suppress(BrowserError):
                self.call("Browser.close", timeout_s=5.0, step="close")
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, 9)
                self.process.wait(timeout=10)
        self._cleanup()

    def _cleanup(self) -> None:
        for fd in ("_to_child", "_from_child"):
            if getattr(self, fd) is not None:
                with contextlib.suppress(OSError):
                    os.close(getattr(self, fd))
                setattr(self, fd, None)
        self._stderr.close()
        shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is not None and self.process.poll() is None:  # interrupted or failed: its process group goes now
            with contextlib.suppress(OSError):
                os.killpg(self.process.pid, 9)
        self.close()


class Page:
    """One tab: evaluate JavaScript, take screenshots, read its console errors."""

    def __init__(self, browser: Browser, session: str):
        self.browser, self.session = browser, session

    def _messages(self):
        """``(kind, level, text)`` of each console message, uncaught exception and browser log entry so far."""
        for ev in self.browser._events:
            p = ev.get("params", {})
            if ev.get("sessionId") != self.session:
                continue
            if ev["method"] == "Runtime.consoleAPICalled":
                yield "console", p.get("type"), " ".join(str(a.get("value", a.get("description", "")))
                                                         for a in p.get("args", []))
            elif ev["method"] == "Runtime.exceptionThrown":
                d = p.get("exceptionDetails", {})
                yield "exception", "error", str(d.get("exception", {}).get("description") or d.get("text"))
            elif ev["method"] == "Log.entryAdded":
                yield "log", p["entry"].get("level"), str(p["entry"].get("text"))

    @property
    def errors(self) -> list[str]:
        """Console errors, uncaught exceptions and failed loads reported so far (one line each)."""
        return [f"{'console.error' if kind == 'console' else kind}: {text}" for kind, level, text in self._messages()
                if level == "error" or (kind, level) == ("console", "assert")]

    @property
    def console(self) -> list[str]:
        """Every console message and browser log entry so far, one line each as ``level: text``."""
        return [f"{level}: {text}" for kind, level, text in self._messages() if kind != "exception"]

    def evaluate(self, expression: str, timeout_s: float = 60.0, step: str | None = None):
        """The value of ``expression`` (awaited if it is a promise), as JSON-compatible Python data."""
        res = self.browser.call("Runtime.evaluate", {"expression": expression, "awaitPromise": True,
                                                     "returnByValue": True, "timeout": int(timeout_s * 1000)},
                                session=self.session, timeout_s=timeout_s + 5, step=step or expression[:60])
        if "exceptionDetails" in res:
            d = res["exceptionDetails"]
            raise BrowserError(f"{step or expression[:60]}: "
                               f"{d.get('exception', {}).get('description') or d.get('text')}")
        return res.get("result", {}).get("value")

    def screenshot(self, timeout_s: float = 60.0) -> bytes:
        """PNG bytes of the viewport."""
        data = self.browser.call("Page.captureScreenshot", {"format": "png"}, session=self.session,
                                 timeout_s=timeout_s, step="screenshot")["data"]
        return base64.b64decode(data)

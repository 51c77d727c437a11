"""The build server (pipeline/rockdove/server.py): ``rockdove server start`` runs later commands in a warm process.

Each test drives the real CLI in fresh interpreters, with one environment for the server and its clients (the
server serves only the interpreter and environment it was started with) and a runtime folder of its own
(``$XDG_RUNTIME_DIR``). The builds are small (:data:`conftest.SMALL_BUILD`).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import OUTSIDE, SMALL_BUILD

SETS = [a for s in SMALL_BUILD for a in ("--set", s)]


def _env(tmp: Path, **extra) -> dict:
    runtime = tmp / "run"
    runtime.mkdir(mode=0o700, exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k not in ("ROCKDOVE_DEBUG", "PYTEST_CURRENT_TEST")}
    env.update(XDG_RUNTIME_DIR=str(runtime), XDG_CACHE_HOME=str(tmp / "user-cache"), PYOPENGL_PLATFORM="egl",
               **extra)
    return env


def cli(env, *args, timeout=300, **kw):
    return subprocess.run([sys.executable, "-m", "rockdove.cli", *args], cwd=OUTSIDE, env=env, capture_output=True,
                          text=True, timeout=timeout, **kw)


def popen(env, *args):
    return subprocess.Popen([sys.executable, "-m", "rockdove.cli", *args], cwd=OUTSIDE, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def status(env) -> dict:
    r = cli(env, "server", "status", "--json", timeout=60)
    return json.loads(r.stdout)


def start(env, *args) -> dict:
    r = cli(env, "server", "start", "--json", *args, timeout=200)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def _wait_until(predicate, timeout=30.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.1)
    return False


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """A running server and the environment its clients use."""
    tmp = tmp_path_factory.mktemp("server")
    env = _env(tmp)
    info = start(env)
    yield env, tmp, info
    cli(env, "server", "stop", timeout=60)
    try:
        os.kill(info["pid"], signal.SIGKILL)
    except ProcessLookupError:
        pass


def _files(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and "verify" not in p.relative_to(folder).parts}


def test_start_status_and_a_second_start_find_the_same_server(served):
    env, tmp, info = served
    assert info["running"] and info["pid"] > 0 and Path(info["socket"]).exists()
    assert Path(info["socket"]).parent == tmp / "run" / "rockdove"
    again = start(env)
    assert again["pid"] == info["pid"]
    r = cli(env, "server", "status")
    assert r.returncode == 0 and f"pid {info['pid']}" in r.stdout and "log" in r.stdout


def test_served_build_is_the_same_as_a_build_here(served, tmp_path):
    """The server builds (and verifies) with the client's arguments, folder and environment: the same files as a
    build in the client's own process, its --json on the client's stdout; the verification's worker, which
    outlives the command, does not hold the client's pipes open (else this run would wait for ever)."""
    env, _, _ = served
    before = status(env)["served"]
    size = ["--set", "verify.width=96", "--set", "verify.height=96"]
    r = subprocess.run([sys.executable, "-m", "rockdove.cli", "build", "--out", "a/pigeon", "--cache", "cache-a",
                        "--json", "--quiet", *SETS, *size], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["verified"] is True and (tmp_path / "a" / "pigeon" / "pigeon.usda").is_file()  # the client's cwd
    assert status(env)["served"] == before + 1
    local = subprocess.run([sys.executable, "-m", "rockdove.cli", "--no-server", "build", "--out", "b/pigeon",
                            "--cache", "cache-b", "--json", "--quiet", *SETS, *size], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=300)
    assert local.returncode == 0, local.stderr
    assert status(env)["served"] == before + 1  # --no-server: not served
    assert json.loads(local.stdout)["config_hash"] == summary["config_hash"]
    a, b = _files(tmp_path / "a" / "pigeon"), _files(tmp_path / "b" / "pigeon")
    assert a.keys() == b.keys() and a == b
    report = json.loads((tmp_path / "a" / "pigeon" / "verify" / "report.json").read_text())
    assert report["argv"][1:4] == ["build", "--out", "a/pigeon"]  # the client's command line, not the server's


def test_bad_input_through_the_server_is_one_line_and_status_2(served, tmp_path):
    env, _, _ = served
    before = status(env)["served"]
    r = cli(env, "build", "--out", str(tmp_path / "x"), "--set", "film.cauchy_a=abc")
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "film.cauchy_a" in r.stderr, r.stderr
    assert not (tmp_path / "x").exists()
    assert status(env)["served"] == before + 1
    r = cli(env, "config", "--json", "--set", "lut.angles=48")
    assert r.returncode == 0 and json.loads(r.stdout)["config"]["lut"]["angles"] == 48
    # a reader that has gone away (`rockdove config | head -1`, head done): no traceback, served or not
    for no_server in ([], ["--no-server"]):
        read_end, write_end = os.pipe()
        os.close(read_end)
        r = subprocess.run([sys.executable, "-m", "rockdove.cli", *no_server, "config", "--verbose"], cwd=OUTSIDE,
                           env=env, stdout=write_end, stderr=subprocess.PIPE, text=True, timeout=120)
        os.close(write_end)
        assert r.returncode == 141 and "Traceback" not in r.stderr, r.stderr


def _blocked_config(env, tmp_path):
    """A served ``rockdove config --config FIFO``: it blocks opening the named pipe (a system call, as a build
    waiting for another build's lock does) until the test writes the file, so the server is busy for as long as
    the test wants. Returns the client process and the pipe's path."""
    fifo = tmp_path / "slow.toml"
    os.mkfifo(fifo)
    proc = popen(env, "config", "--json", "--config", str(fifo))
    assert _wait_until(lambda: status(env)["busy"], 60)
    return proc, fifo


def test_ctrl_c_interrupts_the_served_command_and_the_server_goes_on(served, tmp_path):
    """Also a command blocked in a system call: the interrupt is a real signal to the server's main thread."""
    env, _, _ = served
    proc, _ = _blocked_config(env, tmp_path)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "interrupted" in err, err
    assert _wait_until(lambda: not status(env)["busy"], 30)
    r = cli(env, "config", "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["preset"] == "measured"


def test_a_killed_client_stops_its_command(served, tmp_path):
    env, _, _ = served
    before = status(env)["served"]
    proc, _ = _blocked_config(env, tmp_path)
    proc.kill()
    proc.wait()
    assert _wait_until(lambda: not status(env)["busy"], 60)
    assert status(env)["served"] == before + 1


def test_a_busy_server_lets_the_next_command_run_in_its_own_process(served, tmp_path):
    env, _, _ = served
    proc, fifo = _blocked_config(env, tmp_path)
    served_before = status(env)["served"]
    r = cli(env, "config", "--json", "--set", "lut.angles=40")
    assert r.returncode == 0 and json.loads(r.stdout)["config"]["lut"]["angles"] == 40
    assert proc.poll() is None and status(env)["busy"]  # the first still waits for its file
    fifo.write_text("[lut]\nangles = 48\n")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0 and json.loads(out)["config"]["lut"]["angles"] == 48, err
    assert status(env)["served"] == served_before + 1  # the first; the second ran in its own process


def test_changed_code_stops_the_server_and_the_command_runs_here(tmp_path):
    """A folder on sys.path changes (as when pip installs into site-packages): the server's code is stale.
    ``status`` says so, ``start`` replaces it, and a command sent to a stale server runs in its own process."""
    extra = tmp_path / "extra"
    extra.mkdir()
    env = _env(tmp_path, PYTHONPATH=str(extra))
    info = start(env)
    assert cli(env, "config", "--json").returncode == 0 and status(env)["served"] == 1
    assert status(env)["stale"] is False
    time.sleep(0.02)
    (extra / "new_module.py").write_text("")
    assert status(env)["stale"] is True
    assert "older code" in cli(env, "server", "status").stdout
    replaced = start(env)
    assert replaced["pid"] != info["pid"] and not replaced["stale"]
    time.sleep(0.02)
    (extra / "other_module.py").write_text("")
    r = cli(env, "config", "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["preset"] == "measured"
    assert "older code" in r.stderr
    assert _wait_until(lambda: not Path(replaced["socket"]).exists(), 30)
    assert cli(env, "server", "status").returncode == 1


def test_an_idle_server_exits_and_stop_ends_a_running_one(tmp_path):
    env = _env(tmp_path)
    info = start(env, "--idle-minutes", "0.02")
    assert _wait_until(lambda: not Path(info["socket"]).exists(), 60)
    r = cli(env, "server", "status")
    assert r.returncode == 1 and "none running" in r.stdout
    info = start(env)
    r = cli(env, "server", "stop")
    assert r.returncode == 0 and "stopped" in r.stdout
    assert not Path(info["socket"]).exists()
    assert cli(env, "server", "stop").returncode == 1


def test_a_server_folder_others_can_enter_is_refused(tmp_path):
    env = _env(tmp_path)
    folder = Path(env["XDG_RUNTIME_DIR"]) / "rockdove"
    folder.mkdir(mode=0o755)
    folder.chmod(0o755)
    r = cli(env, "server", "start")
    assert r.returncode == 1 and "not a private folder" in r.stderr and str(folder) in r.stderr
    r = cli(env, "config", "--json")  # no server can be used: the command runs here
    assert r.returncode == 0


def test_bad_idle_minutes_is_a_usage_error(tmp_path):
    for bad in ("0", "-1", "nan", "inf"):
        r = cli(_env(tmp_path), "server", "start", "--idle-minutes", bad)
        assert r.returncode == 2 and "--idle-minutes must be a number > 0" in r.stderr, (bad, r.stderr)
    r = cli(_env(tmp_path), "server", "start", "--idle-minutes", "soon")
    assert r.returncode == 2 and "--idle-minutes" in r.stderr and "Traceback" not in r.stderr

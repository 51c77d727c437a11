"""Reliability through the real CLI: builds killed at several points, signals, two concurrent builds, the lock.

Builds run the real command with the stand-in stages of tests/standins.py, through tests/launcher.py, which
also stops a build right after a chosen point (``--pause-after <stage|assemble|publish-swap>``) so it can be
killed exactly there, or released when the test is ready (``--release FILE``).
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rockdove.graph import publish as P

LAUNCHER = str(Path(__file__).with_name("launcher.py"))
BASE = ["build", "--out", "b/pigeon", "--set", "geometry.card_count=40", "--quiet"]
ENV = {k: v for k, v in os.environ.items() if k != "ROCKDOVE_DEBUG"}


def _cmd(args, pause_after=None, release=None):
    opts = ["--standin"] + (["--pause-after", pause_after] if pause_after else []) + (
        ["--release", str(release)] if release else [])
    return [sys.executable, LAUNCHER, *opts, "--", *BASE, *args]


def run(cwd, *args):
    return subprocess.run(_cmd(args), cwd=cwd, env=ENV, capture_output=True, text=True, timeout=60)


def start(cwd, *args, pause_after=None, release=None):
    return subprocess.Popen(_cmd(args, pause_after, release), cwd=cwd, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def wait_for_line(proc, text, timeout=30.0) -> str:
    """Read the process's stderr until a line containing ``text`` (fails on timeout or exit)."""
    deadline = time.monotonic() + timeout
    seen = []
    while time.monotonic() < deadline:
        ready, _, _ = select.select([proc.stderr], [], [], 0.2)
        if ready:
            line = proc.stderr.readline()
            if not line:
                break
            seen.append(line)
            if text in line:
                return line
    proc.kill()
    raise AssertionError(f"no {text!r} on stderr; saw {seen!r}, exit {proc.poll()}")


def snapshot(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def leftovers(tmp: Path) -> list[str]:
    found = [p.name for p in (tmp / "b").iterdir() if ".rockdove-tmp-" in p.name or ".rockdove-old-" in p.name]
    found += [str(p) for p in (tmp / "b" / ".rockdove-cache").glob("*/.tmp-*")]
    return found


POINTS = ["cards", "lut", "usd_layers", "assemble", "verify", "publish-swap"]


@pytest.mark.parametrize("point", POINTS)
def test_sigkill_at_any_point_leaves_a_complete_asset(tmp_path, point):
    assert run(tmp_path).returncode == 0
    old = snapshot(tmp_path / "b/pigeon")
    proc = start(tmp_path, "--set", "film.cauchy_a=1.61", pause_after=point)
    wait_for_line(proc, f"paused after {point}")
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    now = snapshot(tmp_path / "b/pigeon")
    if point == "publish-swap":  # killed after the swap: the new asset is complete and in place
        assert now != old and ".rockdove-asset.json" in now and set(now) == set(old)
    else:
        assert now == old, f"killed after {point}: the old asset changed"
    # the next build cleans what the killed one left and publishes
    r = run(tmp_path, "--set", "film.cauchy_a=1.61")
    assert r.returncode == 0, r.stderr
    assert leftovers(tmp_path) == []
    assert b"1.61" in (tmp_path / "b/pigeon/pigeon.usda").read_bytes()


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_and_ctrl_c_remove_temporary_files(tmp_path, sig):
    assert run(tmp_path).returncode == 0
    old = snapshot(tmp_path / "b/pigeon")
    proc = start(tmp_path, "--set", "film.cauchy_a=1.62", pause_after="assemble")
    wait_for_line(proc, "paused after assemble")
    assert [p for p in (tmp_path / "b").iterdir() if ".rockdove-tmp-" in p.name], "no staging folder to clean"
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=10)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert snapshot(tmp_path / "b/pigeon") == old
    assert leftovers(tmp_path) == []


def test_two_concurrent_builds_serialise_on_the_lock(tmp_path):
    release = tmp_path / "release-first"
    first = start(tmp_path, "--set", "film.cauchy_a=1.63", "--json", pause_after="lut", release=release)
    wait_for_line(first, "paused after lut")
    second = start(tmp_path, "--set", "film.cauchy_a=1.64", "--json")
    wait_for_line(second, "waiting for another build")
    release.touch()  # the second is now blocked on the lock: let the first finish
    out1, _ = first.communicate(timeout=30)
    out2, _ = second.communicate(timeout=30)
    assert first.returncode == 0 and second.returncode == 0
    s1, s2 = json.loads(out1), json.loads(out2)
    assert "lut" in s1["ran"] and "body" in s2["reused"]  # the second found the first's stages in the cache
    marker = json.loads((tmp_path / "b/pigeon/.rockdove-asset.json").read_text())
    assert marker["config_hash"] == s2["config_hash"]  # the last build's asset, whole
    assert b"1.64" in (tmp_path / "b/pigeon/pigeon.usda").read_bytes()
    assert leftovers(tmp_path) == []


def test_lock_timeout_fails_with_a_clear_message(tmp_path):
    holder = start(tmp_path, pause_after="body")
    try:
        wait_for_line(holder, "paused after body")
        r = run(tmp_path, "--lock-timeout", "0.3")
        assert r.returncode == 2
        last = r.stderr.strip().splitlines()[-1]
        assert "another rockdove build" in last and "Traceback" not in r.stderr
    finally:
        holder.kill()
        holder.wait(10)


def test_refuses_to_replace_a_folder_it_did_not_create(tmp_path):
    (tmp_path / "b/pigeon").mkdir(parents=True)
    (tmp_path / "b/pigeon/notes.txt").write_text("mine\n")
    r = run(tmp_path)
    assert r.returncode == 2 and "did not create" in r.stderr
    assert (tmp_path / "b/pigeon/notes.txt").read_text() == "mine\n"
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == ["pigeon"]


def test_recover_restores_an_asset_moved_aside_by_a_killed_fallback_publish(tmp_path, monkeypatch):
    out = tmp_path / "pigeon"
    out.mkdir()
    P.write_marker(out, {"config_hash": "old"})
    # the rename fallback (no renameat2): kill between "old moved aside" and "new renamed in" ...
    aside = tmp_path / f".pigeon{P._OLD}123-abcd"
    os.rename(out, aside)
    staging = P.make_staging(out)
    P.recover(out)  # ... the next build puts the old asset back and removes the staging folder
    assert json.loads((out / P.MARKER).read_text())["config_hash"] == "old"
    assert not aside.exists() and not staging.exists()


def test_fallback_publish_replaces_the_asset(tmp_path, monkeypatch):
    monkeypatch.setattr(P, "_exchange", lambda a, b: False)
    out = tmp_path / "pigeon"
    for tag in ("one", "two"):
        staging = P.make_staging(out)
        (staging / "f.txt").write_text(tag)
        P.write_marker(staging, {"config_hash": tag})
        P.publish(staging, out)
        assert (out / "f.txt").read_text() == tag and not staging.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pigeon"]


# -- hostile outputs and one-line errors (issue 23: "Why" 4, 5, 6, 8) -----------------------------------------
def _no_override(cmd):
    """``cmd`` without the capabilities that let root write into read-only folders (as an unprivileged user)."""
    return cmd if os.geteuid() else ["setpriv", "--bounding-set=-dac_override,-dac_read_search,-fowner", "--", *cmd]


def _one_line(r, code=2, text=""):
    assert r.returncode == code, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1 and text in r.stderr, r.stderr


def test_a_read_only_asset_folder_is_refused_before_anything_is_written(tmp_path):
    assert run(tmp_path).returncode == 0
    out = tmp_path / "b/pigeon"
    old = snapshot(out)
    (out / "textures").chmod(0o555)
    out.chmod(0o555)
    try:
        r = subprocess.run(_no_override(_cmd(["--set", "film.cauchy_a=1.61"])), cwd=tmp_path, env=ENV,
                           capture_output=True, text=True, timeout=60)
        _one_line(r, 2, "is not writable (read-only)")
        assert snapshot(out) == old and leftovers(tmp_path) == []
    finally:
        out.chmod(0o755)
        (out / "textures").chmod(0o755)
    assert run(tmp_path, "--set", "film.cauchy_a=1.61").returncode == 0  # writable again: it builds


def test_a_symlinked_out_publishes_inside_its_target_and_keeps_the_link(tmp_path):
    (tmp_path / "b/real").mkdir(parents=True)
    (tmp_path / "b/pigeon").symlink_to("real/asset")
    for a in ("1.61", "1.62"):  # the first publishes into the link's (missing) target, the second replaces it
        r = run(tmp_path, "--set", f"film.cauchy_a={a}")
        assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
        assert (tmp_path / "b/pigeon").is_symlink() and a.encode() in (tmp_path / "b/real/asset/pigeon.usda").read_bytes()
    assert leftovers(tmp_path) == [] and sorted(p.name for p in (tmp_path / "b/real").iterdir()) == [
        ".asset.rockdove.lock", "asset"]


def test_leftovers_of_earlier_builds_are_removed_even_read_only_ones_and_orphan_links(tmp_path):
    assert run(tmp_path).returncode == 0
    stale = tmp_path / f"b/.pigeon{P._TMP}stale"
    (stale / "textures").mkdir(parents=True)
    (stale / "textures/x.png").write_text("x")
    (stale / "textures").chmod(0o555)
    stale.chmod(0o555)
    (tmp_path / f"b/.pigeon{P._TMP}link").symlink_to(tmp_path / "b/pigeon")  # an earlier build's orphan link
    r = subprocess.run(_no_override(_cmd(["--set", "film.cauchy_a=1.61"])), cwd=tmp_path, env=ENV,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert leftovers(tmp_path) == [] and (tmp_path / "b/pigeon/pigeon.usda").is_file()


def test_a_full_disk_is_one_line_and_the_old_asset_stays(tmp_path):
    """ENOSPC on a 4 MiB tmpfs mounted in a private mount namespace (as root, or as a user in a user namespace)."""
    script = (f"mount -t tmpfs -o size=4m tmpfs {tmp_path} && cd {tmp_path} && {' '.join(_cmd([]))} && "
              f"head -c 8m /dev/zero > fill 2>/dev/null; {' '.join(_cmd(['--set', 'film.cauchy_a=1.61']))}; echo rc=$?; "
              "grep -c 1.61 b/pigeon/pigeon.usda; ls -a b")
    unshare = ["unshare", "--mount"] if os.geteuid() == 0 else ["unshare", "--user", "--map-root-user", "--mount"]
    r = subprocess.run([*unshare, "sh", "-c", script], env=ENV, capture_output=True, text=True, timeout=120)
    assert "rc=2\n0\n" in r.stdout, (r.stdout, r.stderr)  # exit 2; the old asset (no 1.61) in place
    assert r.stderr.strip().splitlines() == ["rockdove build: error: No space left on device"], r.stderr
    assert not [n for n in r.stdout.split() if P._TMP in n or P._OLD in n]


@pytest.mark.parametrize("value, says", [
    ("film.cauchy_a=1979-05-27", "config key 'film.cauchy_a': value 1979-05-27 (a TOML date) has the wrong type; "
                                 "allowed: number >= 1 and <= 3"),
    ("film.cauchy_a=07:32:00", "value 07:32:00 (a TOML time) has the wrong type"),
    ("thickness.spread=nan", "config key 'thickness.spread': value nan is not a finite number; allowed: number >= 0 "
                             "and <= 2"),
    ("thickness.base_nm=[500, inf]", "config key 'thickness.base_nm[1]': value inf is not a finite number"),
    ("lut.angles=-inf", "config key 'lut.angles': value -inf is not a finite number; allowed: integer >= 2"),
])
def test_bad_config_values_are_one_line_naming_the_dotted_key_and_its_range(tmp_path, value, says):
    r = run(tmp_path, "--set", value)
    _one_line(r, 2, says)
    assert "_spread" not in r.stderr and not (tmp_path / "b").exists()


@pytest.mark.parametrize("seconds", ["-1", "nan", "inf"])
def test_lock_timeout_must_be_a_finite_number_of_seconds(tmp_path, seconds):
    _one_line(run(tmp_path, "--lock-timeout", seconds), 2, "--lock-timeout must be a finite number of seconds >= 0")
    assert not (tmp_path / "b").exists()


# ----------------------------------------------------------------------------------------------- a shared cache
_UNSHARE = ["unshare", "--pid", "--fork", "--mount-proc"]
needs_namespaces = pytest.mark.skipif(os.geteuid() != 0 or subprocess.run(
    [*_UNSHARE, "true"], capture_output=True).returncode != 0, reason="needs root and unshare(1) PID namespaces")


def _in_namespace(cmd, pad):
    """``cmd`` in a PID and mount namespace of its own, as pid ``pad + 2`` there (``pad`` short-lived processes
    first, so the writers' pids differ and none is a pid the cleaner's namespace has)."""
    loop = f'i=0; while [ $i -lt {pad} ]; do /bin/true; i=$((i+1)); done; "$@"; exit $?'
    return [*_UNSHARE, "sh", "-c", loop, "sh", *cmd] if pad else [*_UNSHARE, *cmd]


def _ns_start(cwd, cmd, pad):
    return subprocess.Popen(_in_namespace(cmd, pad), cwd=cwd, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


_CHEAP = ["--set", "geometry.card_count=40", "--set", "usd.usdz=false"]  # the stand-in usdz has zip dates


def _point(name, seed, pause=None, release=None):
    opts = ["--standin"] + (["--pause-after", pause] if pause else []) + (["--release", str(release)] if release
                                                                           else [])
    return [sys.executable, LAUNCHER, *opts, "--", "build", "--out", f"pts/{name}", "--cache", "shared",
            *_CHEAP, "--set", f"geometry.seed={seed}", "--quiet"]


@needs_namespaces
def test_cache_shared_across_pid_namespaces_spares_live_writers_and_cleans_killed_ones(tmp_path):
    """Issue 23: a build that cleans a shared cache removed `.tmp-<pid>-*` folders whose pid was not alive in
    *its* process table, so a worker in another container (or on another host) deleted a live writer's work.
    Three writers in PID namespaces of their own over one cache folder: K is killed mid-point (inside the
    cards store), A is paused mid-point, B builds from start to end (and cleans at its start). A's folder
    survives and A publishes; K's folder and lock go; every point equals a serial build with its own cache."""
    shared = tmp_path / "shared"
    procs = []
    try:
        k = _ns_start(tmp_path, _point("k", 1, "store:cards"), pad=40)
        procs.append(k)
        wait_for_line(k, "paused after store:cards")
        os.killpg(k.pid, signal.SIGKILL)  # mid-point: its cards folder half-way to the cache, its lock file held
        k.wait(10)
        assert len(list(shared.glob("cards/.tmp-*"))) == 1 and list(shared.glob("cards/.lock-*"))
        release = tmp_path / "release-a"
        a = _ns_start(tmp_path, _point("a", 2, "store:cards", release), pad=60)
        procs.append(a)
        wait_for_line(a, "paused after store:cards")
        (a_tmp,) = shared.glob("cards/.tmp-*")  # A's own (A's build, at its start, cleaned K's: K is dead)
        b = subprocess.run(_in_namespace(_point("b", 3), 0), cwd=tmp_path, env=ENV, capture_output=True, text=True,
                           timeout=60)
        assert b.returncode == 0, b.stderr
        assert list(shared.glob("cards/.tmp-*")) == [a_tmp] and (a_tmp / "value").is_dir()  # A's work is kept
        owner = json.loads((a_tmp / ".owner").read_text())  # who writes it, beyond a pid
        assert owner["host"] == os.uname().nodename and owner["pid_ns"] != os.readlink("/proc/self/ns/pid")
        assert owner["boot_id"] == Path("/proc/sys/kernel/random/boot_id").read_text().strip()
        release.touch()
        _, err = a.communicate(timeout=60)
        assert a.returncode == 0, err
    finally:  # a failed assertion leaves no paused writer behind (each is the leader of its session)
        for p in procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(10)
    again = subprocess.run(_in_namespace(_point("k", 1), 20), cwd=tmp_path, env=ENV, capture_output=True,
                           text=True, timeout=60)
    assert again.returncode == 0, again.stderr
    assert not list(shared.glob("*/.tmp-*")) and not list(shared.glob("*/.lock-*"))
    for name, seed in (("k", 1), ("a", 2), ("b", 3)):
        serial = subprocess.run([sys.executable, LAUNCHER, "--standin", "--", "build", "--out", f"serial/{name}",
                                 *_CHEAP, "--set", f"geometry.seed={seed}", "--quiet"],
                                cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=60)
        assert serial.returncode == 0, serial.stderr
        assert snapshot(tmp_path / "pts" / name) == snapshot(tmp_path / "serial" / name), name


def test_lock_files_left_by_killed_builds_are_cleaned_and_a_held_lock_is_not(tmp_path):
    """Issue 23: `.lock-*` files piled up in the cache after kills. A lock nobody holds is removed by the next
    build's clean; a held one stays, and a waiter whose lock file was removed under it locks the new one."""
    from rockdove.graph.engine import Cache

    cache = Cache(tmp_path)
    (tmp_path / "lut").mkdir()
    (tmp_path / "lut" / ".lock-dead").write_text("")  # a holder killed while computing
    with cache.entry_lock("lut", "live"):
        cache.clean_temporaries()
        assert sorted(p.name for p in (tmp_path / "lut").iterdir()) == [".lock-live"]
    assert list((tmp_path / "lut").iterdir()) == []


def _writer(folder: Path, then: str) -> subprocess.Popen:
    """A process holding a cache temporary of its own (Cache.temporary) in ``folder``'s cache: it then sleeps
    (a live writer) or exits unwaited for (a zombie until the test reaps it: a killed Dask worker's state)."""
    code = ("import sys, time; from rockdove.graph.engine import Cache; from pathlib import Path\n"
            "with Cache(sys.argv[1]).temporary(Path(sys.argv[1]) / 'lut') as t:\n"
            "    print(t, flush=True); time.sleep(60 if sys.argv[2] == 'live' else 0)\n    import os; os._exit(0)")
    return subprocess.Popen([sys.executable, "-c", code, str(folder), then], stdout=subprocess.PIPE, text=True)


def test_clean_temporaries_spares_live_writers_and_removes_dead_ones(tmp_path):
    from rockdove.graph.engine import Cache

    cache = Cache(tmp_path)
    live, zombie = _writer(tmp_path, "live"), _writer(tmp_path, "exit")
    try:
        live_tmp, zombie_tmp = Path(live.stdout.readline().strip()), Path(zombie.stdout.readline().strip())
        t0 = time.monotonic()
        while Path(f"/proc/{zombie.pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z":
            assert time.monotonic() - t0 < 30
            time.sleep(0.02)
        young, old = tmp_path / "lut" / ".tmp-h-1-young", tmp_path / "lut" / ".tmp-h-1-old"  # no .owner (yet)
        young.mkdir()
        old.mkdir()
        os.utime(old, (time.time() - 7200,) * 2)
        with cache.temporary(tmp_path / "lut") as mine:  # this thread's own, as another thread's would be
            cache.clean_temporaries()
            assert mine.exists()
        assert live_tmp.exists() and young.exists() and not zombie_tmp.exists() and not old.exists()
    finally:
        live.kill()
        live.wait()
        zombie.wait()


# ----------------------------------------------------------------------------------------------- memory
@pytest.mark.parametrize("argv, words", [
    # issue 23: inside the old ranges, these passed 8.5 GB (body texture) and 4 GB (LUT) of RSS
    (["build", "--out", "b", "--set", "textures.body_resolution=8192"], ["textures.body_resolution", "<= 4096"]),
    (["lut", "--out", "l.exr", "--angles", "16000", "--thicknesses", "16000"], ["--angles", "[2, 4096]", "16000"]),
    (["lut", "--out", "l.exr", "--thicknesses", "4097"], ["--thicknesses", "[1, 4096]"]),
    # a 4096 px verification passed 8.3 GB, a 2048 px one 5.3 GB
    (["build", "--out", "b", "--set", "verify.width=4096"], ["verify.width", "<= 1024"]),
    (["verify", "b", "--height", "4096"], ["--height", "from 16 to 1024"]),
    # 64 views at 1024 px passed 5.2 GB (a verification's memory grows with its views)
    (["build", "--out", "b", "--set", "verify.views=64"], ["verify.views", "<= 16"]),
    # an 8192 px render passed 8.6 GB; every view's buffers were kept until all were rendered
    (["render", "b", "--out", "r", "--width", "8192", "--supersample", "1"], ["--width x --supersample", "4096"]),
    (["render", "b", "--out", "r", "--height", "2048", "--supersample", "4"], ["--height x --supersample", "4096"]),
    (["render", "b", "--out", "r", "--views", "1000"], ["--views x --width x --height", "1000 x 512 x 512"]),
])
def test_sizes_past_the_memory_budget_exit_2_naming_the_key_and_range(tmp_path, argv, words):
    r = subprocess.run([sys.executable, "-m", "rockdove.cli", *argv], cwd=tmp_path, env=ENV, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and all(w in r.stderr for w in words), r.stderr
    assert list(tmp_path.iterdir()) == []


def test_the_lut_bakers_limits_are_the_schemas():
    from rockdove.config import load_schema
    from rockdove.lut.bake import MAX_ANGLES, MAX_THICKNESSES

    lut = load_schema()["properties"]["lut"]["properties"]
    assert (lut["angles"]["maximum"], lut["thicknesses"]["maximum"]) == (MAX_ANGLES, MAX_THICKNESSES)

"""The verification's worker process (rockdove.verify.worker): results, errors, a dead worker, large messages
both ways, a clean stdout, and GL renders identical to the ones made in this process."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

from rockdove.verify import worker


@pytest.fixture
def w():
    wk = worker.Worker(preload=())
    yield wk
    wk.close()


def test_a_call_runs_in_another_process_and_arrays_come_back_equal_and_writable(w):
    assert w.call("os:getpid") not in (os.getpid(), None)
    a = w.call("numpy:arange", 0, 2_000_000, 1, "float32")  # 8 MB: out of band
    assert a.dtype == np.float32 and a.shape == (2_000_000,) and a[-1] == 1_999_999
    a[0] = 7  # writable: callers may edit results in place
    assert w.call("numpy:sum", np.full((100, 100), 2.0)) == 20000.0  # an array argument


def test_an_exception_in_the_worker_is_a_remote_error_naming_it_and_the_worker_goes_on(w):
    with pytest.raises(worker.RemoteError, match=r"math:sqrt failed .*ValueError: math domain error"):
        w.call("math:sqrt", -1.0)
    assert w.call("math:sqrt", 4.0) == 2.0


def test_a_killed_worker_fails_its_requests_with_its_exit_status_and_shared_restarts_it():
    first = worker.shared()
    pid = first.call("os:getpid")
    pending = first.submit("time:sleep", 30)
    os.kill(pid, signal.SIGKILL)
    with pytest.raises(worker.WorkerFailed, match=r"exited with status -9"):
        pending.result()
    assert not first.alive
    again = worker.shared()
    assert again is not first and again.alive and again.call("os:getpid") != pid


def test_a_large_request_sent_while_a_large_reply_is_unread_does_not_block(w):
    big_reply = w.submit("numpy:ones", (4096, 4096))  # 128 MB back, not read yet
    done = {}

    def second():
        done["sum"] = w.call("numpy:sum", np.ones((2048, 2048)))  # 32 MB out

    t = threading.Thread(target=second, daemon=True)
    t.start()
    t.join(timeout=60)
    assert not t.is_alive(), "the second request blocked behind the unread reply"
    assert done["sum"] == 2048 * 2048
    assert big_reply.result().shape == (4096, 4096)


def test_what_the_worker_prints_goes_to_stderr_not_to_the_callers_stdout():
    code = ("import json; from rockdove.verify import worker; "
            "worker.shared().call('builtins:print', 'from-the-worker'); print(json.dumps({'ok': 1}))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert json.loads(r.stdout) == {"ok": 1}
    assert "from-the-worker" in r.stderr


def test_gl_renders_from_the_worker_equal_the_ones_made_here(small_asset):
    from rockdove.render.gl import render_views
    from rockdove.verify.inputs import verification_scene, verification_views

    layer, scene, lut, _ = verification_scene(small_asset)
    every = verification_views(scene, 48, 32, 3)
    views = [every[0], every[-1]]  # a turntable frame and the hero (twice the size)
    assert views[1].width == 2 * views[0].width
    here = render_views(scene, views, lut=lut)
    renders = worker.GLRenders(scene, views[::-1], lut)  # the other order, opened at the hero's size
    there = [renders.result(i) for i in range(len(views))][::-1]
    assert all(seconds > 0 for _, seconds in there)
    for a, (b, _) in zip(here, there):
        assert a.view == b.view and a.part_names == b.part_names
        for name in ("radiance_rgb", "alpha", "part_id", "depth_m", "cos_theta", "thickness_nm", "mask", "st"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_gl_renders_that_cannot_open_fail_every_view_with_the_opening_error():
    from rockdove.render.views import View

    view = View(name="v", camera_to_world=np.eye(4), yfov_rad=0.6, width=16, height=16,
                light_direction=np.array([0.0, 0.0, 1.0]), light_rgb=np.ones(3))
    renders = worker.GLRenders("not a scene", [view, view], None)
    for i in range(2):
        with pytest.raises(worker.RemoteError, match=r"gl_open failed .*scene must be a RenderScene"):
            renders.result(i)
    assert worker.shared().call("os:getpid") > 0  # the worker serves on


def test_the_worker_exits_when_its_caller_is_killed():
    code = ("import os, sys; from rockdove.verify import worker; w = worker.shared(); "
            "print(w.call('os:getpid'), flush=True); sys.stdin.read()")
    caller = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        pid = int(caller.stdout.readline())
        os.kill(pid, 0)  # alive
        caller.kill()  # SIGKILL: no atexit, the socket just closes
        caller.wait(timeout=30)
        for _ in range(100):
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            threading.Event().wait(0.1)
            if _process_state(pid) == "Z":  # exited, waiting to be reaped by init
                break
        else:
            pytest.fail(f"the worker (pid {pid}) outlived its killed caller by 10 s")
    finally:
        caller.kill()


def _process_state(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0]
    except OSError:
        return "gone"


def test_a_forked_child_starts_a_worker_of_its_own_and_its_exit_leaves_its_parents_alone():
    # in a script of its own: the child exits normally, running its atexit handlers (which must not stop the
    # parent's worker)
    code = """if True:
        import os, sys
        from rockdove.verify import worker
        first = worker.shared()
        mine = first.call("os:getpid")
        pid = os.fork()
        if pid == 0:  # a child that never renders: its exit must not stop the parent's worker
            sys.exit(0)
        os.waitpid(pid, 0)
        pid = os.fork()
        if pid == 0:  # a child that renders: a worker of its own
            print("child", worker.shared().call("os:getpid"), flush=True)
            sys.exit(0)
        os.waitpid(pid, 0)
        assert worker.shared() is first
        print("parent", mine, first.call("os:getpid"), flush=True)
    """
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    lines = dict(line.split(" ", 1) for line in r.stdout.splitlines())
    parent_before, parent_after = lines["parent"].split()
    assert parent_before == parent_after != lines["child"]


def test_a_validation_the_worker_could_not_run_runs_here_and_one_that_raised_there_fails(small_asset):
    from rockdove.verify import verdict
    from rockdove.verify.inputs import verification_scene

    layer = verification_scene(small_asset)[0]
    gone = worker.Pending.failed("rockdove.verify.worker:validate_timed", worker.WorkerFailed("the worker exited"))
    validation, seconds = verdict._validation(gone, layer)
    assert validation["passed"] and validation["error"] is None and seconds > 0  # ran in this process
    raised = worker.Pending.failed("rockdove.verify.worker:validate_timed", worker.RemoteError("OSError: boom"))
    validation, _ = verdict._validation(raised, layer)
    assert not validation["passed"] and "boom" in validation["error"]


def test_a_started_validation_is_taken_once_and_a_changed_asset_is_validated_anew(small_asset, tmp_path):
    import shutil

    from rockdove.verify import verdict
    from rockdove.verify.inputs import verification_scene

    asset = tmp_path / "pigeon"
    shutil.copytree(small_asset, asset, ignore=shutil.ignore_patterns("verify"))
    layer = verification_scene(asset)[0]
    verdict.start_validation(layer)
    verdict.start_validation(layer)  # the same files: not sent twice
    started = verdict._VALIDATIONS[verdict._asset_state(layer)]
    assert verdict._take_validation(layer) is started
    assert verdict._asset_state(layer) not in verdict._VALIDATIONS
    verdict.start_validation(layer)
    old_key = verdict._asset_state(layer)
    old = verdict._VALIDATIONS[old_key]
    (asset / "pigeon.usda").write_text((asset / "pigeon.usda").read_text() + "\n")
    fresh = verdict._take_validation(layer)
    assert fresh is not old and fresh.result()[0]["passed"]
    assert verdict._VALIDATIONS.pop(old_key) is old  # left for its own (now stale) files

"""``rockdove sweep`` on Dask: the grid syntax, a sweep against a real external ``dask scheduler`` with two
``dask worker`` processes on 127.0.0.1 (shared cache, byte-identical points, an invalid point failing alone, a
worker killed mid-point), and the LocalCluster default with verification and the index page.

Points are made cheap with --set (a coarse body, few cards, tiny textures and LUT, no usdz); they share one
stage cache per cluster so the body is built once.
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

from rockdove.commands import sweep as S
from rockdove.errors import UsageError

BIN = Path(sys.executable).parent
CHEAP = ["geometry.body_voxel_m=0.01", "geometry.card_count=60", "textures.feather_resolution=32",
         "textures.body_resolution=32", "lut.angles=32", "lut.thicknesses=8", "usd.usdz=false", "beauty.width=128",
         "beauty.height=96"]
CHEAP_ARGS = [a for s in CHEAP for a in ("--set", s)]


def rockdove(*args, cwd, timeout=300):
    env = {**os.environ, "PYOPENGL_PLATFORM": "egl"}
    env.pop("ROCKDOVE_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "rockdove.cli", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout)


def _files(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# ----------------------------------------------------------------------------------------------- the grid
def test_grid_values_are_toml_literals_as_set_takes_them_and_make_a_product():
    axes = S.parse_grid(["film.cauchy_a=[1.5, 1.55]", 'film.model=[keratin, "paper"]',
                         "thickness.base_nm=[[480, 580], [500, 600],]"])
    assert [k for k, _ in axes] == ["film.cauchy_a", "film.model", "thickness.base_nm"]
    assert [v for _, v in axes[1][1]] == ["keratin", "paper"] and axes[2][1][1][1] == [500, 600]
    points = S.grid_points(axes)
    assert len(points) == 8 and len({p.name for p in points}) == 8
    p = points[-1]
    assert p.overrides == ("film.cauchy_a=1.55", 'film.model="paper"', "thickness.base_nm=[500, 600]")
    assert p.name == "film.cauchy_a=1.55__film.model=paper__thickness.base_nm=500_600" and p.index == (1, 1, 1)
    # names are stable (a function of the point alone) and two points that would read the same get a hash
    same = S.grid_points(S.parse_grid(['film.model=["a b", "a_b"]']))
    assert same[0].name != same[1].name and all(n.name.startswith("film.model=a_b-") for n in same)


@pytest.mark.parametrize("grid, words", [
    (["film.cauchy_a=1.5"], ["not a [list]"]),
    (["film.cauchy_a"], ["not KEY=[V1, V2, ...]"]),
    (["film.cauchy_a=[1.5, 1.5]"], ["given twice"]),
    (["film.cauchy_a=[1.5", ], ["not a [list]"]),
    (["film.cauchy_a=[1.5,, 1.6]"], ["empty value"]),
    (["film.cauchy_a=[]"], ["empty"]),
    (["film.nope=[1]"], ["unknown key 'film.nope'"]),
    (["film=[1]"], ["section"]),
    (["film.cauchy_a=[1.5]", "film.cauchy_a=[1.6]"], ["given twice"]),
    (["film.model=[\"x]"], ["unclosed"]),
    ([], ["no --grid"]),
])
def test_bad_grid_is_a_usage_error_naming_it(grid, words):
    with pytest.raises(UsageError) as e:
        S.parse_grid(grid)
    assert all(w in str(e.value) for w in words), str(e.value)


@pytest.mark.parametrize("grid", ["geometry.seed=[3, 3.0]", "film.cauchy_a=[0.0, -0.0]",
                                  "thickness.base_nm=[[600, 700], [600.0, 700.0]]"])
def test_one_value_in_two_spellings_is_a_repeated_value(grid):
    """One canonical value per point: numbers are compared as numbers (issue 33)."""
    with pytest.raises(UsageError, match="given twice"):
        S.parse_grid([grid])


def test_point_folders_cannot_collide():
    """A value that reads like another point's hashed name gets a hash of its own, so no two points share a
    folder (issue 33: the last one won it while sweep.json reported the first there)."""
    import hashlib

    h = hashlib.sha256(b'film.model="a b"').hexdigest()[:8]
    for grid in (f'film.model=["a b", "a_b", "a_b-{h}"]', 'film.model=["Ab", "aB"]'):
        names = [p.name.lower() for p in S.grid_points(S.parse_grid([grid]))]
        assert len(set(names)) == len(names), names


def test_point_records_write_the_keys_of_sweep_json_in_order_and_only_those_known():
    """A record writes its grid point and status, then only what is known; a built point always has verify, build
    and images (verify null when built without it); a report's summary keeps a missing dE as null."""
    from dataclasses import replace

    (p,) = S.grid_points(S.parse_grid(["film.cauchy_a=[1.5]"]))
    rec = S.PointRecord(p.name, p.index, p.overrides, p.values, "points/x")
    head = ["name", "index", "overrides", "values", "asset", "status"]
    assert list(rec.to_json()) == head and rec.to_json()["index"] == [0]
    assert list(replace(rec, status="invalid", error="bad", seconds=0.0).to_json()) == [*head, "error", "seconds"]
    built = replace(rec, status="ok", config_hash="h", pid=1, worker="w", seconds=1.0, build={"ran": []},
                    images=S.Images(preview="p.png"))
    doc = built.to_json()
    assert list(doc) == [*head, "config_hash", "pid", "worker", "seconds", "verify", "build", "images"]
    assert doc["verify"] is None and doc["images"] == {"preview": "p.png"} and S.Images().to_json() == {}
    assert S.Images(("s.png",)).to_json() == {"sweep": ["s.png"], "hue": None}
    assert S.Verified(True, ("n",)).to_json() == {"passed": True, "notes": ["n"]}
    v = S.Verified(False, (), ("f",), None, None, {"green": 1}).to_json()
    assert list(v) == ["passed", "notes", "failures", "median_dE", "p95_dE", "hue"] and v["median_dE"] is None


def test_bad_grid_exits_2_before_anything_runs(tmp_path):
    r = rockdove("sweep", "--out", "s", "--grid", "film.cauchy_a=[1.5, 1.6]", "--grid", "lut.angles=[32 64]",
                 cwd=tmp_path, timeout=60)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "lut.angles" in r.stderr, r.stderr
    assert not (tmp_path / "s").exists()
    r = rockdove("sweep", "--out", "s", "--grid", "film.cauchy_a=[1.5]", "--scheduler", "tcp://127.0.0.1:1",
                 "--workers", "2", cwd=tmp_path, timeout=60)
    assert r.returncode == 2 and "--workers" in r.stderr and not (tmp_path / "s").exists()


@pytest.fixture(scope="module")
def shared_cache(tmp_path_factory):
    """One stage cache for the module's sweeps (as a lab would keep one): the coarse body is built once."""
    return str(tmp_path_factory.mktemp("sweep-cache"))


# ----------------------------------------------------------------------------------------------- external cluster
@pytest.fixture(scope="module")
def dask_cluster(tmp_path_factory):
    """A real ``dask scheduler`` and two ``dask worker`` processes (one thread each) on 127.0.0.1."""
    d = tmp_path_factory.mktemp("dask")
    env = {**os.environ, "PYOPENGL_PLATFORM": "egl"}
    sched_file = d / "scheduler.json"
    common = dict(cwd=d, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    procs = {"scheduler": subprocess.Popen([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
                                            "--no-dashboard", "--scheduler-file", str(sched_file)], **common)}
    try:
        t0 = time.monotonic()
        while not sched_file.exists() and time.monotonic() - t0 < 60:
            time.sleep(0.2)
        address = json.loads(sched_file.read_text())["address"]
        for name in ("w1", "w2"):
            procs[name] = subprocess.Popen([str(BIN / "dask"), "worker", address, "--host", "127.0.0.1",
                                            "--nthreads", "1", "--nworkers", "1", "--name", name, "--no-dashboard"],
                                           **common)
        from distributed import Client

        with Client(address, timeout="30s") as c:
            c.wait_for_workers(2, timeout=90)
        yield {"address": address, "procs": procs, "dir": d}
    finally:
        for p in procs.values():
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in procs.values():
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)


def test_sweep_on_external_scheduler_shares_cache_matches_serial_build_and_fails_invalid_point_alone(
        dask_cluster, tmp_path):
    # its own cache, so that the body is built during this sweep (by one point only)
    r = rockdove("sweep", "--out", "s", "--scheduler", dask_cluster["address"], "--no-verify", "--json",
                 "--grid", "film.cauchy_a=[1.5, 1.6, 0.5]", *CHEAP_ARGS, cwd=tmp_path)
    assert r.returncode == 1, r.stderr  # the invalid point fails, after the others finished
    doc = json.loads(r.stdout)
    assert doc == json.loads((tmp_path / "s/sweep.json").read_text())
    assert doc["state"] == "finished" and doc["done"] == doc["total"] == 3 and doc["workers"] == 2
    pts = {p["name"]: p for p in doc["points"]}
    bad = pts["film.cauchy_a=0.5"]
    assert bad["status"] == "invalid" and "film.cauchy_a" in bad["error"] and ">= 1" in bad["error"]
    ok = [pts["film.cauchy_a=1.5"], pts["film.cauchy_a=1.6"]]
    assert all(p["status"] == "ok" and p["seconds"] > 0 and len(p["config_hash"]) == 64 for p in ok)
    assert all(p["worker"].startswith("tcp://127.0.0.1:") for p in ok)
    # the shared cache: the body (geometry alone) was built by one point and reused by the other
    ran_body = [p["name"] for p in ok if "body" in p["build"]["ran"]]
    assert len(ran_body) == 1 and all("body" in p["build"]["ran"] + p["build"]["reused"] for p in ok)
    assert not (tmp_path / "s/points/film.cauchy_a=0.5").exists()
    # each point is byte-identical to a serial rockdove build with the same overrides (its own fresh cache)
    serial = rockdove("build", "--out", "serial/p", "--no-verify", "--quiet", *CHEAP_ARGS,
                      "--set", "film.cauchy_a=1.6", cwd=tmp_path)
    assert serial.returncode == 0, serial.stderr
    assert _files(tmp_path / "serial/p") == _files(tmp_path / "s/points/film.cauchy_a=1.6")
    assert _files(tmp_path / "serial/p") != _files(tmp_path / "s/points/film.cauchy_a=1.5")
    page = (tmp_path / "s/index.html").read_text()
    assert "refresh" not in page and "film.cauchy_a = 1.6" in page and "feather_preview.png" in page


def test_worker_killed_mid_point_is_retried_on_another_worker(dask_cluster, tmp_path):
    """SIGKILL the whole `dask worker` (nanny and process) running a point: Dask reschedules the point on the
    other worker and the sweep completes; the killed build left no half-written asset."""
    from distributed import Client

    proc = subprocess.Popen([sys.executable, "-m", "rockdove.cli", "sweep", "--out", "s", "--scheduler",
                             dask_cluster["address"], "--no-verify", "--grid", "geometry.seed=[1]", *CHEAP_ARGS,
                             "--cache", "cache"],
                            cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        with Client(dask_cluster["address"], timeout="30s") as c:
            # mid-point: the build has taken the lock of the body entry it is computing (fresh cache)
            t0 = time.monotonic()
            while not list((tmp_path / "cache").glob("body/.lock-*")) and time.monotonic() - t0 < 120:
                time.sleep(0.02)
            busy = [w for w, ts in c.processing().items() if ts]
            assert len(busy) == 1, "the point never started"
            victim = busy[0]
            name = c.scheduler_info(n_workers=-1)["workers"][victim]["name"]
            os.killpg(dask_cluster["procs"][name].pid, signal.SIGKILL)
        out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    (p,) = json.loads((tmp_path / "s/sweep.json").read_text())["points"]
    assert p["status"] == "ok" and p["worker"] != victim
    assert (tmp_path / "s/points/geometry.seed=1/pigeon.usda").is_file()
    assert not [q for q in (tmp_path / "s/points").iterdir() if "rockdove-tmp" in q.name]
    assert not list((tmp_path / "cache").glob("*/.tmp-*"))  # the killed build's temporaries were cleaned


# ----------------------------------------------------------------------------------------------- local cluster
def test_local_cluster_default_verifies_points_and_lays_out_the_index(tmp_path, shared_cache):
    # enough cards, LUT texels and pixels for the verification to pass: the default LUT, 600 cards, 128 px
    sets = [s for s in CHEAP if not s.startswith(("geometry.card_count", "lut."))]
    sets += ["geometry.card_count=600", "verify.width=128", "verify.height=128", "verify.views=2"]
    r = rockdove("sweep", "--out", "s", "--workers", "2", "--grid", "film.cauchy_a=[1.5, 1.6]",
                 "--grid", "geometry.seed=[0]", *[a for s in sets for a in ("--set", s)], "--cache", shared_cache,
                 cwd=tmp_path)
    doc = json.loads((tmp_path / "s/sweep.json").read_text())
    assert r.returncode == 0, (r.stderr, doc)
    assert doc["scheduler"].startswith("tls://127.0.0.1") and doc["workers"] == 2 and doc["verify"] is True
    for p in doc["points"]:
        assert p["status"] == "ok" and p["verify"]["passed"] is True and p["verify"]["hue"]["green"] > 0
        assert p["images"]["sweep"] and p["images"]["hue"]
        assert (tmp_path / "s" / p["asset"] / "verify/report.json").is_file()
    page = (tmp_path / "s/index.html").read_text()
    assert page.count("<td>") == 2 and "geometry.seed = 0" in page and "film.cauchy_a = 1.5" in page
    assert page.count("hue.png") == 2 and page.count("sweep_") >= 2 and "<progress" in page


# ----------------------------------------------------------------------------------------------- privacy
def _ns(**kw):
    import argparse

    return argparse.Namespace(**{"scheduler": None, "security": None, "workers": 1, **kw})


def _pems(sec, folder: Path) -> dict:
    """Write a Security's in-memory PEM texts to files (as a cluster's admin would hand them out)."""
    paths = {}
    for name in ("tls_ca_file", "tls_client_cert", "tls_client_key"):
        paths[name] = folder / f"{name}.pem"
        paths[name].write_text(getattr(sec, name))
    return paths


@pytest.fixture(scope="module")
def private_cluster():
    """The cluster a local sweep starts (one worker), and its client."""
    client, cluster = S._client(_ns())
    try:
        yield client, cluster
    finally:
        client.close()
        cluster.close()


def test_local_cluster_is_private_a_client_without_its_certificate_cannot_submit(private_cluster, tmp_path):
    """Issue 23: another local user who found the sweep's port ran code as the sweep's user. The sweep's
    cluster speaks TLS with a certificate of its own: a plain TCP client and a TLS client with another
    certificate both fail to connect; the sweep's own client runs work."""
    from distributed import Client
    from distributed.security import Security

    client, cluster = private_cluster
    address = cluster.scheduler_address
    assert address.startswith("tls://127.0.0.1:"), address
    assert client.submit(os.getpid, pure=False).result(timeout=60) != os.getpid()  # with them it runs
    marker = tmp_path / "ran"
    for kw in (dict(address=address.replace("tls://", "tcp://")), dict(address=address, security=Security.temporary())):
        with pytest.raises(Exception):  # noqa: B017 - refused by the handshake, whatever the exception
            with Client(**kw, timeout="3s") as intruder:
                intruder.submit(marker.write_text, "pwned", pure=False).result(timeout=10)
    assert not marker.exists()


def test_external_tls_cluster_takes_a_security_file_and_refuses_without_one(private_cluster, tmp_path):
    """--scheduler tls://... as a studio's TLS cluster: the credentials come from --security FILE (here the
    private cluster's own, written out as an admin would hand them out)."""
    import yaml

    address = private_cluster[1].scheduler_address
    pem = _pems(private_cluster[1].security, tmp_path)
    with pytest.raises(UsageError, match="uses TLS: give --security FILE"):
        S._client(_ns(scheduler=address, workers=None))
    conf = tmp_path / "tls.yaml"
    conf.write_text(yaml.safe_dump({"distributed": {"comm": {"require-encryption": True, "tls": {
        "ca-file": str(pem["tls_ca_file"]),
        "client": {"cert": str(pem["tls_client_cert"]), "key": str(pem["tls_client_key"])}}}}}))
    client, none = S._client(_ns(scheduler=address, security=str(conf), workers=None))
    try:
        assert none is None and client.submit(sum, [1, 2]).result(timeout=60) == 3
    finally:
        client.close()
    (tmp_path / "bad.yaml").write_text("distributed: {}\n")
    with pytest.raises(UsageError, match="not a Dask configuration with distributed.comm.tls"):
        S._client(_ns(scheduler=address, security=str(tmp_path / "bad.yaml"), workers=None))
    with pytest.raises(UsageError, match="--security applies to --scheduler only"):
        S._client(_ns(security=str(conf)))

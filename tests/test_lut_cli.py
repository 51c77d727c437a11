"""``rockdove lut`` and ``rockdove bench lut`` as a user runs them (subprocess)."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import OUTSIDE

from rockdove.lut import read_exr


def _rockdove(*args, cwd=None):
    env = dict(os.environ)
    env.pop("ROCKDOVE_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "rockdove.cli", *args], cwd=cwd or OUTSIDE, env=env,
                          capture_output=True, text=True, timeout=120)


def test_lut_command_writes_exr_and_preview(tmp_path):
    out = tmp_path / "sub" / "lut.exr"
    res = _rockdove("lut", "--out", str(out), "--angles", "48", "--thicknesses", "5", "--angle-gamma", "1.5",
                    "--error-points", "150")
    assert res.returncode == 0, res.stderr
    assert str(out) in res.stdout
    assert "5 x 48 texels (240)" in res.stdout and "max dE2000" in res.stdout
    assert out.is_file() and (tmp_path / "sub" / "lut.png").is_file()
    assert sorted(os.listdir(out.parent)) == ["lut.exr", "lut.png"]  # no temporary files left behind
    lut = read_exr(out)
    assert lut.rgb.shape == (5, 48, 3) and lut.angle_warp_gamma == 1.5
    assert lut.metadata["method"] == "fourier" and float(lut.metadata["estimatedMaxDeltaE2000"]) > 0
    assert "150 random points" in lut.metadata["estimatedErrorSample"]


def test_lut_command_one_texel_high_keratin(tmp_path):
    out = tmp_path / "one.exr"
    res = _rockdove("lut", "--out", str(out), "--angles", "32", "--thickness-range", "650", "650",
                    "--film", "keratin", "--error-points", "0")
    assert res.returncode == 0, res.stderr
    lut = read_exr(out)
    assert lut.rgb.shape == (1, 32, 3) and lut.thickness_range_nm == (650.0, 650.0)
    assert lut.metadata["film"] == "keratin"


def test_same_arguments_give_identical_files(tmp_path):
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    for p in (a, b):
        assert _rockdove("lut", "--out", str(p), "--angles", "16", "--thicknesses", "3",
                         "--error-points", "20").returncode == 0
    assert a.read_bytes() == b.read_bytes()
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


@pytest.mark.parametrize(
    "args, word",
    [
        (["--angles", "1"], "--angles"),
        (["--thicknesses", "0"], "--thicknesses"),
        (["--thickness-range", "700", "480"], "--thickness-range"),
        (["--film", "glass"], "--film"),
        (["--method", "magic"], "--method"),
        (["--angle-gamma", "-1"], "--angle-gamma"),
        (["--colour-space", "srgb"], "--colour-space"),
        (["--angles", "many"], "--angles"),
        (["--error-points", "-1"], "--error-points"),
    ],
)
def test_bad_lut_arguments_exit_2_with_one_line_and_write_nothing(tmp_path, args, word):
    out = tmp_path / "bad" / "lut.exr"
    res = _rockdove("lut", "--out", str(out), *args)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and word in lines[0], res.stderr
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "bad").exists()


def test_out_must_be_an_exr_path(tmp_path):
    res = _rockdove("lut", "--out", str(tmp_path / "lut.png"))
    assert res.returncode == 2 and "--out" in res.stderr and "Traceback" not in res.stderr
    assert os.listdir(tmp_path) == []


def test_bench_lut_quick_writes_table_json_and_plot(tmp_path):
    res = _rockdove("bench", "lut", "--quick", "--out", str(tmp_path), "--points", "100")
    assert res.returncode == 0, res.stderr
    assert "spectral 1 nm (straightforward)" in res.stdout and "speed ratio" in res.stdout
    data = json.loads((tmp_path / "lut_bench.json").read_text())
    rows = data["rows"]
    assert any(r["baseline"] for r in rows) and any(r["default"] for r in rows)
    assert all(r["time_s"] > 0 and np.isfinite(r["max_dE"]) for r in rows)
    assert "speed_ratio" in data["summary"]["paper"]
    assert (tmp_path / "lut_bench.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

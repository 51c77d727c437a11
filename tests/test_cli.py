"""The ``build`` and ``config`` commands through the real CLI (subprocess): bad inputs and the happy paths.

Every bad input must exit 2 with exactly one line on stderr naming the problem, no traceback, and write
nothing (no output folder, lock file or cache). Most builds here run the real command with the stand-in stages of
tests/standins.py patched in by tests/launcher.py, so they test the command and the framework in a fraction of a
second each; the physical-only and --cache builds and the last test run the real stages.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

LAUNCHER = str(Path(__file__).with_name("launcher.py"))


def rockdove(*args, cwd, standin=True, timeout=60):
    """``rockdove ARGS`` in a fresh interpreter: the stand-in stages, or the real ones with ``standin=False``."""
    env = {k: v for k, v in os.environ.items() if k != "ROCKDOVE_DEBUG"}
    cmd = [sys.executable, LAUNCHER, *(["--standin"] if standin else []), "--", *args]
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def _tree(folder: Path) -> set:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def _setup(tmp: Path) -> None:
    (tmp / "malformed.toml").write_text("[lut\nangles = 3\n")
    (tmp / "unknown.toml").write_text("[lut]\nangels = 128\n")
    (tmp / "wrongtype.toml").write_text("[geometry]\ncard_count = \"many\"\n")
    (tmp / "adir.toml").mkdir()
    (tmp / "afile").write_text("not a folder\n")
    (tmp / "foreign").mkdir()
    (tmp / "foreign" / "precious.txt").write_text("user data\n")


BAD = [
    # (id, args, words the one-line message must contain)
    ("unknown-key", ["--set", "lut.nope=1"], ["lut.nope", "unknown"]),
    ("unknown-section", ["--set", "nope.x=1"], ["nope", "unknown"]),
    ("wrong-type-string", ["--set", 'lut.angles="many"'], ["lut.angles", "many", "integer"]),
    ("below-minimum", ["--set", "lut.angles=1"], ["lut.angles", "1", ">= 2"]),
    ("above-maximum", ["--set", "lut.angles=100000"], ["lut.angles", "100000", "<= 4096"]),
    ("empty-range", ["--set", "thickness.base_nm=[]"], ["thickness.base_nm", "[]", "too few"]),
    ("min-above-max", ["--set", "thickness.base_nm=[600, 500]"], ["thickness.base_nm", "lo > hi"]),
    ("range-item-out-of-range", ["--set", "thickness.top_nm=[0, 700]"], ["thickness.top_nm[0]", "0", ">= 1"]),
    ("range-too-long", ["--set", "thickness.top_nm=[600, 700, 800]"], ["thickness.top_nm", "too many"]),
    ("bad-enum-film", ["--set", "film.model=glass"], ["film.model", "glass", '"keratin"']),
    ("index-below-one", ["--set", "film.cauchy_a=0.5"], ["film.cauchy_a", "0.5", ">= 1"]),
    ("negative-index", ["--set", "film.n_substrate=-1"], ["film.n_substrate", "-1"]),
    ("bad-precision", ["--set", "lut.precision=double"], ["lut.precision", "double", "half"]),
    ("bad-colour-space", ["--set", "lut.colour_space=srgb"], ["lut.colour_space", "srgb", "lin_rec709"]),
    ("acescg-asset", ["--set", "lut.colour_space=acescg"], ["lut.colour_space", "acescg", "lin_rec709"]),
    ("bad-shading", ["--set", "shading.variant=none"], ["shading.variant", "none", "physical"]),
    ("zero-width", ["--set", "verify.width=0"], ["verify.width", "0", ">= 16"]),
    ("negative-seed", ["--set", "geometry.seed=-1"], ["geometry.seed", "-1", ">= 0"]),
    ("zero-cards", ["--set", "geometry.card_count=0"], ["geometry.card_count", "0", ">= 1"]),
    ("fractional-cards", ["--set", "geometry.card_count=2.5"], ["geometry.card_count", "2.5", "integer"]),
    ("int-for-bool", ["--set", "usd.usdz=1"], ["usd.usdz", "1", "boolean"]),
    ("section-not-table", ["--set", "lut=3"], ["lut", "3", "table"]),
    ("card-length-reversed", ["--set", "geometry.card_length_m=[0.02, 0.01]"], ["geometry.card_length_m", "lo > hi"]),
    ("gamma-zero", ["--set", "lut.angle_warp_gamma=0"], ["lut.angle_warp_gamma", "> 0"]),
    ("set-without-equals", ["--set", "lut.angles"], ["lut.angles", "KEY=VALUE"]),
    ("set-empty-key", ["--set", "=3"], ["=3", "dotted name"]),
    ("set-empty-value", ["--set", "lut.angles="], ["lut.angles", "empty"]),
    ("set-bad-literal", ["--set", "lut.angles=[1"], ["[1", "TOML literal"]),
    ("set-bad-key", ["--set", "lut..angles=3"], ["lut..angles", "dotted name"]),
    ("bad-preset", ["--preset", "nosuch"], ["nosuch", "measured", "paper"]),
    ("missing-config", ["--config", "missing.toml"], ["missing.toml", "does not exist"]),
    ("malformed-config", ["--config", "malformed.toml"], ["malformed.toml", "not valid TOML"]),
    ("config-unknown-key", ["--config", "unknown.toml"], ["lut.angels", "unknown"]),
    ("config-wrong-type", ["--config", "wrongtype.toml"], ["geometry.card_count", "many"]),
    ("config-is-dir", ["--config", "adir.toml"], ["adir.toml", "directory"]),
    ("out-is-file", ["--out", "afile"], ["afile", "not a folder"]),
    ("out-under-file", ["--out", "afile/pigeon"], ["afile", "is a file"]),
    ("out-not-ours", ["--out", "foreign"], ["foreign", "did not create"]),
    ("out-dot", ["--out", "."], ["."]),
    ("out-unwritable", ["--out", "/sys/rockdove-pigeon"], ["/sys/rockdove-pigeon", "cannot create"]),
    ("out-uncreatable", ["--out", "/proc/rockdove/pigeon"], ["/proc/rockdove/pigeon", "cannot create"]),
    ("out-empty", ["--out", ""], ["--out"]),
    ("cache-is-file", ["--cache", "afile"], ["afile", "not a folder"]),
    ("lock-timeout-not-number", ["--lock-timeout", "soon"], ["lock-timeout", "soon"]),
    ("unknown-option", ["--colour", "green"], ["--colour"]),
]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cli")
    _setup(tmp)
    return tmp


def _check_bad(workdir, args, words, command="build"):
    before = _tree(workdir)
    extra = [] if any(a == "--out" for a in args) else ["--out", "build/pigeon"]
    r = rockdove(command, *args, *(extra if command == "build" else []), cwd=workdir)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1, r.stderr
    assert "Traceback" not in r.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert _tree(workdir) == before, "a rejected build wrote something"
    return lines[0]


@pytest.mark.parametrize("case", BAD, ids=[c[0] for c in BAD])
def test_bad_input_exits_2_with_one_line_and_writes_nothing(workdir, case):
    _, args, words = case
    _check_bad(workdir, args, words)


def test_config_command_reports_bad_input_the_same_way(workdir):
    _check_bad(workdir, ["--set", "lut.angles=1"], ["lut.angles", ">= 2"], command="config")


def test_version_and_help(tmp_path):
    r = rockdove("--version", cwd=tmp_path)
    assert r.returncode == 0 and r.stdout.startswith("rockdove ")
    for cmd in ("build", "config"):
        r = rockdove(cmd, "--help", cwd=tmp_path)
        assert r.returncode == 0 and "--set KEY=VALUE" in r.stdout and "--preset" in r.stdout


def test_config_prints_units_and_json(tmp_path):
    r = rockdove("config", "--preset", "paper", "--set", "lut.angles=64", cwd=tmp_path)
    assert r.returncode == 0
    assert "thickness.base_nm" in r.stdout and "[650.0, 650.0] nm" in r.stdout
    assert "lut.angles" in r.stdout and "64 texels" in r.stdout
    r = rockdove("config", "--json", cwd=tmp_path)
    data = json.loads(r.stdout)
    assert data["config"]["film"]["model"] == "keratin" and len(data["config_hash"]) == 64
    assert not list(tmp_path.iterdir()), "config wrote something"


def test_build_json_reports_ran_then_reused(tmp_path):
    args = ["build", "--out", "build/pigeon", "--set", "geometry.card_count=40", "--json", "--quiet"]
    first = json.loads(rockdove(*args, cwd=tmp_path).stdout)
    assert "lut" in first["ran"] and first["reused"] == [] and first["verified"] is True
    second = json.loads(rockdove(*args, cwd=tmp_path).stdout)
    assert second["ran"] == [] and set(second["reused"]) == set(first["ran"])
    marker = json.loads((tmp_path / "build/pigeon/.rockdove-asset.json").read_text())
    assert marker["tool"] == "rockdove" and marker["config_hash"] == second["config_hash"]
    # --quiet and --json: stdout is the JSON only; no progress on a non-terminal stderr
    r = rockdove(*args, cwd=tmp_path)
    assert r.stderr == ""


def test_film_change_through_cli_rebakes_lut_and_material_only(tmp_path):
    base = ["build", "--out", "b/p", "--set", "geometry.card_count=40", "--json", "--no-verify"]
    rockdove(*base, cwd=tmp_path)
    r = json.loads(rockdove(*base, "--set", "film.cauchy_a=1.6", cwd=tmp_path).stdout)
    assert set(r["ran"]) == {"lut", "usd_layers", "usdz"}
    assert {"body", "cards", "textures"} <= set(r["reused"])


def _small_real(cache: Path, body_from: Path) -> list:
    """Options of a small real build (tests/conftest.py's SMALL_BUILD) into a cache seeded with the session's
    body (the one expensive stage, same configuration), so the real stages run in seconds."""
    import shutil

    from conftest import SMALL_BUILD

    shutil.copytree(body_from / "body", cache / "body")
    return ["--cache", str(cache)] + [a for s in SMALL_BUILD for a in ("--set", s)]


def test_physical_only_build_has_no_lut(tmp_path, small_asset, build_root):
    """The real stages: physical-only shading has no lut stage and writes no EXR."""
    r = rockdove("build", "--out", "b/p", "--set", 'shading.variant="physical"', "--json", "--no-verify",
                 *_small_real(tmp_path / "c", build_root / "cache"), cwd=tmp_path, standin=False, timeout=300)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert "lut" not in s["ran"] + s["reused"] and {"textures", "usd_layers"} <= set(s["ran"])
    assert "body" in s["reused"] and not (tmp_path / "b/p/textures/thinfilm_lut.exr").exists()
    assert (tmp_path / "b/p/textures/feather_preview.png").is_file()


def test_failed_verification_exits_1_and_keeps_the_old_asset(tmp_path):
    base = ["build", "--out", "b/p", "--set", "geometry.card_count=40", "--quiet"]
    assert rockdove(*base, cwd=tmp_path).returncode == 0
    before = (tmp_path / "b/p/pigeon.usda").read_text()
    r = rockdove(*base, "--set", "verify.width=17", "--set", "film.cauchy_a=1.7", cwd=tmp_path)
    assert r.returncode == 1 and "failed" in r.stderr and "Traceback" not in r.stderr
    assert (tmp_path / "b/p/pigeon.usda").read_text() == before
    assert not [p for p in (tmp_path / "b").iterdir() if "rockdove-tmp" in p.name]


def test_cache_option_and_no_verify(tmp_path, small_asset, build_root):
    """The real stages: --cache puts every stage's entry there (none beside the output); --no-verify runs no
    verification stage and says so."""
    r = rockdove("build", "--out", "o/p", "--no-verify", "--json", *_small_real(tmp_path / "c", build_root / "cache"),
                 cwd=tmp_path, standin=False, timeout=300)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["verified"] is None and "verify" not in s["ran"] + s["reused"]
    assert {p.name for p in (tmp_path / "c").iterdir()} == set(s["ran"] + s["reused"])
    assert not (tmp_path / "o" / ".rockdove-cache").exists() and not (tmp_path / "o/p/verify").exists()


# ------------------------------------------------------------------------------------- the real pipeline
TINY = ["--set", "geometry.body_voxel_m=0.01", "--set", "geometry.card_count=600", "--set",
        "textures.feather_resolution=32", "--set", "textures.body_resolution=32", "--set", "verify.width=192",
        "--set", "verify.height=192", "--set", "usd.usdz=false", "--set", "beauty.width=128", "--set",
        "beauty.height=96", "--json", "--quiet"]


def test_real_pipeline_builds_verifies_and_rebuilds_only_what_changed(tmp_path):
    """One small real asset through the real stages (no stand-ins): build, verify, film change."""
    r = rockdove("build", "--out", "b/p", "--no-verify", *TINY, cwd=tmp_path, standin=False, timeout=300)
    assert r.returncode == 0, r.stderr
    first = json.loads(r.stdout)
    assert first["ran"] == ["body", "bird", "thickness_range", "lut", "texture_images", "textures", "film_textures",
                            "usd_geometry", "usd_rig", "usd_layers", "gltf"]
    asset = tmp_path / "b/p"
    assert (asset / "pigeon.usda").is_file() and (asset / "textures/thinfilm_lut.exr").is_file()
    assert (asset / "pigeon.glb").is_file()
    # the LUT spans the thickness range on the mesh, no more
    from rockdove.lut.exr import read_exr

    lo, hi = read_exr(asset / "textures/thinfilm_lut.exr").thickness_range_nm
    assert 480 <= lo < 600 and 600 < hi <= 700
    # verification added: only the verify stage runs, on the same asset, every view rendered
    r = rockdove("build", "--out", "b/p", *TINY, cwd=tmp_path, standin=False, timeout=300)
    assert r.returncode == 0, r.stderr
    second = json.loads(r.stdout)
    assert second["ran"] == ["verify"] and second["verified"] is True
    assert "gltf" in second["reused"]  # nothing the glb reads changed
    # the report names the published asset, not the staging folder, and shows the interactive view first
    report_html = (asset / "verify/report.html").read_text()
    # (portable since the report ships no build machine's path: the asset named by its own folder)
    assert "pigeon.usda" in report_html and ".rockdove-tmp-" not in report_html and str(tmp_path) not in report_html
    assert report_html.index("viewer.html") < report_html.index("<table>")
    assert (asset / "verify/viewer.html").is_file() and (asset / "verify/viewer_data.js").is_file()
    views = ["turntable_030", "turntable_210", "sweep_060", "sweep_120", "sweep_090", "hero"]
    assert _items(asset)["ran"]["views"] == views and _items(asset)["ran"]["hosts"] == ["glsl"]
    assert json.loads((asset / "verify/report.json").read_text())["passed"] is True
    report_views = json.loads((asset / "verify/report.json").read_text())["views"]
    assert not (asset / "verify/value.json").exists(), "the cache's value record leaked into the asset"
    verdict = json.loads((tmp_path / "b/.rockdove-cache/verify" / _verify_record(second)["key"] / "value/value.json")
                         .read_text())
    assert verdict["passed"] is True and verdict["views"] == views  # the view names (key "view") reach the verdict
    # a change that renders the same scene (the usdz added, the recipe's description): no view re-rendered
    r = rockdove("build", "--out", "b/p", *TINY, "--set", "usd.usdz=true", "--set", "description=metadata",
                 cwd=tmp_path, standin=False, timeout=300)
    assert r.returncode == 0, r.stderr
    meta = json.loads(r.stdout)
    assert meta["ran"] == ["usdz", "verify"] and meta["verified"] is True
    assert _items(asset)["ran"]["views"] == [] and _items(asset)["reused"]["views"] == views
    assert (asset / "pigeon.usdz").is_file() and (asset / "verify/sweep_090_gl.png").is_file()
    # rockdove verify is the build's verification with the build's cache: what the build checked is not redone
    r = rockdove("verify", "b/p", "--hosts", "glsl", "--width", "192", "--height", "192", "--beauty", "off",
                 "--out", "v", "--quiet", cwd=tmp_path, standin=False, timeout=300)
    assert r.returncode == 0, r.stderr
    cli = json.loads((tmp_path / "v/report.json").read_text())
    assert cli["cache"]["ran"] == {"surfaces": [], "views": [], "hosts": [], "pictures": []}
    assert cli["cache"]["reused"]["views"] == views and cli["views"] == report_views
    # film index change: LUT, textures (the preview mixes the LUT in), layers and every view; geometry reused;
    # gltf.glb = false: no glb, and no viewer in the report (it shows the glb)
    r = rockdove("build", "--out", "b/p", "--set", "film.cauchy_a=1.56", "--set", "gltf.glb=false", *TINY,
                 cwd=tmp_path, standin=False, timeout=300)
    assert r.returncode == 0, r.stderr
    third = json.loads(r.stdout)
    assert third["ran"] == ["lut", "film_textures", "usd_layers", "verify"]
    assert not (asset / "pigeon.glb").exists() and not (asset / "verify/viewer.html").exists()
    assert {"body", "bird", "thickness_range", "texture_images", "textures", "usd_geometry", "usd_rig"} == set(
        third["reused"])
    assert _items(asset)["ran"]["views"] == views
    # ... but not what the reference shades at its hits before the film: one item per camera (the sweep shares one)
    surfaces = _items(asset)
    assert surfaces["ran"]["surfaces"] == [] and 3 <= len(surfaces["reused"]["surfaces"]) < len(views)
    # physical-only shading: no bake at all (the lut stage is not in the graph), verified with a note
    r = rockdove("build", "--out", "b/p", "--set", "shading.variant=physical", *TINY, cwd=tmp_path, standin=False,
                 timeout=300)
    assert r.returncode == 0, r.stderr
    fourth = json.loads(r.stdout)
    assert "lut" not in fourth["ran"] + fourth["reused"] and fourth["verified"] is True
    pattern = [n for n in fourth["notes"] if n.startswith("boundary at sweep_090:")]  # verify's closing note
    assert len(pattern) == 1 and len(fourth["notes"]) == 2 and "verification-only LUT" in fourth["notes"][0]
    assert [n[:22] for n in third["notes"]] == ["boundary at sweep_090:"]
    assert {"film_textures", "usd_layers", "verify"} <= set(fourth["ran"])
    assert not (asset / "textures/thinfilm_lut.exr").exists()
    report = json.loads((asset / "verify/report.json").read_text())
    assert report["passed"] and report["lut"]["verification_only"] and "physical-only" in report["notes"][0]
    assert "gltf" in fourth["ran"] and (asset / "pigeon.glb").is_file()  # a LUT-less asset exports too
    assert (asset / "verify/viewer.html").is_file()


def _verify_record(summary: dict, name: str = "verify") -> dict:
    return next(s for s in summary["stages"] if s["name"] == name)


def _items(asset) -> dict:
    """The verification's items that ran and were reused (rockdove.verify.verification), from its report."""
    return json.loads((asset / "verify/report.json").read_text())["cache"]


def test_every_listed_command_has_a_module_with_the_command_interface():
    import importlib

    from rockdove.cli import COMMANDS, build_parser

    for name in COMMANDS:
        mod = importlib.import_module(f"rockdove.commands.{name.replace('-', '_')}")
        assert callable(mod.add_arguments) and callable(mod.run), name
        build_parser(name)  # its arguments are added without error


@pytest.mark.parametrize("error, status", [("UsageError", 2), ("HostError", 2), ("BrowserError", 2),
                                           ("GLRenderError", 2), ("VerificationFailed", 1), ("ValueError", None),
                                           ("KeyError", None)])
def test_the_cli_turns_rockdoves_errors_into_one_line_and_lets_a_bug_show_its_traceback(monkeypatch, capsys, error,
                                                                                        status):
    """Every error rockdove raises on purpose derives from RockdoveError and is one line; a bare ValueError (a
    library's, or a bug's) is not caught as bad usage."""
    from rockdove import cli, errors
    from rockdove.commands import schema_path
    from rockdove.hosts import HostError
    from rockdove.verify.gl_renders import GLRenderError
    from rockdove.web.browser import BrowserError

    kinds = {"HostError": lambda: HostError("x", "it broke"), "BrowserError": lambda: BrowserError("it broke"),
             "GLRenderError": lambda: GLRenderError("it broke"), "ValueError": lambda: ValueError("it broke"),
             "KeyError": lambda: KeyError("it broke")}
    exc = kinds.get(error, lambda: getattr(errors, error)("it broke"))()
    assert isinstance(exc, errors.RockdoveError) == (status is not None)

    def run(args):
        raise exc

    monkeypatch.setattr(schema_path, "run", run)
    monkeypatch.delenv("ROCKDOVE_DEBUG", raising=False)
    if status is None:
        with pytest.raises(type(exc)):
            cli.main(["schema-path"])
        return
    assert cli.main(["schema-path"]) == status
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "it broke" in err and "Traceback" not in err


def test_watch_rebuilds_on_an_edit_not_without_one_survives_a_bad_edit_and_ends_on_ctrl_c(tmp_path):
    """``rockdove build --watch``: one process; an edit of the --config file rebuilds (the film stages run, the
    geometry is reused), no edit builds nothing, a malformed edit prints its one-line error and keeps watching,
    a repaired file builds again, and Ctrl-C (SIGINT) ends it with status 0 and no staging folder left."""
    import select
    import signal

    config = tmp_path / "look.toml"
    config.write_text("[film]\ncauchy_a = 1.50\n")
    cmd = [sys.executable, LAUNCHER, "--standin", "--", "build", "--watch", "--json", "--quiet", "--no-verify",
           "--config", str(config), "--out", "b/p"]
    proc = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    def line(timeout: float):
        ready, _, _ = select.select([proc.stdout], [], [], timeout)
        return json.loads(proc.stdout.readline()) if ready else None

    try:
        first = line(60)
        assert first is not None and "lut" in first["ran"] and "body" in first["ran"]
        assert line(1.5) is None  # nothing changed: no rebuild
        config.write_text("[film]\ncauchy_a = 1.60\n")
        second = line(60)
        assert second is not None and "lut" in second["ran"] and "body" in second["reused"]
        config.write_text("[film\ncauchy_a = 1.7\n")
        bad = line(60)
        assert bad is not None and "not valid TOML" in bad["error"] and proc.poll() is None
        config.write_text("[film]\ncauchy_a = 1.70\n")
        third = line(60)
        assert third is not None and "lut" in third["ran"] and third["config_hash"] != second["config_hash"]
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert "stopped watching" in err and "Traceback" not in err
    assert err.count("not valid TOML") == 1
    assert not list((tmp_path / "b").glob(".p.rockdove-tmp-*"))


def test_api_build_returns_a_typed_result_and_a_failed_verification_raises_with_it(tmp_path, monkeypatch):
    """The library API in this process (stand-in stages): values in, a BuildResult out; overrides as a mapping
    and as KEY=VALUE strings give the same configuration; a failed verification publishes nothing and raises
    BuildFailed carrying what ran."""
    from standins import standin_stages

    from rockdove import api
    from rockdove.graph import stages

    monkeypatch.setattr(stages, "make_stages", standin_stages)
    config = api.load_config(preset="paper", overrides={"film.cauchy_a": 1.55})
    assert config == api.load_config(preset="paper", overrides=["film.cauchy_a=1.55"])
    with pytest.raises(api.UsageError, match="lut.angles"):
        api.load_config(overrides={"lut.angles": 1})
    result = api.build(config, tmp_path / "p", cache=tmp_path / "c")
    assert result.verified is True and result.report_dir == tmp_path / "p" / "verify"
    assert "lut" in result.ran and not result.reused and set(result.keys) == {s.name for s in result.stages}
    again = api.build(config, tmp_path / "p", cache=tmp_path / "c", verify=False)
    assert again.ran == [] and again.verified is None and again.keys["lut"] == result.keys["lut"]
    bad = api.load_config(preset="paper", overrides={"film.cauchy_a": 1.55, "verify.width": 17})
    with pytest.raises(api.BuildFailed) as info:
        api.build(bad, tmp_path / "p", cache=tmp_path / "c")
    assert info.value.result.verified is False and "stand-in width 17" in info.value.result.failure
    assert "verify" in info.value.result.ran
    assert json.loads((tmp_path / "p" / ".rockdove-asset.json").read_text())["config_hash"] == result.config_hash


def test_config_paths_lists_the_user_cache_in_use_and_the_suite_has_its_own(tmp_path, user_cache):
    """``rockdove config --paths`` names the user cache of this environment and what each folder in it holds;
    the suite runs with its own (conftest's session fixture), never the developer's ~/.cache."""
    assert Path(os.environ["XDG_CACHE_HOME"]) == user_cache != Path.home() / ".cache"
    xdg = tmp_path / "xdg"
    (xdg / "rockdove" / "code").mkdir(parents=True)
    env = {**os.environ, "XDG_CACHE_HOME": str(xdg)}
    r = subprocess.run([sys.executable, "-m", "rockdove.cli", "config", "--paths", "--json"], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert rows[0]["path"] == str(xdg / "rockdove")
    assert any(row["path"] == str(xdg / "rockdove" / "code") and "imports" in row["what"]
               and row["stale"].startswith("no key.json") for row in rows)

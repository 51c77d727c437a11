"""Hostile inputs, second round: an unwritable user cache, odd characters in paths, huge scenes, SIGTERM during
a verification, Blender's path templates, asset strings that would become shader code."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import OUTSIDE, copy_asset

EXE = os.path.join(os.path.dirname(sys.executable), "rockdove")
SMALL = ["--hosts", "glsl", "--width", "64", "--height", "64", "--views", "2", "--beauty", "off", "--quiet"]


def rockdove(*args, env=None, prefix=(), timeout=300):
    env = {k: v for k, v in {**os.environ, **(env or {})}.items() if k != "ROCKDOVE_DEBUG"}
    return subprocess.run([*prefix, EXE, *map(str, args)], capture_output=True, text=True, cwd=OUTSIDE, env=env,
                          timeout=timeout)


def one_line(r, code, *words):
    assert r.returncode == code, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert all(w in r.stderr for w in words), r.stderr


# ----------------------------------------------------------------------------------------------- user cache
def _unprivileged(cmd):
    return list(cmd) if os.geteuid() else ["setpriv", "--bounding-set=-dac_override,-dac_read_search,-fowner", "--",
                                           *cmd]


@pytest.mark.gl
@pytest.mark.parametrize("how", ["file", "read-only", "full"])
def test_an_unwritable_user_cache_only_costs_time(small_asset, tmp_path, how):
    """An asset with no build cache beside it is verified with the user cache; where that cannot be written
    (a regular file in its place, a read-only folder, a full disk) verify still passes, its report whole."""
    asset = copy_asset(small_asset, tmp_path / "a" / "pigeon")
    xdg, report = tmp_path / "xdg", tmp_path / "report"
    cmd = [EXE, "verify", str(asset), "--out", str(report), *SMALL]
    if how == "file":
        xdg.write_text("not a folder\n")
    elif how == "read-only":
        xdg.mkdir(mode=0o555)
        cmd = _unprivileged(cmd)
    else:  # a 256 KiB tmpfs, filled, in a mount namespace of its own
        xdg.mkdir()
        script = 'mount -t tmpfs -o size=256k tmpfs "$1" && head -c 1m /dev/zero > "$1/fill" 2>/dev/null; shift; "$@"'
        unshare = ["unshare", "--mount"] if os.geteuid() == 0 else ["unshare", "--user", "--map-root-user", "--mount"]
        cmd = [*unshare, "sh", "-c", script, "sh", str(xdg), *cmd]
    env = {k: v for k, v in os.environ.items() if k != "ROCKDOVE_DEBUG"}
    r = subprocess.run(cmd, capture_output=True, text=True, env={**env, "XDG_CACHE_HOME": str(xdg)}, timeout=300)
    assert r.returncode == 0, r.stderr
    assert (report / "report.json").is_file() and (report / "report.html").is_file()
    assert not [p for p in report.iterdir() if p.name.startswith(".scratch-")]


# ----------------------------------------------------------------------------------------------- path characters
@pytest.mark.parametrize("command", ["verify", "gltf", "render"])
def test_a_backslash_in_the_asset_folder_is_named_not_called_outside_the_asset(small_asset, tmp_path, command):
    """USD reads ``\\`` as a separator, so it looks for the payload in another folder: one line says so (it said
    the asset's own layers were "outside the asset")."""
    asset = copy_asset(small_asset, tmp_path / "a\\b" / "pigeon")
    r = rockdove(command, asset, *(["--out", tmp_path / "r"] if command == "render" else []))
    one_line(r, 2, "backslash, which USD reads as a folder separator")
    assert "outside" not in r.stderr and not (tmp_path / "r").exists()


def test_nvidias_validator_reads_an_asset_under_a_folder_with_a_hash(small_asset, tmp_path):
    """Its engine ``urlparse``\\ s the path: ``#`` began a fragment and the asset was "not a readable USD file"."""
    from rockdove.usd.nvidia import run_nvidia_validator

    asset = copy_asset(small_asset, tmp_path / "take#2?x;y" / "pigeon")
    for layer in ("pigeon.usda", "pigeon.usdz"):
        issues, _ = run_nvidia_validator(str(asset / layer))
        assert not [i for i in issues if i.severity == "error"], issues


@pytest.mark.parametrize("argv", [["build", "--out", "b\nx"], ["render", "{asset}", "--out", "r\x01"],
                                  ["verify", "{asset}", "--out", "v\rw"], ["gltf", "{asset}", "--out", "g\t.glb"]])
def test_a_control_character_in_out_is_one_line(small_asset, tmp_path, argv):
    r = subprocess.run([EXE, *(a.format(asset=small_asset) for a in argv)], capture_output=True, text=True,
                       cwd=tmp_path, timeout=120)
    one_line(r, 2, "holds a control character")
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------------------------- Blender
_SHOOT = """
import json, sys
import bpy, mathutils
sys.path.insert(0, sys.argv[1])
import blender_job, jobs
view = jobs.JobView(**json.loads(sys.argv[2]))
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.context.scene.render.engine = "BLENDER_WORKBENCH"
blender_job.shoot(bpy, mathutils, mathutils.Matrix.Identity(4), [view], sys.argv[3], "png")
"""


def test_blender_writes_each_view_where_asked_whatever_braces_the_folder_holds(tmp_path):
    """Blender 5 expands ``{...}`` in ``scene.render.filepath`` (an unknown name fails the render) and reads ``\\``
    as ``/``: the job saves each view by its path as given, into a folder named like a template."""
    import dataclasses
    import json

    from rockdove.hosts import bpy_runner as blender
    from rockdove.hosts.jobs import JobView

    if blender.unavailable():
        pytest.skip(blender.unavailable())
    work = tmp_path / "{blend_name}{x}#1\\a" / "blender"
    work.mkdir(parents=True)
    view = JobView("v", [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1], [0, 0, 0, 1]], 0.5, 16, 8, [0, 0, 1], [1, 1, 1])
    r = subprocess.run([blender.bpy_python(), "-c", _SHOOT, os.path.dirname(blender.__file__),
                        json.dumps(dataclasses.asdict(view)), str(work)], capture_output=True, text=True, timeout=120,
                       cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert [p.relative_to(tmp_path) for p in tmp_path.rglob("*.png")] == [work.relative_to(tmp_path) / "v.png"]


# ----------------------------------------------------------------------------------------------- budgets
def _bomb(folder: Path, kind: str) -> Path:
    """A copy of the small asset whose payload also sublayers ``bomb.usdc``: one just over a budget of
    :mod:`rockdove.usd.budget` (small on disk: crate compresses what it repeats)."""
    from pxr import Sdf, Vt

    layer = Sdf.Layer.CreateAnonymous(".usda")
    if kind == "prims":
        layer.ImportFromString("#usda 1.0\n" + "".join(f"def \"P{i}\" {{}}\n" for i in range(100_001)))
    else:
        mesh = Sdf.CreatePrimInLayer(layer, "/Pigeon/Geom/Body")
        name, typ, value = {"face": ("faceVertexCounts", Sdf.ValueTypeNames.IntArray, Vt.IntArray([1025])),
                            "array": ("primvars:junk", Sdf.ValueTypeNames.FloatArray,
                                      Vt.FloatArray((1 << 24) + 1))}[kind]
        Sdf.AttributeSpec(mesh, name, typ).default = value
    layer.Export(str(folder / "bomb.usdc"))
    payload = folder / "pigeon_payload.usda"
    payload.chmod(0o644)
    payload.write_text(payload.read_text().replace("subLayers = [", "subLayers = [@./bomb.usdc@, ", 1))
    return folder


@pytest.mark.parametrize("kind, words", [("prims", ["100,002 specs (prims and properties)", "budget is 100,000"]),
                                         ("array", ["16,777,217 elements", "budget is 16,777,216"]),
                                         ("face", ["face of 1,025 vertices", "budget is 1,024"])])
def test_a_scene_over_a_budget_is_refused_in_one_line_before_usd_composes_it(small_asset, tmp_path, kind, words):
    """Issue 33: 2 million empty prims passed 8 GiB in validate, a 150 million element primvar 7.6 GiB, a
    5 million vertex polygon 3.6 GiB and minutes. A scan of the layers' bytes refuses them first."""
    asset = _bomb(copy_asset(small_asset, tmp_path / "a" / "pigeon"), kind)
    assert (asset / "bomb.usdc").stat().st_size < 2 << 20
    one_line(rockdove("gltf", asset, "--out", tmp_path / "x.glb", timeout=60), 1, *words)
    r = rockdove("validate", asset, timeout=60)
    from rockdove.usd import budget

    assert (budget.MAX_SPECS, budget.MAX_ARRAY, budget.MAX_FACE) == (100_000, 1 << 24, 1024)
    assert r.returncode == 1 and all(w in r.stdout for w in words) and "Traceback" not in r.stderr, r.stdout


def test_a_crate_whose_value_section_claims_chunks_is_refused_not_passed_unscanned(tmp_path):
    """A crate's FIELDS value reps in TfFastCompression chunks (only a section over 2 GB needs them; this one holds
    a few fields) cannot be scanned for its array sizes: the budget refuses it rather than letting USD open it."""
    import struct

    from pxr import Sdf, Vt

    from rockdove.usd import budget

    layer = Sdf.Layer.CreateAnonymous(".usda")
    Sdf.AttributeSpec(Sdf.CreatePrimInLayer(layer, "/P"), "a", Sdf.ValueTypeNames.FloatArray).default = \
        Vt.FloatArray(8)
    path = tmp_path / "c.usdc"
    layer.Export(str(path))
    assert budget.over_budget(str(path)) is None
    data = bytearray(path.read_bytes())
    (toc,) = struct.unpack_from("<q", data, 16)
    (count,) = struct.unpack_from("<Q", data, toc)
    sections = {struct.unpack_from("<16s", data, toc + 8 + 32 * k)[0].rstrip(b"\0"):
                struct.unpack_from("<q", data, toc + 24 + 32 * k)[0] for k in range(count)}
    at = sections[b"FIELDS"]
    (skip,) = struct.unpack_from("<Q", data, at + 8)
    assert data[at + 24 + skip] == 0  # one LZ4 block, as every writer makes it for a section this small
    data[at + 24 + skip] = 1
    path.write_bytes(bytes(data))
    assert "in chunks" in budget.over_budget(str(path))


# ----------------------------------------------------------------------------------------------- SIGTERM
def _children(pid: int, text: str) -> list[int]:
    """Processes whose command line holds ``text`` and whose parent is ``pid`` (or was: orphans have parent 1)."""
    found = []
    for p in Path("/proc").glob("[0-9]*"):
        try:
            cmd = (p / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            ppid = int((p / "stat").read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        if text in cmd and ppid in (pid, 1) and int(p.name) != os.getpid():
            found.append(int(p.name))
    return found


@pytest.mark.gl
def test_sigterm_during_verify_ends_its_jobs_and_publishes_no_half_report(small_asset, tmp_path):
    """A supervisor stopping ``rockdove verify`` while Blender renders: exit 130 as for Ctrl-C, the bpy job's
    process group ended with it, no report folder (the report is published whole or not at all), no cache
    temporaries."""
    import signal
    import time

    from rockdove.hosts import bpy_runner as blender

    if blender.unavailable():
        pytest.skip(blender.unavailable())
    asset = copy_asset(small_asset, tmp_path / "a" / "pigeon")
    report, cache = tmp_path / "report", tmp_path / "cache"
    env = {k: v for k, v in os.environ.items() if k != "ROCKDOVE_DEBUG"}
    proc = subprocess.Popen([EXE, "verify", str(asset), "--out", str(report), "--cache", str(cache),
                             *SMALL[2:], "--hosts", "glsl,blender"], env=env, text=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=OUTSIDE)
    jobs = []
    try:
        deadline = time.monotonic() + 120
        while not jobs and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.2)
            jobs = _children(proc.pid, "blender_job.py")
        assert jobs, "the Blender job never started"
        time.sleep(1.0)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 130 and "interrupted" in err and "Traceback" not in err, (proc.returncode, err)
        time.sleep(0.5)
        assert not [j for j in jobs if Path(f"/proc/{j}").exists() and "blender_job.py" in Path(
            f"/proc/{j}/cmdline").read_bytes().decode(errors="replace")], "the bpy job outlived rockdove"
        assert not report.exists() and not [p.name for p in tmp_path.iterdir() if "rockdove-tmp" in p.name]
        assert not list(cache.glob("*/.tmp-*"))
    finally:
        for j in jobs:
            with contextlib.suppress(OSError):
                os.kill(j, signal.SIGKILL)
        if proc.poll() is None:
            proc.kill()


# ----------------------------------------------------------------------------------------------- shader code
_EDITS = {  # pigeon_looks.usda's text -> a hand edit that a generator would paste into its code
    "geomprop": ('inputs:geomprop = "thickness"', 'inputs:geomprop = "thickness\\";\\n#include \\"/etc/passwd"'),
    "missing primvar": ('inputs:geomprop = "thickness"', 'inputs:geomprop = "thicknes"'),
    "enum": ('string inputs:wrapS = "clamp"', 'string inputs:wrapS = "clamp\\", \\"periodic"'),
    "colour space": ('colorSpace = "srgb_texture"', 'colorSpace = "srgb_texture\\" #"'),
    "varname": ('string inputs:varname = "previewST"', 'string inputs:varname = "previewST;x"'),
}


def _edited(small_asset, tmp_path, what):
    asset = copy_asset(small_asset, tmp_path / "a" / "pigeon")
    looks = asset / "pigeon_looks.usda"
    looks.chmod(0o644)
    old, new = _EDITS[what]
    assert old in looks.read_text()
    looks.write_text(looks.read_text().replace(old, new, 1))
    return asset


@pytest.mark.parametrize("what", list(_EDITS))
def test_validate_reports_each_value_a_generator_would_paste_into_code(small_asset, tmp_path, what):
    """Issue 33: a hand-edited geomprop, enum, colour space or primvar reader name became shader code
    (an #include of a file of the machine); validate called the asset clean."""
    from pxr import Usd

    from rockdove.usd.validate import CODE_CHECK, check_mtlx_shaders

    stage = Usd.Stage.Open(str(_edited(small_asset, tmp_path, what) / "pigeon.usda"))
    issues, _ = check_mtlx_shaders(stage)
    assert [i for i in issues if "would paste it into the code" in i.message and i.check == CODE_CHECK], issues


@pytest.mark.parametrize("what", ["geomprop", "missing primvar", "enum", "colour space"])
def test_no_such_value_reaches_materialx_generators(small_asset, tmp_path, what):
    from rockdove.errors import UsageError
    from rockdove.hosts.materialx import feather_networks

    with pytest.raises(UsageError):
        feather_networks(str(_edited(small_asset, tmp_path, what) / "pigeon.usda"), "baked")


def test_texture_paths_reach_the_osl_shader_as_parameters(small_asset, tmp_path):
    """The OSL source names no texture file (a quote in the asset's folder broke it): the files are the values of
    its parameters, which the Cycles job sets on the Script node."""
    from rockdove.hosts.materialx import BASE_COLOUR, feather_networks
    from rockdove.hosts.osl import generate_osl, lobe_document

    asset = copy_asset(small_asset, tmp_path / 'it"s' / "pigeon")
    (net,) = feather_networks(str(asset / "pigeon.usda"), "baked").values()
    doc, files = lobe_document(net, BASE_COLOUR["baked"])
    source = generate_osl(doc, net.material)
    assert str(tmp_path) not in source and "textures/" not in source
    assert sorted(files.values()) == sorted(str(asset / "textures" / f) for f in
                                            ("feather_base.png", "feather_mask.png", "thinfilm_lut.exr"))
    assert all(f'string {param} = ""' in source for param in files)


@pytest.mark.parametrize("what", ["varname", "geomprop"])
def test_storm_refuses_a_network_whose_values_would_be_code(small_asset, tmp_path, what):
    """Storm generates its own shaders (HdMtlx, the UsdPrimvarReader's varname as an identifier): the host does
    not draw such an asset."""
    from rockdove.hosts.storm import _code_values

    assert "would paste it into the code" in (_code_values(str(_edited(small_asset, tmp_path, what) /
                                                                "pigeon.usda")) or "")


# ----------------------------------------------------------------------------------------------- own round
def test_a_texture_whose_header_declares_too_many_texels_is_not_decoded(small_asset, tmp_path):
    """A 140 KB PNG declaring 12,000 x 12,000 texels (inside Pillow's own limit) took 55 s and 2.1 GB in verify;
    its header is read first and it is refused in one line."""
    import struct
    import zlib

    asset = copy_asset(small_asset, tmp_path / "a" / "pigeon")
    w = h = 12_000
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))  # noqa: E731
    mask = asset / "textures" / "feather_mask.png"
    mask.chmod(0o644)
    mask.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)) +
                     chunk(b"IDAT", zlib.compress(b"\0" * ((w + 1) * h), 1)) + chunk(b"IEND", b""))
    one_line(rockdove("render", asset, "--out", tmp_path / "r", timeout=60), 1,
             "12,000 x 12,000 texels; the budget is 16,777,216")


@pytest.mark.parametrize("argv", [["config", "--config", "deep.toml"],
                                  ["config", "--set", "film.cauchy_a=" + "[" * 3000 + "1" + "]" * 3000]])
def test_toml_nested_past_the_parsers_recursion_is_one_line(tmp_path, argv):
    (tmp_path / "deep.toml").write_text("a = " + "[" * 5000 + "1" + "]" * 5000 + "\n")
    r = subprocess.run([EXE, *argv], capture_output=True, text=True, cwd=tmp_path, timeout=60)
    one_line(r, 2, "nests arrays or tables too deeply")


# ----------------------------------------------------------------------------------------------- the host cache key
@pytest.mark.gl
def test_a_hosts_cached_result_follows_the_material_network_it_rendered(small_asset, tmp_path):
    """The stale-key case of issue 33: the feather network edited (its thickness read from another primvar,
    which the scene the GL renders read leaves alone) passed on a warm cache and failed on a fresh one, and an
    untouched asset was reported failed from the edited one's cached result. The host's key holds every file the
    asset composes, so each asset is judged by its own render, in either order."""
    from rockdove import api
    from rockdove.hosts.materialx import BAKED

    if BAKED.unavailable():
        pytest.skip(BAKED.unavailable())
    untouched = copy_asset(small_asset, tmp_path / "u" / "pigeon")
    edited = copy_asset(small_asset, tmp_path / "e" / "pigeon")
    looks = edited / "pigeon_looks.usda"
    looks.chmod(0o644)
    looks.write_text(looks.read_text().replace('inputs:geomprop = "thickness"', 'inputs:geomprop = "neckS"', 1))

    def check(asset, cache):
        v = api.verify(asset, ["glsl", "materialx"], cache=tmp_path / cache, out=tmp_path / f"r-{cache}",
                       width=64, height=64, n_views=2, views=["sweep_090"], beauty={"renderer": "off"})
        (host,) = [h for h in v.hosts if h.name == "materialx"]
        return host.status, "materialx" in v.report.cache.reused.hosts

    assert check(untouched, "c1") == ("passed", False)
    assert check(edited, "c1") == ("failed", False)  # was ("passed", True): the untouched asset's result
    assert check(untouched, "c1") == ("passed", True)
    assert check(edited, "c2") == ("failed", False)
    assert check(untouched, "c2") == ("passed", False)  # was ("failed", True): the edited asset's result


@pytest.mark.parametrize("inside", [".", "textures"])
def test_a_report_never_replaces_an_asset_or_a_folder_of_other_files(small_asset, tmp_path, inside):
    """The report is swapped in whole, so an --out that holds an asset or other files is refused, untouched."""
    asset = copy_asset(small_asset, tmp_path / "a" / "pigeon")
    before = sorted(p.relative_to(asset) for p in asset.rglob("*"))
    one_line(rockdove("verify", asset, "--out", asset / inside, *SMALL, timeout=60), 2, "holds more than a")
    assert sorted(p.relative_to(asset) for p in asset.rglob("*")) == before

"""The build graph: content keys, the cache, early cut-off and the incremental rules.

Most tests use the stand-in pipeline of ``tests/standins.py`` (same shape and rules as the real one); the
tests at the end run the real stages (:func:`rockdove.graph.stages.make_stages`) on small configurations.
"""

from __future__ import annotations

import dataclasses
import importlib
import os
from pathlib import Path

import numpy as np
import pytest

from rockdove import sources
from rockdove.graph import engine as G
from rockdove.config import load_config
from conftest import SMALL_BUILD
from standins import standin_body, standin_stages  # tests/ is on sys.path under pytest


# ------------------------------------------------------------------------------------- helpers
def _build(tmp_path, cfg, verify=True):
    graph = G.Graph(standin_stages(cfg, verify=verify), cfg, G.Cache(tmp_path / "cache"))
    graph.run()
    asset = tmp_path / "asset"
    asset.mkdir(exist_ok=True)
    graph.assemble(asset)
    graph.run(asset_dir=asset, needs_asset=True)
    return graph


def _status(graph):
    return {n: r.status for n, r in graph.records.items()}


def _cfg(*overrides, preset="measured"):
    return load_config(preset=preset, overrides=["geometry.card_count=50", *overrides])


# ------------------------------------------------------------------------------------- tests
def test_second_build_reuses_every_stage(tmp_path):
    cfg = _cfg()
    first = _build(tmp_path, cfg)
    assert set(_status(first).values()) == {"ran"}
    second = _build(tmp_path, cfg)
    assert set(_status(second).values()) == {"reused"}
    assert {n: r.key for n, r in first.records.items()} == {n: r.key for n, r in second.records.items()}


def _geometry(ctx):
    return {"points": np.arange(6.0)}


def _film(ctx):
    return {"sum": float(ctx.inputs["geometry"]["points"].sum() * ctx.config["film"]["cauchy_a"])}


def test_a_shared_codec_loads_each_cache_entry_once_per_process(tmp_path):
    """A film change in the same process hands the rerun stage the geometry loaded by an earlier build (a shared
    codec), not a fresh read; an entry deleted and written again is read again; other codecs read every time."""
    loads = []

    def load(folder):
        loads.append(folder)
        return G.load_npz(folder / "value.npz")

    def stages(shared):
        codec = G.Codec("geometry_test", G.NPZ.save, load, shared=shared)
        return [G.Stage("geometry", _geometry, codec=codec), G.Stage("film", _film, config=("film",),
                                                                     deps=("geometry",))]

    def build(a, shared=True):
        g = G.Graph(stages(shared), _cfg(f"film.cauchy_a={a}"), G.Cache(tmp_path / "cache"))
        g.run()
        return g

    build(1.5)
    assert len(loads) == 1  # loaded back from its temporary folder after it ran
    first = build(1.6)
    assert first.records["film"].status == "ran" and first.records["geometry"].status == "reused"
    assert len(loads) == 2  # read from its cache entry
    second = build(1.7)
    assert second.records["film"].status == "ran" and second.records["geometry"].status == "reused"
    assert len(loads) == 2 and second.value("geometry") is first.value("geometry")
    assert second.value("film") == {"sum": 15.0 * 1.7}
    import shutil

    shutil.rmtree(second.entry_dir("geometry").parent)  # the whole entry: written again by the next build
    third = build(1.8)
    assert third.records["geometry"].status == "ran" and len(loads) == 3
    build(1.9)
    assert len(loads) == 4  # the new entry, read once
    build(2.0)
    assert len(loads) == 4
    build(2.1, shared=False)
    build(2.2, shared=False)
    assert len(loads) == 6


def test_film_change_rebakes_lut_and_rewrites_material_but_reuses_geometry(tmp_path):
    _build(tmp_path, _cfg())
    g = _build(tmp_path, _cfg("film.cauchy_a=1.6"))
    st = _status(g)
    assert st["lut"] == st["usd_layers"] == "ran"
    assert st["body"] == st["cards"] == st["thickness_range"] == st["textures"] == "reused"


def test_seed_change_with_same_thickness_range_does_not_rebake_lut(tmp_path):
    # paper preset: the range is (650, 650) whatever the seed; early cut-off on the range's digest
    _build(tmp_path, _cfg(preset="paper"))
    g = _build(tmp_path, _cfg("geometry.seed=7", preset="paper"))
    st = _status(g)
    assert st["cards"] == "ran" and st["thickness_range"] == "ran"
    assert st["lut"] == "reused"


def test_uniform_film_bakes_one_texel_high_lut(tmp_path):
    g = _build(tmp_path, _cfg(preset="paper"))
    assert np.load(g.entry_dir("lut") / "thinfilm_lut.npy").shape[0] == 1
    g = _build(tmp_path, _cfg("lut.thicknesses=5"))
    assert np.load(g.entry_dir("lut") / "thinfilm_lut.npy").shape[0] == 5


def test_physical_only_shading_has_no_bake(tmp_path):
    g = _build(tmp_path, _cfg("shading.variant=physical"))
    assert "lut" not in g.records
    assert not (tmp_path / "asset" / "textures" / "thinfilm_lut.npy").exists()


def _fake_package(tmp_path, monkeypatch, files: dict) -> Path:
    """A package ``rockdove`` of ``files`` (relative path -> source) standing in for the installed one."""
    from rockdove import resources

    root = tmp_path / "rockdove"
    for rel, text in {"__init__.py": "", **files}.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    monkeypatch.setattr(resources, "package_root", lambda: root)
    monkeypatch.setattr(sources, "_MEMO", {})
    return root


def _function(path: Path, name: str):
    """Function ``name`` of the module file ``path``, compiled from its definition there (so its source file is
    ``path``; the module's own imports are not run)."""
    import ast

    tree = ast.parse(path.read_text())
    tree.body = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name]
    namespace: dict = {"__name__": "fake"}
    exec(compile(tree, str(path), "exec"), namespace)
    return namespace[name]


FAKE = {
    "graph/__init__.py": "", "graph/engine.py": "from ..config import X\n", "config.py": "X = 1\n",
    # the imports are what the key reads; the fake package is not importable, so running the stage skips them
    "wiring.py": "from .geo import types\n\n\ndef run(ctx):\n    if ctx is None:\n        from .tex import paint\n"
                 "    return 1\n\n\ndef other(ctx):\n    return types.Y\n",
    "tex.py": "from .sdf import field\n\n\ndef paint():\n    return field()\n",
    "sdf.py": "def field():\n    return 1\n",
    "geo/__init__.py": "", "geo/types.py": "Y = 2\n",
    "hosts/__init__.py": "HOSTS = {'glsl': 'rockdove.hosts.glsl'}\n", "hosts/glsl.py": "Z = 3\n",
    "unrelated.py": "# nothing a stage reaches\nU = 1\n",
}


def test_an_edit_a_stage_reaches_only_indirectly_reruns_it_and_an_unrelated_edit_reuses_it(tmp_path, monkeypatch):
    """The stale-key case of issue 24: the stage's function imports tex, which imports sdf; an edit to sdf's
    function (reached only through tex) reruns the stage, and a comment added to a module outside its import
    closure (unrelated.py, geo/types.py: used by another function of the same wiring module) reuses it."""
    root = _fake_package(tmp_path, monkeypatch, FAKE)
    stage = G.Stage("s", _function(root / "wiring.py", "run"), codec=G.JSON)
    cfg = _cfg()

    def status():
        graph = G.Graph([stage], cfg, G.Cache(tmp_path / "cache"))
        graph.run()
        return graph.records["s"].status

    assert status() == "ran" and status() == "reused"
    (root / "sdf.py").write_text("def field():\n    return 2\n")  # same size as before, other code
    assert status() == "ran" and status() == "reused"
    (root / "unrelated.py").write_text("# nothing a stage reaches, edited\nU = 1\n")
    (root / "geo" / "types.py").write_text("Y = 2  # a comment\n")
    assert status() == "reused"
    (root / "config.py").write_text("X = 1  # the engine's own closure\n")
    assert status() == "ran"
    other = G.Stage("o", _function(root / "wiring.py", "other"))
    before = G.source_digest(other)
    (root / "geo" / "types.py").write_text("Y = 3\n")
    assert G.source_digest(other) != before


def test_modules_named_by_strings_are_followed_and_the_digest_is_remembered_until_a_file_changes(
        tmp_path, monkeypatch):
    """A registry that imports by name ("rockdove.hosts.glsl") is part of the closure; a process remembers a
    digest until a file it read or a folder it listed changes (a new file in a listed folder recomputes it, to
    the same digest when nothing imports the file), and the remembered digest is the one a fresh process
    computes."""
    root = _fake_package(tmp_path, monkeypatch, {**FAKE, "wiring.py": "def run(ctx):\n    from . import hosts\n"})
    (tmp_path / "materials" / "glsl").mkdir(parents=True)
    (tmp_path / "materials" / "glsl" / "x.frag").write_text("void main() {}\n")
    monkeypatch.setattr(sources.resources, "folder", lambda name: tmp_path / name)
    stage = G.Stage("s", _function(root / "wiring.py", "run"), data=("materials/glsl",))

    def fresh():
        monkeypatch.setattr(sources, "_MEMO", {})
        return G.source_digest(stage)

    first = fresh()
    assert G.source_digest(stage) == first
    (root / "hosts" / "glsl.py").write_text("Z = 4\n")
    second = G.source_digest(stage)
    assert second != first and second == fresh()
    (root / "hosts" / "new.py").write_text("N = 1\n")  # nobody imports it
    assert G.source_digest(stage) == second == fresh()
    (tmp_path / "materials" / "glsl" / "y.frag").write_text("\n")
    assert G.source_digest(stage) not in (first, second)



def test_a_module_named_at_run_time_is_warned_about_and_the_package_has_none(tmp_path, monkeypatch):
    """A dynamic import the key cannot follow (``import_module(name)``) warns naming its file and line; one named
    by a literal is followed without a warning; no stage and no registered host of rockdove reaches one."""
    import warnings

    from rockdove import hosts
    from rockdove.graph import stages
    from rockdove.verify.host_check import check_host

    real = [G.source_digest(s) for s in stages.make_stages(_cfg())]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        monkeypatch.setattr(sources, "_MEMO", {})
        assert [G.source_digest(s) for s in stages.make_stages(_cfg())] == real
        for host in hosts.HOSTS.values():
            sources.digest([host.render, check_host])
    plugins = "import importlib\n\n\ndef load(name):\n    return importlib.import_module(name)\n"
    root = _fake_package(tmp_path, monkeypatch, {**FAKE, "plugins.py": plugins,
                                                 "wiring.py": "def run(ctx):\n    from . import plugins\n"})
    stage = G.Stage("s", _function(root / "wiring.py", "run"))
    with pytest.warns(sources.DynamicImportWarning, match=r"plugins.py line 5 imports a module named at run time"):
        G.source_digest(stage)
    (root / "plugins.py").write_text(plugins.replace("import_module(name)", "import_module('rockdove.sdf')"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert "rockdove/sdf.py" in G.source_digest(stage, record=True)[1]["files"]

def test_the_real_stages_are_keyed_by_the_code_they_reach_and_not_by_what_they_do_not():
    """The stale keys issue 24 found: texture_images reaches srgb, geometry.sdf and geometry.neck; usd_geometry
    geometry.types; gltf geometry.types and usd.schema. None of the stages reaches the CLI, the commands, the API
    or the benchmarks, and the LUT reaches no geometry (a geometry edit reuses the bake)."""
    from rockdove.graph import stages

    graph = {s.name: s for s in stages.make_stages(_cfg())}
    files = {name: {f.removeprefix("rockdove/")
                    for f in G.source_digest(s, [graph[d] for d in s.deps], record=True)[1]["files"]}
             for name, s in graph.items()}
    assert {"srgb.py", "geometry/sdf.py", "geometry/neck.py", "textures.py"} <= files["texture_images"]
    assert "geometry/types.py" in files["usd_geometry"]
    assert {"geometry/types.py", "usd/schema.py", "web/gltf.py"} <= files["gltf"]
    assert {"verify/run.py", "render/gl.py", "verify/gl_renders.py", "hosts/glsl.py"} <= files["verify"]
    for name, fs in files.items():
        assert not {f for f in fs if f.split("/")[0] in ("commands", "bench") or f in ("cli.py", "api.py")}, name
        assert "graph/engine.py" in fs and "graph/stages.py" in fs
    assert not {f for f in files["lut"] if f.startswith("geometry/")}


def test_folder_digest_streams_the_files_a_stage_wrote(tmp_path):
    """A stage's content digest is sha256 over (relative path, NUL, bytes, NUL) of its files in path order, read
    without keeping them: a long-lived process rebuilding many assets does not hold their bytes."""
    import hashlib

    (tmp_path / "textures").mkdir()
    files = {"b.usda": b"#usda 1.0\n", "textures/a.png": bytes(range(256)) * 5000, "a.bin": b""}
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    expected = hashlib.sha256()
    for name in sorted(files, key=lambda n: str(tmp_path / n)):
        expected.update(name.encode() + b"\0" + files[name] + b"\0")
    before = sources._bytes.cache_info().currsize
    assert G.folder_digest(tmp_path) == expected.hexdigest()
    assert sources._bytes.cache_info().currsize == before


def test_a_stage_whose_data_is_missing_or_empty_cannot_be_keyed(tmp_path, monkeypatch):
    """A stage key never silently hashes nothing: a data folder that is absent or empty is an error naming it."""
    from rockdove import resources
    from rockdove.errors import ResourceMissing

    (tmp_path / "materials" / "empty").mkdir(parents=True)
    monkeypatch.setattr(resources, "folder", lambda name: tmp_path / name)
    with pytest.raises(ResourceMissing, match="materials/glsl"):
        G.source_digest(G.Stage("s", lambda ctx: 1, data=("materials/glsl",)))
    with pytest.raises(ValueError, match="'materials/empty'.*holds no files"):
        G.source_digest(G.Stage("s", lambda ctx: 1, data=("materials/empty",)))


def test_key_reads_exactly_the_declared_config(tmp_path):
    stage = G.Stage("s", standin_body, config=("lut.angles",))
    a, b, c = _cfg(), _cfg("lut.method=spectral", "geometry.seed=3"), _cfg("lut.angles=12")
    src = G.source_digest(stage)
    assert G.stage_key(stage, a, {}, src) == G.stage_key(stage, b, {}, src)
    assert G.stage_key(stage, a, {}, src) != G.stage_key(stage, c, {}, src)


def test_cached_values_are_read_only(tmp_path):
    cfg = _cfg()
    _build(tmp_path, cfg)
    g = _build(tmp_path, cfg)
    cards = g.value("cards")
    with pytest.raises(ValueError):
        cards["thickness_nm"][0] = 0
    f = g.entry_dir("usd_layers") / "pigeon.usda"
    # the mode bits, not os.access: tests run as root, who may write anything
    assert f.stat().st_mode & 0o222 == 0, oct(f.stat().st_mode)


def test_incomplete_cache_entry_is_rebuilt(tmp_path):
    cfg = _cfg()
    g = _build(tmp_path, cfg)
    meta = g.cache.entry("lut", g.records["lut"].key) / "meta.json"
    os.chmod(meta, 0o644)
    meta.unlink()  # as if killed between writing and renaming (never happens: entries are renamed complete)
    import shutil

    shutil.rmtree(meta.parent)
    g2 = _build(tmp_path, cfg)
    assert g2.records["lut"].status == "ran" and g2.records["usd_layers"].status == "reused"


def test_graph_rejects_bad_order_and_duplicates(tmp_path):
    cache = G.Cache(tmp_path)
    with pytest.raises(ValueError, match="not earlier"):
        G.Graph([G.Stage("b", standin_body, deps=("a",)), G.Stage("a", standin_body)], _cfg(), cache)
    with pytest.raises(ValueError, match="twice"):
        G.Graph([G.Stage("a", standin_body), G.Stage("a", standin_body)], _cfg(), cache)


# ------------------------------------------------------------------------------------- real stage wiring
def _real_stages(cfg, upto=None):
    """The real stages of ``rockdove build --no-verify`` for ``cfg``; with ``upto`` only those up to that stage."""
    from rockdove.graph.stages import make_stages

    stages = make_stages(cfg, verify=False)
    names = [st.name for st in stages]
    return stages if upto is None else stages[:names.index(upto) + 1]


def _real_cfg(*overrides):
    """The measured preset at the small size of the session's builds (tests/conftest.py), plus ``overrides``."""
    return load_config(preset="measured", overrides=[*SMALL_BUILD, *overrides])


def test_real_usd_stages_build_a_valid_asset_and_rebuild_incrementally(tmp_path):
    from rockdove.graph import stages as S

    cfg = _real_cfg("lut.angles=16", "lut.thicknesses=4", "lut.method=spectral_fast")
    graph = G.Graph(_real_stages(cfg), cfg, G.Cache(tmp_path / "cache"))
    graph.run()
    asset = tmp_path / "asset"
    asset.mkdir()
    graph.assemble(asset)
    names = {str(p.relative_to(asset)) for p in asset.rglob("*") if p.is_file()}
    assert {"pigeon.usda", "pigeon_payload.usda", "pigeon_looks.usda", "pigeon_geom.usdc", "pigeon.usdz",
            "textures/thinfilm_lut.exr"} <= names
    # the LUT spans exactly the (rounded-out) range on the mesh
    lo, hi = graph.value("thickness_range")
    d = graph.value("bird").part("NeckFeathers").primvars["thickness"].values
    assert lo <= d.min() and d.max() <= hi and hi - lo < (d.max() - d.min()) + 2
    from rockdove.lut.exr import read_exr

    lut = read_exr(asset / "textures" / "thinfilm_lut.exr")
    assert lut.thickness_range_nm == (lo, hi) and lut.rgb.shape == (4, 16, 3)
    # codecs round-trip exactly
    bird2 = S.BIRD.load(graph.entry_dir("bird"))
    assert np.array_equal(bird2.part("NeckFeathers").points_m, graph.value("bird").part("NeckFeathers").points_m)
    assert np.array_equal(S.LUT.load(graph.entry_dir("lut")).rgb, lut.rgb)
    # a film change re-bakes and rewrites the material; the bird is reused
    cfg2 = _real_cfg("lut.angles=16", "lut.thicknesses=4", "lut.method=spectral_fast", "film.cauchy_a=1.6")
    g2 = G.Graph(_real_stages(cfg2), cfg2, G.Cache(tmp_path / "cache"))
    g2.run()
    st = _status(g2)
    assert st["body"] == st["bird"] == st["thickness_range"] == st["texture_images"] == st["usd_geometry"] == "reused"
    assert st["lut"] == st["film_textures"] == st["usd_layers"] == st["usdz"] == "ran"
    assert st["textures"] == "reused"  # the film-independent PNGs
    geometry = "pigeon_geom.usdc"
    assert (g2.entry_dir("usd_geometry") / geometry).read_bytes() == (asset / geometry).read_bytes()


def test_half_precision_lut_is_a_half_exr_that_validates(tmp_path):
    import OpenEXR

    from rockdove.lut.exr import read_exr
    from rockdove.usd.validate import validate_asset

    cfg = _real_cfg("lut.angles=96", "lut.thicknesses=24", "lut.method=spectral_fast", "lut.precision=half",
                    "usd.usdz=false")
    graph = G.Graph(_real_stages(cfg), cfg, G.Cache(tmp_path / "cache"))
    graph.run()
    rgb = graph.value("lut").rgb
    assert np.array_equal(rgb, rgb.astype(np.float16).astype(np.float32))
    assert graph.value("lut").metadata["precision"] == "half"
    asset = tmp_path / "asset"
    asset.mkdir()
    graph.assemble(asset)
    exr = asset / "textures" / "thinfilm_lut.exr"
    with OpenEXR.File(str(exr)) as f:
        assert f.channels()["RGB"].pixels.dtype == np.float16 and f.header()["rockdove:precision"] == "half"
    assert np.array_equal(read_exr(exr).rgb, rgb)
    report = validate_asset(asset)
    assert report.clean, report.format()
    # the recorded error is that of the table as shipped (half values), not of the float32 bake
    from rockdove.graph.stages import LUT_ERROR_POINTS, film_from_config
    from rockdove.lut.reference import lut_error

    film = film_from_config(cfg["film"])
    err = lut_error(read_exr(exr), film, n_points=LUT_ERROR_POINTS)
    assert read_exr(exr).metadata["estimatedMaxDeltaE2000"] == f"{err['max']:.4g}"
    # negative control: the float32 bake of the same table measures differently, so the check above can tell
    cfg32 = _real_cfg("lut.angles=96", "lut.thicknesses=24", "lut.method=spectral_fast")
    g32 = G.Graph(_real_stages(cfg32, upto="lut"), cfg32, G.Cache(tmp_path / "cache"))
    g32.run()
    f32 = dataclasses.replace(read_exr(exr), rgb=g32.value("lut").rgb)
    assert f"{lut_error(f32, film, n_points=LUT_ERROR_POINTS)['max']:.4g}" != f"{err['max']:.4g}"


def test_build_lut_records_its_measured_error(tmp_path):
    from rockdove.graph.stages import LUT_ERROR_POINTS

    def recorded(*sets):
        cfg = _real_cfg("lut.method=spectral_fast", *sets)
        graph = G.Graph(_real_stages(cfg, upto="lut"), cfg, G.Cache(tmp_path / "cache"))
        graph.run()
        return graph.value("lut").metadata

    coarse, fine = recorded("lut.angles=16", "lut.thicknesses=4"), recorded("lut.angles=128", "lut.thicknesses=32")
    # a measurement, not a label: a 16 x 4 table over 480-700 nm is visibly off, a 128 x 32 one is not
    assert float(coarse["estimatedMaxDeltaE2000"]) > 1.0 > 0.2 > float(fine["estimatedMaxDeltaE2000"]) > 0
    for md in (coarse, fine):
        assert float(md["estimatedP99DeltaE2000"]) <= float(md["estimatedMaxDeltaE2000"])
        assert md["estimatedErrorSample"].startswith(f"{LUT_ERROR_POINTS} random points")


def test_schema_lut_defaults_are_the_bakers():
    from rockdove.config import defaults
    B = importlib.import_module("rockdove.lut.bake")  # the package re-exports the function bake

    lut = defaults()["lut"]
    assert lut["angle_warp_gamma"] == B.DEFAULT_ANGLE_WARP_GAMMA == 1.0
    assert lut["angles"] >= 256 and lut["thicknesses"] >= 64  # issue 2's default size
    assert (lut["angles"], lut["thicknesses"]) == (B.DEFAULT_ANGLES, B.DEFAULT_THICKNESSES)


# ------------------------------------------------------------------------------ concurrent processes, one cache
def _slow_counted(ctx):
    """A stage that records each run (one line per run, O_APPEND) and is slow enough for runs to overlap."""
    import time

    with open(ctx.config["log"], "a") as f:
        f.write(f"{os.getpid()}\n")
    time.sleep(0.5)
    return {"x": np.arange(1000, dtype=np.float64) * ctx.config["scale"]}


def _graph_in_process(cache_root, log, scale, start, result_q):
    start.wait()
    stages = [G.Stage("slow", _slow_counted, config=("log", "scale"), codec=G.NPZ)]
    g = G.Graph(stages, {"log": str(log), "scale": scale}, G.Cache(cache_root))
    g.run()
    result_q.put((g.records["slow"].status, g.records["slow"].digest, float(g.value("slow")["x"].sum())))


def test_cache_under_concurrent_processes_computes_each_entry_once(tmp_path):
    """Four processes build the same stage against one cache at the same moment: it runs once, the others wait
    and reuse the one entry (same digest, same value); a different key in parallel is not held up by it."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    start, q = ctx.Event(), ctx.Queue()
    log = tmp_path / "runs.log"
    procs = [ctx.Process(target=_graph_in_process, args=(tmp_path / "cache", log, 1.0, start, q)) for _ in range(4)]
    procs.append(ctx.Process(target=_graph_in_process, args=(tmp_path / "cache", tmp_path / "other.log", 2.0, start, q)))
    for p in procs:
        p.start()
    start.set()
    results = [q.get(timeout=60) for _ in procs]
    for p in procs:
        p.join(timeout=60)
        assert p.exitcode == 0
    assert len(log.read_text().split()) == 1  # computed once
    same = [r for r in results if r[2] == 999 * 1000 / 2]
    assert len(same) == 4 and sorted(r[0] for r in same) == ["ran", "reused", "reused", "reused"]
    assert len({r[1] for r in same}) == 1
    assert len((tmp_path / "other.log").read_text().split()) == 1
    # entries complete, read-only, no temporaries or lock files left behind
    left = sorted(p.name for p in (tmp_path / "cache" / "slow").iterdir())
    assert len(left) == 2 and not any(n.startswith(".") for n in left)



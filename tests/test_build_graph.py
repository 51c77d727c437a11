"""The build graph: content keys, the cache, early cut-off, fan-out items, and the incremental rules.

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


def test_verification_rerenders_only_views_whose_inputs_changed(tmp_path):
    g = _build(tmp_path, _cfg("verify.views=2"))
    assert g.records["verify"].items_ran == ["view_000", "view_001"]
    g = _build(tmp_path, _cfg("verify.views=3"))
    assert g.records["verify"].status == "ran"
    assert g.records["verify"].items_ran == ["view_002"]
    assert g.records["verify"].items_reused == ["view_000", "view_001"]
    g = _build(tmp_path, _cfg("verify.views=3", "verify.width=64"))
    assert g.records["verify"].items_ran == ["view_000", "view_001", "view_002"]


def test_code_change_invalidates_a_stage(tmp_path, monkeypatch):
    root = tmp_path / "pipeline"
    (root / "pkg").mkdir(parents=True)
    (root / "pkg" / "mod.py").write_text("X = 1\n")
    monkeypatch.setattr(G.resources, "package_root", lambda: root)
    stage = G.Stage("s", lambda ctx: {"ok": 1}, modules=("rockdove.pkg.mod",))
    before = G.source_digest(stage)
    (root / "pkg" / "mod.py").write_text("X = 2\n")
    assert G.source_digest(stage) != before
    with pytest.raises(ValueError, match="pkg.nothing"):
        G.source_digest(G.Stage("s", lambda ctx: 1, modules=("rockdove.pkg.nothing",)))


def test_source_digest_is_remembered_until_a_file_or_folder_it_read_changes(tmp_path, monkeypatch):
    """A process computes a stage's source digest once per state of its files: the remembered digest is the one a
    fresh process computes, and an edited (same size), added, removed or renamed module file in a sub-package, a
    new data file and a new sibling module of a file module each change it; links to folders are not followed."""
    from rockdove import resources

    root = tmp_path / "pipeline"
    (root / "pkg" / "sub").mkdir(parents=True)
    (root / "pkg" / "__init__.py").write_text("")
    (root / "pkg" / "sub" / "a.py").write_text("A = 1\n")
    (root / "one.py").write_text("ONE = 1\n")
    (tmp_path / "materials" / "glsl").mkdir(parents=True)
    (tmp_path / "materials" / "glsl" / "x.frag").write_text("void main() {}\n")
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "z.py").write_text("Z = 1\n")
    os.symlink(tmp_path / "elsewhere", root / "pkg" / "linked")
    monkeypatch.setattr(resources, "package_root", lambda: root)
    monkeypatch.setattr(resources, "folder", lambda name: tmp_path / name)
    stage = G.Stage("s", lambda ctx: 1, modules=("rockdove.pkg", "rockdove.one"), data=("materials/glsl",))

    def fresh():
        monkeypatch.setattr(G, "_SOURCE_MEMO", {})
        return G.source_digest(stage)

    digests = [fresh()]
    assert G.source_digest(stage) == digests[-1]  # remembered
    changes = [(lambda: (root / "pkg" / "sub" / "a.py").write_text("A = 2\n"), None),
               (lambda: (root / "pkg" / "sub" / "b.py").write_text("B = 1\n"), None),
               (lambda: (root / "pkg" / "sub" / "b.py").rename(root / "pkg" / "sub" / "c.py"), None),
               (lambda: (root / "pkg" / "sub" / "c.py").unlink(), 1),  # the files after the first edit again
               (lambda: (tmp_path / "materials" / "glsl" / "y.frag").write_text("\n"), None),
               (lambda: (root / "one").mkdir(), None)]  # rockdove.one is now a package (with no file yet)
    for change, same_as in changes:
        change()
        remembered = G.source_digest(stage) if same_as is not None or not (root / "one").is_dir() else None
        if remembered is None:  # a package with no .py file cannot be keyed, remembered or not
            with pytest.raises(ValueError, match="rockdove.one"):
                G.source_digest(stage)
            (root / "one" / "__init__.py").write_text("ONE = 1\n")
            remembered = G.source_digest(stage)
        assert remembered == fresh()
        assert remembered == digests[same_as] if same_as is not None else remembered not in digests
        digests.append(remembered)
    (tmp_path / "elsewhere" / "z.py").write_text("Z = 2\n")  # behind a link: not part of the stage
    assert G.source_digest(stage) == digests[-1] == fresh()


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
    before = G._source_bytes.cache_info().currsize
    assert G.folder_digest(tmp_path) == expected.hexdigest()
    assert G._source_bytes.cache_info().currsize == before


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


def test_planned_batch_items_are_keyed_by_their_plan_not_by_upstream_bytes(tmp_path):
    """item_plan + batch (the real verify stage's shape): items are named and keyed at run time by what they
    read; an upstream change that leaves an item's plan entry alone redoes nothing; the items to redo run in
    one call, and each keeps its own files."""
    calls = []

    def source(ctx):
        return {"content": ctx.config["x"]["content"], "metadata": ctx.config["x"]["metadata"]}

    def plan(ctx):
        content = ctx.inputs["source"]["content"]
        return {f"view_{i}": {"reads": content[i]} for i in range(len(content))}

    def run(ctx):
        calls.append(sorted(ctx.items))
        for name, item in ctx.items.items():
            (ctx.workdir / name / "image.txt").write_text(f"{name}: {item['reads']}\n")
        return {name: {"pixels": item["reads"]} for name, item in ctx.items.items()}

    def combine(ctx, views):
        return {"views": sorted(views), "pixels": [v["pixels"] for v in views.values()]}

    def stages():
        return [G.Stage("source", source, config=("x",)),
                G.Stage("verify", run, deps=("source",), item_plan=plan, batch=True, combine=combine)]

    def build(content, metadata="a"):
        cfg = {"x": {"content": content, "metadata": metadata}}
        graph = G.Graph(stages(), cfg, G.Cache(tmp_path / "cache"))
        graph.run()
        return graph, graph.records["verify"]

    g, rec = build([1, 2, 3])
    assert rec.items_ran == ["view_0", "view_1", "view_2"] and calls == [["view_0", "view_1", "view_2"]]
    assert g.value("verify") == {"views": ["view_0", "view_1", "view_2"], "pixels": [1, 2, 3]}
    item_dirs = sorted((tmp_path / "cache" / "verify.items").glob("*/value/image.txt"))
    assert sorted(p.read_text() for p in item_dirs) == ["view_0: 1\n", "view_1: 2\n", "view_2: 3\n"]
    # the source's bytes change (metadata), no plan entry does: the stage reruns, no item does
    g, rec = build([1, 2, 3], metadata="b")
    assert g.records["source"].status == "ran" and rec.status == "ran"
    assert rec.items_ran == [] and rec.items_reused == ["view_0", "view_1", "view_2"] and len(calls) == 1
    # one item's input changes: only it runs, alone in the batch
    g, rec = build([1, 5, 3], metadata="b")
    assert rec.items_ran == ["view_1"] and calls[-1] == ["view_1"]
    assert g.value("verify")["pixels"] == [1, 5, 3]
    # a whole-stage reuse still says which items it holds
    g, rec = build([1, 5, 3], metadata="b")
    assert rec.status == "reused" and rec.items_reused == ["view_0", "view_1", "view_2"]
    assert not list((tmp_path / "cache" / "verify.items").glob(".tmp-*"))  # the batch scratch is gone


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



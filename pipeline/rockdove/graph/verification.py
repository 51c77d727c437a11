"""The one verification, run by the build's ``verify`` stage and by ``rockdove verify`` alike, and its cache.

The renders are items, each an entry of the stage cache (folders ``verify.<kind>``) keyed by what it reads:

- ``surface``, per camera: what the reference shades at its primary hits before any light or film, so a film
  change reuses it;
- ``view``, per view: the GL render against the reference, its images and checks; keyed by the scene content it
  renders (:func:`rockdove.verify.inputs.scene_digest`: not the usdz or file paths) and the view;
- ``host``, per host: its metrics and images over the views; keyed by the scene content, the views and its lobe.

Each key also holds the code the item can execute (:mod:`rockdove.sources`) and the installed distributions. So
``rockdove verify`` and a build reuse each other's views, and an edit to one host's code re-renders that host alone.
A host that failed is not kept. Validation and the report are redone every time.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

from ..config import canonical_json
from .. import sources
from .engine import GRAPH_VERSION, Cache, load_npz

#: The hosts the build verifies with: the GL renders alone (a cold build's verification takes seconds).
BUILD_HOSTS = ("glsl",)


def item_key(kind: str, fns: tuple, *reads) -> str:
    """The key of an item that ``fns`` compute from ``reads`` (the code they can execute: rockdove.sources)."""
    code = sources.digest(list(fns))[0]
    return hashlib.sha256(canonical_json([GRAPH_VERSION, kind, code, *reads]).encode()).hexdigest()


class _Items:
    """The cache entries of one kind of item: ``<cache>/verify.<kind>/<key>/value/``. A cache that cannot be
    written (a full disk, a read-only folder, a file in its place) only costs time: nothing is kept, the scratch
    folders go into ``spare`` (the report's folder) instead."""

    def __init__(self, cache: Cache, kind: str, spare: str):
        self.cache, self.name, self.spare = cache, f"verify.{kind}", spare

    def get(self, key: str) -> str | None:
        return str(self.cache.entry(self.name, key) / "value") if self.cache.lookup(self.name, key) else None

    def put(self, key: str, src, meta: dict) -> str | None:
        """Store the files of folder ``src`` (linked: ``src`` keeps them) and ``item.json`` (``meta``); the
        entry's folder, or None when the cache cannot keep it."""
        def fill(folder):
            for name in os.listdir(src):
                if name != ".owner":  # the scratch folder's own (rockdove.graph.engine.Cache.temporary)
                    try:
                        os.link(os.path.join(src, name), folder / name)
                    except OSError:  # another file system, or one without hard links
                        shutil.copyfile(os.path.join(src, name), folder / name)
            (folder / "item.json").write_text(json.dumps(meta, sort_keys=True, default=_plain))
        try:
            self.cache.store(self.name, key, fill)
        except OSError:
            return None
        return self.get(key)

    @contextlib.contextmanager
    def scratch(self):
        with contextlib.ExitStack() as stack:
            try:
                tmp = stack.enter_context(self.cache.temporary(self.cache.root / self.name))
            except OSError:
                tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix=".scratch-", dir=self.spare)))
            yield tmp


def _plain(o):
    return o.tolist() if hasattr(o, "tolist") else str(o)


def _meta(folder: str) -> dict:
    with open(os.path.join(folder, "item.json")) as f:
        return json.load(f)


def _surfaces(cache: Cache, scene, views, ran: dict, reused: dict, out: str) -> dict:
    """The reference's :class:`~rockdove.verify.reference_image.Surface` of every camera of ``views``."""
    import numpy as np

    from ..verify.rays import camera_key
    from ..verify.reference_image import Surface, cast_surfaces, surface_digest

    items, digest, cameras = _Items(cache, "surface", out), surface_digest(scene), {}
    for v in views:
        cameras.setdefault(camera_key(v), v)
    keys = {cam: item_key("surface", (cast_surfaces,), digest, cam) for cam in cameras}
    found = {cam: items.get(k) for cam, k in keys.items()}
    fresh = cast_surfaces(scene, [v for cam, v in cameras.items() if found[cam] is None])
    for cam, s in fresh.items():
        with items.scratch() as tmp:
            np.savez(tmp / "surface.npz", **s.to_arrays())
            items.put(keys[cam], tmp, {"camera": cam, "stats": s.stats})
    out = {cam: Surface.from_arrays(load_npz(os.path.join(d, "surface.npz")), _meta(d)["stats"])
           for cam, d in found.items() if d is not None}
    ran["surfaces"], reused["surfaces"] = [c[:16] for c in fresh], [c[:16] for c in out]
    return {**out, **fresh}


def _views(cache: Cache, scene, lut, views, digest, surfaces, redo_all: bool, out: str, say, ran, reused):
    """``({view: result}, fresh)``: each view's :func:`render_and_check`, cached per view; ``fresh``: the GL
    radiance and references of the views rendered (all when ``redo_all``). A failed GL render is not kept."""
    import numpy as np

    from ..verify.run import render_and_check

    items = _Items(cache, "view", out)
    keys = {v.name: item_key("view", (render_and_check,), digest, v.to_dict()) for v in views}
    found = {n: items.get(k) for n, k in keys.items()}
    todo = [v for v in views if redo_all or found[v.name] is None]
    fresh, results = {}, {}
    if todo:
        with items.scratch() as tmp:
            results, fresh["refs"], fresh["gl"] = render_and_check(scene, lut, todo, str(tmp), say=say,
                                                                   surfaces=surfaces)
            for v in todo:
                r = results[v.name]
                if r["metrics"] is not None:  # a failed GL render is not kept: asked again next time
                    np.savez(os.path.join(r["dir"], "sheet_row.npz"), *r["sheet_row"])
                    found[v.name] = items.put(keys[v.name], r["dir"],
                                              {k: x for k, x in r.items() if k not in ("sheet_row", "dir")})
                if r["metrics"] is None or found[v.name] is None:  # not kept: its images go to the report now
                    for f in r["files"].values():
                        shutil.copyfile(os.path.join(r["dir"], f), os.path.join(out, f))
                    found[v.name] = r["dir"] = out
    done = {v.name: results[v.name] for v in todo if found[v.name] == out}
    for v in views:
        if v.name in done:
            continue
        r = done[v.name] = _meta(found[v.name])
        rows = load_npz(os.path.join(found[v.name], "sheet_row.npz"))
        r["sheet_row"], r["dir"] = [rows[f"arr_{i}"] for i in range(len(rows))], found[v.name]
    ran["views"], reused["views"] = [v.name for v in todo], [v.name for v in views if v not in todo]
    return {v.name: done[v.name] for v in views}, fresh


def _host_key(host, digest: str, views, layers: str) -> str:
    """A host renders the asset's files as they are (its networks, not only the scene :func:`scene_digest`
    reads): ``layers`` is :func:`rockdove.usd.dependencies.asset_digest`."""
    from ..verify.host_check import check_host

    return item_key("host", (host.render, check_host), digest, layers, [v.to_dict() for v in views], host.name,
                    host.lobe, host.variant)


def _host(cache, host, layer, scene, views, digest, layers, refs, fresh, out, say) -> tuple[dict, dict, bool]:
    """One host's report entry, image files in ``out`` (where it renders) and whether they came from the cache."""
    from ..verify.host_check import check_host

    items = _Items(cache, "host", out)
    key = _host_key(host, digest, views, layers)
    found = items.get(key)
    if found is not None:
        value = _meta(found)
        for name in _files(value["files"]):
            shutil.copyfile(os.path.join(found, name), os.path.join(out, name))
        return value["entry"], value["files"], True
    rendered = fresh["gl"] if host.name == "glsl" else None
    entry, files = check_host(host, layer, scene, views, refs(host.lobe), out, rendered, say)
    if entry.get("passed") is not None and "error" not in entry:  # one skipped or failed is asked again
        with items.scratch() as tmp:
            for name in _files(files):
                shutil.copyfile(os.path.join(out, name), tmp / name)
            items.put(key, tmp, {"entry": entry, "files": files})
    return entry, files, False


def _files(files: dict) -> set:
    return {name for per_view in files.values() for name in per_view.values()}


def _motion(cache, layer, lut, motion, times, width, height, out, say, results, ran, reused) -> dict:
    """The motion's measures, and its frames checked as views (added to ``results``, their items to ``ran`` /
    ``reused``): the report's ``motion`` entry."""
    from ..render.scene import load_scene
    from ..verify.inputs import scene_digest
    from ..verify.motion import frame_views, measure_motion

    say(f"motion {motion}: measured at every time code")
    entry = measure_motion(layer, motion)
    entry["times"], entry["views"] = list(times), []
    for t in times:
        say(f"motion {motion}: the film at time code {t:g}")
        scene = load_scene(layer, {"motion": motion}, t)
        views = frame_views(scene, width, height, f"{motion}{t:03.0f}")
        did, kept = {}, {}
        surfaces = _surfaces(cache, scene, views, did, kept, out)
        frame, _ = _views(cache, scene, lut, views, scene_digest(scene), surfaces, False, out, say, did, kept)
        results.update(frame)
        entry["views"] += list(frame)
        for into, items in ((ran, did), (reused, kept)):
            for kind, names in items.items():
                into[kind] = list(into.get(kind, [])) + list(names)
    return entry


def default_cache(asset) -> str:
    """A verification's cache when none is given: the build's (``.rockdove-cache`` beside the asset folder) when
    there is one, else the user cache's ``verify/`` (:func:`rockdove.resources.user_cache_dir`)."""
    from ..resources import user_cache_dir

    beside = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(asset))), ".rockdove-cache")
    return beside if os.path.isdir(beside) else str(user_cache_dir("verify"))


def verify(asset, hosts=BUILD_HOSTS, *, cache=None, out_dir=None, width=None, height=None, n_views=None,
           views=None, bench_dir=None, progress=None, beauty=None, published_asset=None, motion=None,
           times=None) -> dict:
    """Validate, render and check the asset of root layer ``asset``; write the report into ``out_dir`` (default
    ``verify/`` beside it); return the content of report.json (``cache``: the items that ran and were reused).

    ``hosts``: :data:`rockdove.hosts.HOSTS` names (None: :data:`rockdove.hosts.DEFAULT`; ``["all"]``); ``glsl``
    always runs; an unavailable host is skipped with its reason. ``cache``: a folder or a :class:`Cache` (default
    :func:`default_cache`). ``width``, ``height``, ``n_views``: default the schema's ``[verify]``; ``views``: only
    these (a subset without a light-sweep view cannot run the hue check). ``beauty``: ``[beauty]`` settings of the
    report's opening picture (``auto`` takes Cycles only when ``hosts`` names blender); ``published_asset``: the
    root layer's path once published, which the report names. ``motion`` (e.g. ``"walk"``): also measure that
    motion at every time code (:func:`rockdove.verify.motion.measure_motion`) and check the film at ``times``
    (default :data:`rockdove.verify.motion.DEFAULT_TIMES`), each frame skinned by UsdSkel, in
    :func:`rockdove.verify.motion.frame_views`.
    """
    from ..hosts import select
    from ..render.beauty import settings
    from ..usd.dependencies import asset_digest
    from ..verify.inputs import scene_digest, select_views, sizes, verification_scene, verification_views
    from ..verify.reference_image import render_reference
    from ..verify.verdict import combine, default_out_dir

    width, height, n_views = sizes(width, height, n_views)
    say = progress or (lambda msg: None)
    t_start = time.perf_counter()
    selection = select(hosts)  # unknown names: ValueError before any work
    layer, scene, lut, notes = verification_scene(asset)
    if motion is not None:
        from ..verify.motion import motion_times

        times = motion_times(layer, motion, times)  # a bad motion or time: UsageError before any render
    out = os.path.abspath(os.fspath(out_dir)) if out_dir else default_out_dir(layer)
    os.makedirs(out, exist_ok=True)
    cache = cache if isinstance(cache, Cache) else Cache(cache or default_cache(layer))
    chosen = select_views(verification_views(scene, width, height, n_views), views)
    digest, layers, ran, reused = scene_digest(scene), asset_digest(layer), {}, {}
    say(f"GL renders and CPU reference ({len(chosen)} views)")
    surfaces = _surfaces(cache, scene, chosen, ran, reused, out)
    glsl = next(h for h in selection.available if h.name == "glsl")
    redo = _Items(cache, "host", out).get(_host_key(glsl, digest, chosen, layers)) is None  # its images: the GL renders
    results, fresh = _views(cache, scene, lut, chosen, digest, surfaces, redo, out, say, ran, reused)
    lobes = {"half_angle": fresh["refs"]} if redo else {}
    motion_entry = None if motion is None else _motion(cache, layer, lut, motion, times, width, height, out, say,
                                                       results, ran, reused)

    def refs(lobe):
        if lobe not in lobes:
            say(f"CPU reference ({lobe})")
            lobes[lobe] = render_reference(scene, chosen, lobe=lobe, surfaces=surfaces)
        return lobes[lobe]

    t = time.perf_counter()
    entries, images, ran["hosts"], reused["hosts"] = [], {}, [], []
    for host in selection.available:
        entry, files, cached = _host(cache, host, layer, scene, chosen, digest, layers, refs, fresh, out, say)
        entries.append(entry)
        images.update({host.name: files} if files else {})
        (reused if cached else ran)["hosts"].append(host.name)
    entries += [{"name": n, "skipped": True, "reason": r, "passed": None} for n, r in selection.unavailable.items()]
    named = hosts is not None and "blender" in hosts  # auto: Cycles only when asked for (2-4 min of CPU)
    beauty = {**settings(beauty), "cycles_ok": named and any(h.name == "blender" for h in selection.available)}
    return combine(layer, scene, lut, notes, results, out, width, height, bench_dir, say, t_start=t_start,
                   reused=reused["views"], hosts=(entries, images, time.perf_counter() - t), beauty=beauty,
                   published_asset=published_asset, items={"ran": ran, "reused": reused}, motion=motion_entry)


"""The one verification, run by the build's ``verify`` stage and by ``rockdove verify`` alike, and its cache.

The renders are items, each an entry of the stage cache (folders ``verify.<kind>``) keyed by what it reads: a
``surface`` per camera (the reference's shading inputs before any light or film: a film change reuses it); a
``view`` per view (GL render against the reference, images, checks; keyed by the scene content,
:func:`rockdove.verify.inputs.scene_digest`, not file paths); a ``host`` per host (keyed by the scene content, the
views and its lobe); ``beauty`` and ``animation``, the report's pictures (the scene and the ``[beauty]`` settings).

Each key also holds the code the item can execute (:mod:`rockdove.sources`) and the installed distributions. So
``rockdove verify`` and a build reuse each other's views, and an edit to one host's code re-renders that host alone.
A host that failed is not kept. Validation and the report are redone every time."""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import logging
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from .. import sources
from ..cache import KEY_VERSION, Cache
from ..config import canonical_json
from ..hosts import select
from ..hosts.beauty import for_report as draw_beauty
from ..render.animation import for_report as draw_animation
from ..render.beauty import settings as beauty_settings
from ..render.scene import load_scene
from ..resources import load_npz, user_cache_dir
from ..usd.dependencies import asset_digest
from .host_check import check_host
from .inputs import scene_digest, select_views, sizes, verification_scene, verification_views
from .motion import animation, frame_prefix, frame_views, measure_motion, motion_times
from .rays import camera_key
from .reference_image import Surface, cast_surfaces, render_reference, surface_digest
from .results import HostResult, ItemNames, ItemsUsed, MotionCheck, ViewResult
from .run import render_and_check
from .verdict import Checked, combine, default_out_dir

_log = logging.getLogger(__name__)
#: The hosts the build verifies with: the GL renders alone (a cold build's verification takes seconds).
BUILD_HOSTS = ("glsl",)


def item_key(kind: str, fns: tuple, *reads) -> str:
    """The key of an item that ``fns`` compute from ``reads``: the code they can execute (rockdove.sources) and the
    ``materials`` they read at run time (the GLSL shaders, the MaterialX documents, the add-on)."""
    code = sources.digest(list(fns), data=("materials",))[0]
    return hashlib.sha256(canonical_json([KEY_VERSION, kind, code, *reads]).encode()).hexdigest()


class _Items:
    """The cache entries of one kind of item: ``<cache>/verify.<kind>/<key>/value/``. A cache that cannot be written
    only costs time: nothing is kept, the scratch folders go into ``spare`` (the report's folder) instead."""

    def __init__(self, cache: Cache, kind: str, spare: str):
        self.cache, self.name, self.spare = cache, f"verify.{kind}", spare

    def get(self, key: str) -> str | None:
        return str(self.cache.entry(self.name, key) / "value") if self.cache.lookup(self.name, key) else None

    def put(self, key: str, src, meta: dict) -> str | None:
        """Store the files of ``src`` (linked) and ``item.json`` (``meta``); the entry's folder, or None if not kept."""
        def fill(folder):
            for name in os.listdir(src):
                if name != ".owner":  # the scratch folder's own (rockdove.cache.Cache.temporary)
                    try:
                        os.link(os.path.join(src, name), folder / name)
                    except OSError:  # another file system, or one without hard links
                        shutil.copyfile(os.path.join(src, name), folder / name)
            (folder / "item.json").write_text(json.dumps(
                meta, sort_keys=True, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
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


def _meta(folder: str) -> dict:
    with open(os.path.join(folder, "item.json")) as f:
        return json.load(f)


def _surfaces(cache: Cache, scene, views, out: str) -> tuple[dict, list, list]:
    """The reference's :class:`~rockdove.verify.reference_image.Surface` by camera, and the cameras cast and reused."""
    items, digest = _Items(cache, "surface", out), surface_digest(scene)
    cameras = {camera_key(v): v for v in views}  # views of one camera share its surface
    keys = {cam: item_key("surface", (cast_surfaces,), digest, cam) for cam in cameras}
    found = {cam: items.get(k) for cam, k in keys.items()}
    fresh = cast_surfaces(scene, [v for cam, v in cameras.items() if found[cam] is None])
    for cam, s in fresh.items():
        with items.scratch() as tmp:
            np.savez(tmp / "surface.npz", **s.to_arrays())
            items.put(keys[cam], tmp, {"camera": cam, "stats": s.stats})
    kept = {cam: Surface.from_arrays(load_npz(os.path.join(d, "surface.npz")), _meta(d)["stats"])
            for cam, d in found.items() if d is not None}
    return {**kept, **fresh}, [c[:16] for c in fresh], [c[:16] for c in kept]


def _views(cache: Cache, scene, lut, views, digest, surfaces, redo_all: bool, out: str):
    """``({view: ViewResult}, references, {view: GL radiance}, names rendered)``: each view's
    :func:`render_and_check`, cached per view; the references and radiance of the views rendered (all when
    ``redo_all``; None when none)."""
    items = _Items(cache, "view", out)
    keys = {v.name: item_key("view", (render_and_check,), digest, v.to_dict()) for v in views}
    found = {n: items.get(k) for n, k in keys.items()}
    todo = [v for v in views if redo_all or found[v.name] is None]
    refs = gl = None
    done: dict[str, ViewResult] = {}
    if todo:
        with items.scratch() as tmp:
            results, refs, gl = render_and_check(scene, lut, todo, str(tmp), surfaces=surfaces)
            for v in todo:
                r = results[v.name]
                if r.metrics is not None:  # a failed GL render is not kept: asked again next time
                    np.savez(os.path.join(r.folder, "sheet_row.npz"), *r.sheet_row)
                    found[v.name] = items.put(keys[v.name], r.folder, r.to_json())
                if r.metrics is None or found[v.name] is None:  # not kept: its images go to the report now
                    for f in r.files.values():
                        shutil.copyfile(os.path.join(r.folder, f), os.path.join(out, f))
                    done[v.name] = dataclasses.replace(r, folder=out)
    for v in views:
        if v.name not in done:
            folder = str(found[v.name])  # cached, or stored above
            rows = load_npz(os.path.join(folder, "sheet_row.npz"))
            done[v.name] = ViewResult.from_json(_meta(folder), folder,
                                                tuple(rows[f"arr_{i}"] for i in range(len(rows))))
    return {v.name: done[v.name] for v in views}, refs, gl, [v.name for v in todo]


def _host_key(host, digest: str, views, layers: str) -> str:
    """A host renders the asset's files as they are: ``layers`` is :func:`rockdove.usd.dependencies.asset_digest`."""
    return item_key("host", (host.render, check_host), digest, layers, [v.to_dict() for v in views], host.name,
                    host.lobe, host.variant)


def _host(cache, host, layer, scene, views, digest, layers, refs, gl, out):
    """One host's :class:`~rockdove.verify.results.HostResult` (its images in ``out``) and whether it was cached."""
    items = _Items(cache, "host", out)
    key = _host_key(host, digest, views, layers)
    found = items.get(key)
    if found is not None:
        value = _meta(found)
        for name in _files(value["files"]):
            shutil.copyfile(os.path.join(found, name), os.path.join(out, name))
        return HostResult.from_json(value["entry"], value["files"]), True
    rendered = gl if host.name == "glsl" else None
    result = check_host(host, layer, scene, views, refs(host.lobe), out, rendered)
    if result.status in ("passed", "failed"):  # one skipped or failed is asked again
        with items.scratch() as tmp:
            for name in _files(result.files):
                shutil.copyfile(os.path.join(out, name), tmp / name)
            items.put(key, tmp, {"entry": result.to_json(), "files": result.files})
    return result, False


def _pictures(cache, layer, scene, lut, digest: str, layers: str, settings: dict,
              out: str) -> tuple[dict, tuple, tuple]:
    """The report's pictures (beauty and animation), ``{kind: (entry or None, note or None)}``, the kinds drawn and
    reused, their files copied into ``out``; one drawn other than as asked (with a note) is not kept."""
    draw = {"beauty": lambda tmp: draw_beauty(layer, scene, tmp, settings, cycles_ok=settings.get("cycles_ok", False),
                                         lut=lut),
            "animation": lambda tmp: draw_animation(scene, tmp, settings, lut=lut)}
    pictures: dict[str, tuple] = {}
    ran: list[str] = []
    reused: list[str] = []
    for kind, fn in (("beauty", draw_beauty), ("animation", draw_animation)):
        # the beauty may be Cycles through the add-on, which reads the asset's files as composed (as a host does)
        reads = (digest, settings, layers) if kind == "beauty" else (digest, settings)
        items, key = _Items(cache, kind, out), item_key(kind, (fn,), *reads)
        found = items.get(key)
        if found is not None:
            entry, note = _meta(found)["entry"], None
            for name in (entry or {}).get("files", {}).values():
                shutil.copyfile(os.path.join(found, name), os.path.join(out, name))
        else:
            with items.scratch() as tmp:
                entry, note = draw[kind](str(tmp))
                for name in (entry or {}).get("files", {}).values():
                    shutil.copyfile(tmp / name, os.path.join(out, name))
                if entry is not None and note is None:
                    items.put(key, tmp, {"entry": entry})
        if entry is not None:
            (reused if found is not None else ran).append(kind)
        pictures[kind] = entry, note
    return pictures, tuple(ran), tuple(reused)


def _files(files: dict) -> set:
    return {name for per_view in files.values() for name in per_view.values()}


def _motion(cache, layer, lut, motion, times, width, height, out) -> tuple[MotionCheck, dict, list[list[str]]]:
    """The report's motion check, its frames checked as views and their items (surfaces cast, kept, views)."""
    _log.info(f"motion {motion}: measured at every time code")
    measured = measure_motion(layer, motion)
    results: dict = {}
    items: list[list[str]] = [[], [], []]
    for t in times:
        _log.info(f"motion {motion}: the film at time code {t:g}")
        scene = load_scene(layer, {"motion": motion}, t)
        views = frame_views(scene, width, height, frame_prefix(motion, t))
        surfaces, cast, kept = _surfaces(cache, scene, views, out)
        frame, _, _, rendered = _views(cache, scene, lut, views, scene_digest(scene), surfaces, False, out)
        results.update(frame)
        for into, names in zip(items, (cast, kept, rendered)):
            into += names
    _log.info(f"motion {motion}: its animation")
    checked = dataclasses.replace(measured, times=tuple(times), views=tuple(results))
    try:  # a picture, not a measurement: the report goes on without it
        checked = dataclasses.replace(checked, animation=animation(layer, motion, out, lut))
    except Exception as exc:  # noqa: BLE001 - any renderer's error
        checked = dataclasses.replace(checked, notes=(f"no {motion} animation: {type(exc).__name__}: {exc}",))
    return checked, results, items


def default_cache(asset) -> str:
    """A verification's cache when none is given: the build's (``.rockdove-cache`` beside the asset folder) when
    there is one, else the user cache's ``verify/`` (:func:`rockdove.resources.user_cache_dir`)."""
    beside = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(asset))), ".rockdove-cache")
    return beside if os.path.isdir(beside) else str(user_cache_dir("verify"))


def verify(asset, hosts=BUILD_HOSTS, *, cache=None, out_dir=None, width=None, height=None, n_views=None,
           views=None, bench_dir=None, beauty=None, published_asset=None, motion=None, times=None):
    """Validate, render and check the asset of root layer ``asset``; write the report into ``out_dir`` (default
    ``verify/`` beside it); return it (:class:`rockdove.verify.results.Report`). Progress goes to this module's logger.

    ``hosts``: :data:`rockdove.hosts.HOSTS` names (None: :data:`rockdove.hosts.DEFAULT`; ``["all"]``); ``glsl``
    always runs; an unavailable host is skipped with its reason. ``cache``: a folder or a :class:`Cache` (default
    :func:`default_cache`). ``width``, ``height``, ``n_views``: default the schema's ``[verify]``; ``views``: only
    these (without a light-sweep view, no hue check). ``beauty``: ``[beauty]`` settings (``auto`` takes Cycles only
    when ``hosts`` names blender); ``published_asset``: the root layer's path once published, which the report names.
    ``motion`` (e.g. ``"walk"``): also measure it at every time code and check the film at ``times`` (default
    :data:`rockdove.verify.motion.DEFAULT_TIMES`), each frame skinned by UsdSkel."""
    width, height, n_views = sizes(width, height, n_views)
    t_start = time.perf_counter()
    selection = select(hosts)  # unknown names: UsageError before any work
    layer, scene, lut, notes = verification_scene(asset)
    if motion is not None:
        times = motion_times(layer, motion, times)  # a bad motion or time: UsageError before any render
    out = os.path.abspath(os.fspath(out_dir)) if out_dir else default_out_dir(layer)
    os.makedirs(out, exist_ok=True)
    cache = cache if isinstance(cache, Cache) else Cache(cache or default_cache(layer))
    chosen = select_views(verification_views(scene, width, height, n_views), views)
    digest, layers = scene_digest(scene), asset_digest(layer)
    _log.info(f"GL renders and CPU reference ({len(chosen)} views)")
    surfaces, cast, kept = _surfaces(cache, scene, chosen, out)
    glsl = next(h for h in selection.available if h.name == "glsl")
    redo = _Items(cache, "host", out).get(_host_key(glsl, digest, chosen, layers)) is None  # its images: the GL renders
    results, fresh_refs, gl, rendered = _views(cache, scene, lut, chosen, digest, surfaces, redo, out)
    lobes = {"half_angle": fresh_refs} if redo else {}
    motion_entry, frames, (m_cast, m_kept, m_rendered) = (None, {}, ([], [], [])) if motion is None else _motion(
        cache, layer, lut, motion, times, width, height, out)

    def refs(lobe):
        if lobe not in lobes:
            _log.info(f"CPU reference ({lobe})")
            lobes[lobe] = render_reference(scene, chosen, lobe=lobe, surfaces=surfaces)
        return lobes[lobe]

    t = time.perf_counter()
    checked = [_host(cache, h, layer, scene, chosen, digest, layers, refs, gl, out) for h in selection.available]
    host_results = (*(r for r, _ in checked),
                    *(HostResult(n, "skipped", reason=why) for n, why in selection.unavailable.items()))
    named = hosts is not None and "blender" in hosts  # auto: Cycles only when asked for (2-4 min of CPU)
    beauty = {**beauty_settings(beauty), "cycles_ok": named and any(h.name == "blender" for h in selection.available)}
    ran_hosts = tuple(r.name for r, cached in checked if not cached)
    rendered, views_checked = [*rendered, *m_rendered], [*results.values(), *frames.values()]
    items = ItemsUsed(ItemNames(tuple(cast + m_cast), tuple(rendered), ran_hosts),
                      ItemNames(tuple(kept + m_kept), tuple(r.view for r in views_checked if r.view not in rendered),
                                tuple(r.name for r, cached in checked if cached)))
    return combine(Checked(layer, scene, lut, tuple(notes), tuple(views_checked), host_results, items,
                           (width, height), time.perf_counter() - t, t_start, motion_entry), out, bench_dir=bench_dir,
                   pictures=lambda: _pictures(cache, layer, scene, lut, digest, layers, beauty, out),
                   published_asset=published_asset)

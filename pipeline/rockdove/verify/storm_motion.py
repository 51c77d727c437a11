"""A motion of the asset played by Hydra Storm and measured in Storm's own pictures.

Storm skins a UsdSkel mesh itself (its ExtComputations), so nothing here poses a point: the Storm job
(:mod:`rockdove.hosts.storm_job`) selects the ``motion`` variant and records each view at its time code. Per time
code: ``head`` and ``trunk``, a fixed side camera seeing only :data:`HEAD_PARTS` or :data:`TRUNK_PARTS`, whose
silhouette's centre (Storm's alpha) must move as UsdSkel moves their joint (``ComputeJointWorldTransforms``)
projected through the same camera (``*_error_px``: the distance between the two displacements since the first time
code); ``neck``, the ``storm`` host's baked film on the neck against the exact ``view_angle`` reference of the same
frame (:func:`rockdove.verify.host_check.host_metrics`). :func:`strip` draws the side view with materials as authored.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import os

import numpy as np
import OpenEXR
from pxr import Usd, UsdGeom, UsdSkel

from ..errors import UsageError
from ..hosts import bpy_runner
from ..hosts.base import ENVIRONMENT_RADIANCE, HostError
from ..hosts.jobs import JobView, StormJob
from ..hosts.storm import BAKED, FEATHER_MATERIAL, TIMEOUT_S, VARIANTS
from ..png import save_png
from ..render.scene import load_scene
from ..render.views import View, default_views, look_at
from ..srgb import linear_to_srgb8
from ..usd.layout import resolve_root_layer
from .host_check import host_metrics
from .reference_image import render_reference

#: Parts rigid on the head, and the parts that ride the trunk (each wing feather on a wing joint under the chest).
HEAD_PARTS, TRUNK_PARTS = ("Beak", "Cere", "Eyes", "EyeRings"), ("Wings",)
HEAD_JOINT, TRUNK_JOINT = "head", "chest"


def side_view(scene, times, width: int, height: int):
    """A still camera on the bird's left (+X), level, framing its bounds at every one of ``times``."""
    bounds = np.concatenate([load_scene(scene.root_layer, scene.variants, t).bounds_m for t in times])
    lo, hi = bounds.min(axis=0), bounds.max(axis=0)
    centre, yfov = 0.5 * (lo + hi), np.radians(30.0)
    half = 0.55 * max(hi[1] - lo[1], (hi[2] - lo[2]) * height / width)
    eye = centre + np.array([hi[0] - centre[0] + half / np.tan(yfov / 2), 0.0, 0.0])
    return View("side", look_at(eye, centre), yfov, width, height, (0.3, 0.8, 0.5), (1.0, 1.0, 1.0))


def project(view, points) -> np.ndarray:
    """(N, 2) pixel coordinates (x right, y down, pixel centres at +0.5) of world ``points`` (N, 3) in ``view``."""
    cam = (np.c_[np.asarray(points, np.float64), np.ones(len(points))] @ np.linalg.inv(view.camera_to_world).T)[:, :3]
    focal = 0.5 * view.height / np.tan(0.5 * view.yfov_rad)
    return np.stack([0.5 * view.width + focal * cam[:, 0] / -cam[:, 2],
                     0.5 * view.height - focal * cam[:, 1] / -cam[:, 2]], axis=1)


def joint_positions(layer: str, motion: str, times, joints) -> np.ndarray:
    """(T, len(joints), 3) world positions, metres, of the named joints (leaf names) at ``times`` of ``motion``."""
    stage = Usd.Stage.Open(layer, Usd.Stage.LoadAll)
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        stage.GetDefaultPrim().GetVariantSet("motion").SetVariantSelection(motion)
    skel = next(UsdSkel.Skeleton(p) for p in stage.Traverse() if p.IsA(UsdSkel.Skeleton))
    query = UsdSkel.Cache().GetSkelQuery(skel)
    leaves = [str(j).rsplit("/", 1)[-1] for j in query.GetJointOrder()]
    index = [leaves.index(j) for j in joints]
    return np.stack([np.asarray(query.ComputeJointWorldTransforms(UsdGeom.XformCache(float(t))))[index, 3, :3]
                     for t in times])


def _alpha(path: str) -> np.ndarray:
    with OpenEXR.File(path) as f:
        return np.asarray(f.channels()["RGBA"].pixels, np.float64)[..., 3]


def _centre(alpha, name) -> np.ndarray:
    """Alpha-weighted centre (x, y) of a silhouette, pixels."""
    if alpha.sum() < 4:
        raise HostError(BAKED.name, f"Storm drew no {name} (alpha sums to {alpha.sum():.2f})")
    y, x = np.mgrid[:alpha.shape[0], :alpha.shape[1]] + 0.5
    return np.array([(x * alpha).sum(), (y * alpha).sum()]) / alpha.sum()


def _view(view, time: float, name: str | None = None, only=None) -> JobView:
    """``view`` drawn at ``time`` (renamed ``name``), of the meshes ``only`` (prim names; else all)."""
    (job,) = bpy_runner.job_views([dataclasses.replace(view, name=name or view.name)])
    return dataclasses.replace(job, time=float(time), only=only and list(only))


def _run(layer: str, work: str, views: list[JobView], motion: str, as_authored: bool = False) -> None:
    os.makedirs(work, exist_ok=True)
    save_png(np.full((2, 4, 3), 255, np.uint8), os.path.join(work, "white.png"))  # the dome light's texture
    job = StormJob(asset=layer, variant=BAKED.variant, overrides={FEATHER_MATERIAL: VARIANTS[BAKED.name][1]},
                   environment_radiance=ENVIRONMENT_RADIANCE, out_dir=work, views=views, motion=motion,
                   as_authored=as_authored)
    bpy_runner.run_job(job, work, importlib.util.find_spec("rockdove.hosts.storm_job").origin, TIMEOUT_S,
                       host=BAKED.name, renderer="Storm")


def strip(asset: str, out_png: str, motion: str = "walk", times=tuple(range(0, 25, 3)), *, size=(320, 240)) -> str:
    """``out_png``: Storm's frames of ``motion`` at ``times`` from :func:`side_view`, side by side (work files in
    ``<out_png>.storm/``); returns its path."""
    layer = resolve_root_layer(asset)
    side = side_view(load_scene(layer, {"motion": motion}, times[0]), times, *size)
    views = [dataclasses.replace(side, name=f"frame_{t:03.0f}") for t in times]
    work = os.path.abspath(os.fspath(out_png)) + ".storm"
    _run(layer, work, [_view(v, t) for v, t in zip(views, times)], motion, as_authored=True)
    images = bpy_runner.read_views(BAKED.name, "Storm", views, work)
    save_png(np.concatenate([linear_to_srgb8(images[v.name]) for v in views], axis=1), os.fspath(out_png))
    return os.fspath(out_png)


def play(asset: str, out_dir: str, motion: str = "walk", times=(15.0, 21.0, 26.0), *, size=(256, 192),
         neck_size: int = 128, film: bool = True) -> dict:
    """Draw ``motion`` in Storm at ``times`` into ``out_dir/storm_motion``: ``{"times", "head_error_px",
    "trunk_error_px", "head_travel_px", "trunk_travel_px"`` (per time code), ``"film"`` (per time code: the neck's
    :func:`host_metrics`), ``"work"}``. UsageError for a motion or time the asset has not; HostError if Storm fails."""
    layer = resolve_root_layer(asset)
    times = [float(t) for t in times]
    scenes = {t: load_scene(layer, {"motion": motion}, t) for t in times}  # bad motion or time: UsageError
    if len(times) < 2:
        raise UsageError(f"times={times}: give at least two time codes to follow the motion between")
    side = side_view(scenes[times[0]], times, *size)
    necks = {t: dataclasses.replace([v for v in default_views(scenes[t], neck_size, neck_size, n=2)
                                     if v.name.startswith("sweep_")][0], name=f"neck_{i:02d}")
             for i, t in enumerate(times)}
    views = []
    for i, t in enumerate(times):
        views += [_view(side, t, f"{what}_{i:02d}", parts)
                  for what, parts in (("head", HEAD_PARTS), ("trunk", TRUNK_PARTS))]
        if film:
            views.append(_view(necks[t], t))
    work = os.path.join(os.path.abspath(out_dir), "storm_motion")
    _run(layer, work, views, motion)
    joints = joint_positions(layer, motion, times, (HEAD_JOINT, TRUNK_JOINT))
    out = {"times": times, "work": work, "film": {}}
    for k, what in enumerate(("head", "trunk")):
        drawn = np.stack([_centre(_alpha(os.path.join(work, f"{what}_{i:02d}.exr")), what) for i in range(len(times))])
        moved = project(side, joints[:, k])
        storm_travel, usd_travel = drawn - drawn[0], moved - moved[0]
        out[f"{what}_error_px"] = np.linalg.norm(storm_travel - usd_travel, axis=1).tolist()
        out[f"{what}_travel_px"] = np.linalg.norm(usd_travel, axis=1).tolist()
    if film:
        images = bpy_runner.read_views(BAKED.name, "Storm", list(necks.values()), work)
        for t, view in necks.items():
            refs = render_reference(scenes[t], [view], lobe="view_angle")
            metrics, _ = host_metrics({view.name: images[view.name]}, refs, scenes[t])
            out["film"][t] = {k: v for k, v in dataclasses.asdict(metrics).items() if k != "per_view"}
    return out

"""The Blender host: the written asset imported by Blender (``bpy``) as a user gets it, with the rockdove add-on
(its ``USDHook`` builds the thin-film material from ``rockdove:film:*``), drawn by Cycles in a subprocess
(:mod:`rockdove.hosts.blender_job`: bpy's bundled USD and usd-core's ``pxr`` cannot share one process)."""

from __future__ import annotations

import importlib.util
import os
import zipfile
from typing import TypeVar

from .. import resources
from ..errors import UsageError
from .base import ENVIRONMENT_RADIANCE, Host, HostError
from .bpy_runner import bpy_python, job_views, read_views, run_job, unavailable, work_folder
from .jobs import BlenderJob, CyclesJob, JobView

NAME = "blender"
LOBE = "view_angle"
#: The add-on's Python module (the folder inside the zip) and its source folder among the data files.
ADDON_MODULE = "rockdove_blender"
ADDON_SOURCE = f"materials/blender/{ADDON_MODULE}"
ADDON_ZIP = f"{ADDON_MODULE}.zip"
#: Cycles samples per pixel: enough where the tip mask is fractional (elsewhere every sample is equal).
SAMPLES = 16
#: Transparent bounces: feather layers a camera ray may cross (as the reference's MAX_ALPHA_LAYERS).
TRANSPARENT_BOUNCES = 24
#: Render threads (the machine's 2 cores; Cycles' default would take every core).
THREADS = 2
J = TypeVar("J", bound=CyclesJob)


def addon_zip(out_dir) -> str:
    """Write the add-on ``out_dir/rockdove_blender.zip`` with a fixed timestamp (same sources, same bytes)."""
    source = resources.path(ADDON_SOURCE)
    out_dir = os.path.abspath(os.fspath(out_dir))
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise NotADirectoryError(f"--out: {out_dir!r} exists and is not a folder")
    os.makedirs(out_dir, exist_ok=True)
    files = sorted(p for p in source.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    path = os.path.join(out_dir, ADDON_ZIP)
    with resources.atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for f in files:
            info = zipfile.ZipInfo(f"{ADDON_MODULE}/{f.relative_to(source).as_posix()}", (1980, 1, 1, 0, 0, 0))
            info.external_attr = 0o644 << 16
            zf.writestr(info, f.read_bytes(), zipfile.ZIP_DEFLATED)
    return path


def root_object(asset_path: str) -> str:
    from pxr import Sdf

    layer = Sdf.Layer.FindOrOpen(asset_path)
    if layer is None or not layer.defaultPrim:
        raise HostError(NAME, f"{asset_path}: not a USD layer with a defaultPrim")
    return layer.defaultPrim


#: What :meth:`BlenderHost.render` can draw: the film lobe alone (the verification render), or the asset as Blender
#: imported it (every material untouched) under the same white world: what a user sees.
LOBES = (LOBE, "as_imported")


def cycles_job(kind: type[J], asset: str, views: list[JobView], work: str, samples: int, *, addon: bool = True,
               **fields) -> J:
    """A ``kind`` of job through Blender's import, with what every one reads (the asset, the Cycles settings, the out
    folder, the views) and the ``kind``'s own ``fields``."""
    return kind(asset=asset, root_object=root_object(asset), addon_zip=addon_zip(work) if addon else None,
                addon_module=ADDON_MODULE, samples=int(samples), transparent_bounces=TRANSPARENT_BOUNCES,
                threads=THREADS, out_dir=work, views=views, **fields)


class BlenderHost(Host):
    """Blender's own importer, the rockdove add-on and Cycles (module docstring)."""

    def unavailable(self) -> str | None:
        return unavailable()

    def render(self, asset_path: str, views, out_dir: str, *, addon: bool = True, lobe: str = LOBE,
               samples: int = SAMPLES, frame: int | None = None) -> dict:
        """:meth:`Host.render` in Blender (Cycles) into ``out_dir/blender/``; ``addon=False``: its importer alone (the
        UsdPreviewSurface look); ``frame``: of an animated asset. HostError when Blender or the add-on fails."""
        bpy_python(NAME)  # bpy missing: HostError before any work
        views = list(views)
        if lobe not in LOBES or (lobe == LOBE and not addon):
            raise UsageError(f"lobe={lobe!r} with addon={addon}; allowed: {LOBES[0]!r} (needs the add-on) or "
                             f"{LOBES[1]!r}")
        asset_path = os.path.abspath(os.fspath(asset_path))
        if not os.path.isfile(asset_path):
            raise HostError(NAME, f"no asset at {asset_path!r}")
        work = work_folder(NAME, views, out_dir)
        job = cycles_job(BlenderJob, asset_path, job_views(views), work, samples, addon=addon, lobe=lobe,
                         environment_radiance=ENVIRONMENT_RADIANCE, frame=frame)
        run_job(job, work, importlib.util.find_spec("rockdove.hosts.blender_job").origin)
        return read_views(NAME, "Blender", views, work)


HOST = BlenderHost(NAME, "physical", LOBE)

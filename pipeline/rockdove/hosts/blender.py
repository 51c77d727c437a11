"""The Blender host: the written asset imported by Blender (``bpy``) with the rockdove add-on, drawn by Cycles.

Blender's own code on the asset as a user gets it: the add-on zip (:func:`addon_zip`) installed and enabled with
Blender's operators, a plain ``wm.usd_import`` (the add-on's ``USDHook`` builds the Principled thin-film material
from ``rockdove:film:*``), Cycles' thin-film BSDF (``VARIANT = "physical"``) lit as ``LOBE = "view_angle"``. The
Blender side, :mod:`rockdove.hosts.blender_job`, runs in a subprocess: bpy's bundled USD and usd-core's ``pxr``
cannot share one process. :data:`SAMPLES` per pixel and a 0.01 px pixel filter (the reference samples pixel
centres): with a smooth film, a uniform world and binary cut-outs the only noise is where the tip mask is
fractional. Output: float32 EXR (linear Rec.709, Blender's scene-linear space), background 0.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import contextlib
import os
import signal
import subprocess
import sys
import zipfile

import numpy as np

from . import ENVIRONMENT_RADIANCE, HostError
from ..resources import atomic_path
from ..errors import UsageError

NAME = "blender"
VARIANT = "physical"
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
#: Seconds before a Blender run is given up (import ~2 s, 64x64 renders take a second each).
TIMEOUT_S = 900

#: Names a Python interpreter that has bpy, for when the one running rockdove has not: bpy 5.0 pins numpy < 2,
#: which rockdove's other dependencies (colour-science 0.4.7) have outgrown, so the two usually live in separate
#: environments. A setting of where a tool is, like ``PXR_PLUGINPATH_NAME``.
BPY_PYTHON_ENV = "ROCKDOVE_BPY_PYTHON"
#: The venv ``make`` puts bpy in, beside ``.venv`` in the checkout; looked for where no setting names one.
BPY_VENV = ".venv-bpy"
#: How to give rockdove a bpy, the end of every "not found" reason (the SKIPPED line of ``rockdove verify``).
BPY_HOW = (f"set {BPY_PYTHON_ENV}=/path/to/bin/python of a Python 3.11 with pip install 'bpy==5.0.1', "
           f"or run make test (it makes {BPY_VENV} beside .venv)")
#: The oldest bpy module whose bundled ``pxr`` lets the add-on's USD hook run (the 4.2 wheels ship none).
BPY_MIN = (4, 4)
_PROBE = ("import importlib.metadata as m, importlib.util, sys\n"
          "if importlib.util.find_spec('bpy') is None: sys.exit(3)\n"
          "try: print(m.version('bpy'))\nexcept m.PackageNotFoundError: print('')")


@functools.lru_cache(maxsize=None)
def _probe(exe: str) -> str | None:
    """None when ``exe`` runs and has a bpy of :data:`BPY_MIN` or later, else why not (a few words)."""
    try:
        p = subprocess.run([exe, "-c", _PROBE], capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"does not run ({exc})"
    if p.returncode != 0:
        return "has no bpy"
    version = p.stdout.strip()
    parts = tuple(int(x) for x in version.split(".")[:2] if x.isdigit())
    if version and parts < BPY_MIN:
        return (f"has bpy {version}, which cannot run the add-on's USD hook as a module (no pxr); "
                f"bpy {'.'.join(map(str, BPY_MIN))} or later can")
    return None


def bpy_places() -> list:
    """Where :func:`bpy_python` looks when this Python has no bpy, in order: ``$ROCKDOVE_BPY_PYTHON`` alone where
    it is set; else ``.venv-bpy/bin/python`` beside this Python's venv (``make``'s ``.venv`` and ``.venv-bpy``
    share the checkout) and in the checkout rockdove runs from (an editable install whose venv is elsewhere)."""
    exe = os.environ.get(BPY_PYTHON_ENV, "").strip()
    if exe:
        return [exe]
    from .. import resources

    roots = [os.path.dirname(os.path.abspath(sys.prefix)), str(resources.folder("materials").parent)]
    return list(dict.fromkeys(os.path.join(r, BPY_VENV, "bin", "python") for r in roots))


def _find() -> tuple:
    """(the Python with bpy, None) or (None, why there is none)."""
    if importlib.util.find_spec("bpy") is not None:
        return sys.executable, None
    places, tried, setting = bpy_places(), [], os.environ.get(BPY_PYTHON_ENV, "").strip()
    for exe in places:
        if exe == setting or os.path.exists(exe):
            why = _probe(exe)
            if why is None:
                return exe, None
            tried.append(f"{'$' + BPY_PYTHON_ENV + '=' if exe == setting else ''}{exe} {why}")
    if not tried:
        tried = [f"no {BPY_VENV} at {', '.join(os.path.dirname(os.path.dirname(e)) for e in places)}"]
    return None, f"bpy is not in this Python and {'; '.join(tried)}; {BPY_HOW}"


def bpy_python() -> str:
    """The Python interpreter that runs Blender's side (:mod:`rockdove.hosts.blender_job`): this one when it has
    bpy, else the first of :func:`bpy_places` that has. Raises :class:`HostError` naming why none can."""
    exe, why = _find()
    if why:
        raise HostError(NAME, why)
    return exe


def unavailable() -> str | None:
    """None when bpy (Blender as a Python module, 4.4 or later for the add-on's USD hook) can run: here or in a
    Python :func:`bpy_python` finds; else why not, and how to point rockdove at one."""
    return _find()[1]


def addon_zip(out_dir) -> str:
    """Write ``out_dir/rockdove_blender.zip``, the Blender add-on, from its sources among the data files; return its
    absolute path. It holds the folder ``rockdove_blender/`` (the module Blender installs), its files sorted, with
    a fixed timestamp: the same sources give the same bytes."""
    from .. import resources

    source = resources.path(ADDON_SOURCE)
    out_dir = os.path.abspath(os.fspath(out_dir))
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise NotADirectoryError(f"--out: {out_dir!r} exists and is not a folder")
    os.makedirs(out_dir, exist_ok=True)
    files = sorted(p for p in source.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    path = os.path.join(out_dir, ADDON_ZIP)
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for f in files:
            info = zipfile.ZipInfo(f"{ADDON_MODULE}/{f.relative_to(source).as_posix()}", (1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, f.read_bytes())
    return path


def root_object(asset_path: str) -> str:
    from pxr import Sdf

    layer = Sdf.Layer.FindOrOpen(asset_path)
    if layer is None or not layer.defaultPrim:
        raise HostError(NAME, f"{asset_path}: not a USD layer with a defaultPrim")
    return layer.defaultPrim


def read_exr_rgb(path: str) -> np.ndarray:
    """(H, W, 3) float32 RGB of an EXR Blender wrote (RGBA, premultiplied: background 0)."""
    import OpenEXR

    with OpenEXR.File(path) as f:  # R, G, B(, A) come as one channel "RGBA" (or "RGB")
        channels = f.channels()
        rgb = channels.get("RGBA", channels.get("RGB"))
        if rgb is None:
            raise HostError(NAME, f"{path}: no RGB channels (has {sorted(channels)})")
        return np.ascontiguousarray(np.array(rgb.pixels)[..., :3], dtype=np.float32)


def run_job(job: dict, work: str, module: str = "rockdove.hosts.blender_job", timeout_s: float = TIMEOUT_S, *,
            host: str = NAME, renderer: str = "Blender") -> None:
    """Write ``job`` as ``work/job.json`` and run the job script ``module`` on it with :func:`bpy_python`,
    Blender's user folders inside ``work``; its output goes to ``work/blender.log``. Raises :class:`HostError`
    (``host``, naming ``renderer``) when the job fails or does not finish within ``timeout_s`` seconds."""
    python = bpy_python()
    job_path = os.path.join(work, "job.json")
    with open(job_path, "w", encoding="utf-8") as fh:
        json.dump(job, fh, indent=1)
    user = os.path.join(work, "user")  # Blender's user folders (installed add-ons, preferences) stay in here
    env = dict(os.environ, BLENDER_USER_RESOURCES=user, BLENDER_USER_CONFIG=os.path.join(user, "config"),
               BLENDER_USER_SCRIPTS=os.path.join(user, "scripts"),
               BLENDER_USER_EXTENSIONS=os.path.join(user, "extensions"))
    # run by file: the interpreter with bpy need not have rockdove installed (the job imports none of it); in a
    # process group of its own, ended whole when rockdove is interrupted (Ctrl-C, SIGTERM) or the job times out
    proc = subprocess.Popen([python, importlib.util.find_spec(module).origin, job_path], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=work, process_group=0)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except BaseException as exc:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        if isinstance(exc, subprocess.TimeoutExpired):
            raise HostError(host, f"{renderer} did not finish within {timeout_s:g} s") from None
        raise
    with open(os.path.join(work, "blender.log"), "w", encoding="utf-8") as fh:
        fh.write(out + "\n--- stderr ---\n" + err)
    if proc.returncode != 0:
        lines = [ln for ln in err.strip().splitlines() if ln.strip()]
        raise HostError(host, f"{renderer} exited with status {proc.returncode}: "
                              f"{lines[-1] if lines else 'no message'} (log: {work}/blender.log)")


#: What :func:`render` can draw: the film lobe alone (the verification render), or the asset as Blender
#: imported it (every material untouched) under the same white world: what a user sees.
LOBES = (LOBE, "as_imported")


def render(asset_path: str, views, out_dir: str, *, addon: bool = True, lobe: str = LOBE,
           samples: int = SAMPLES) -> dict:
    """Render ``views`` of ``pigeon.usda`` or ``pigeon.usdz`` in Blender (Cycles, CPU) into ``out_dir/blender/``
    (the add-on zip, Blender's user folders, the job, a EXR and a PNG per view): view name -> (H, W, 3) float32
    linear Rec.709 radiance, background 0. The host interface takes the defaults; ``addon=False`` is Blender's
    importer alone (the UsdPreviewSurface look), ``lobe`` one of :data:`LOBES`, ``samples`` per pixel.
    Raises :class:`HostError` when bpy is missing, Blender fails, or the add-on builds no thin-film material."""
    bpy_python()  # bpy missing: HostError before any work
    views = list(views)
    if lobe not in LOBES or (lobe == LOBE and not addon):
        raise UsageError(f"lobe={lobe!r} with addon={addon}; allowed: {LOBES[0]!r} (needs the add-on) or {LOBES[1]!r}")
    asset_path = os.path.abspath(os.fspath(asset_path))
    if not os.path.isfile(asset_path):
        raise HostError(NAME, f"no asset at {asset_path!r}")
    work = work_folder(NAME, views, out_dir)
    run_job({**base_job(asset_path, views, work, samples, addon=addon), "lobe": lobe,
             "environment_radiance": ENVIRONMENT_RADIANCE}, work)
    return read_views(NAME, "Blender", views, work)


def base_job(asset: str, views, work: str, samples: int, *, addon: bool = True) -> dict:
    """What every job through the add-on reads: the asset to import (:func:`rockdove.hosts.blender_job.import_asset`),
    the Cycles settings, where the images go and the views."""
    return {"asset": asset, "root_object": root_object(asset), "addon_zip": addon_zip(work) if addon else None,
            "addon_module": ADDON_MODULE, "samples": int(samples), "transparent_bounces": TRANSPARENT_BOUNCES,
            "threads": THREADS, "out_dir": work, "views": [v.to_dict() for v in views]}


def work_folder(folder: str, views: list, out_dir: str, ext: str = "exr") -> str:
    """``out_dir/<folder>``, made, without the ``views``' images a job wrote there before (so a job that writes
    none is caught). ValueError for no views."""
    if not views:
        raise UsageError("views must hold at least one View, got none")
    work = os.path.join(os.path.abspath(out_dir), folder)
    os.makedirs(work, exist_ok=True)
    for v in views:
        with contextlib.suppress(FileNotFoundError):
            os.remove(os.path.join(work, f"{v.name}.{ext}"))
    return work


def read_views(host: str, renderer: str, views, work: str, ext: str = "exr") -> dict:
    """The ``<view>.exr`` a job of host ``host`` (drawn by ``renderer``, for messages) wrote into ``work``: view name
    -> (H, W, 3) float32 linear radiance, each also written as ``<view>.png`` (``ext="png"``: the PNGs, uint8).
    Raises :class:`HostError` for a missing image or one of the wrong size (naming the job's log)."""
    from PIL import Image

    from ..png import save_png
    from ..srgb import linear_to_srgb8

    out = {}
    for v in views:
        path = os.path.join(work, f"{v.name}.{ext}")
        if not os.path.isfile(path):
            raise HostError(host, f"{renderer} wrote no image for view {v.name!r} ({path}; log: {work}/blender.log)")
        img = read_exr_rgb(path) if ext == "exr" else np.asarray(Image.open(path).convert("RGB"))
        if img.shape != (v.height, v.width, 3):
            raise HostError(host, f"view {v.name!r}: {renderer} image is {img.shape[:2]}, expected "
                                  f"{(v.height, v.width)}")
        if ext == "exr":
            save_png(linear_to_srgb8(img), os.path.join(work, f"{v.name}.png"))
        out[v.name] = img
    return out

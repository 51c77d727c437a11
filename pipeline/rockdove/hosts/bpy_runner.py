"""The bpy job runner the Blender, Storm and OSL hosts and the beauty render share: find a Python that has bpy, run
a ``*_job.py`` script in it by file on a :mod:`.jobs` record (stdlib only, so that Python needs no rockdove; its own
process, because bpy's bundled USD cannot share one with usd-core's ``pxr``), read back the images it wrote."""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import os
import signal
import subprocess
import sys

import numpy as np

from .. import resources
from ..errors import UsageError
from ..png import save_png
from ..srgb import linear_to_srgb8
from .base import HostError
from .jobs import Job, JobView

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
#: Seconds before a job is given up (Blender's import ~2 s, 64x64 renders take a second each).
TIMEOUT_S = 900
_PROBE = ("import importlib.metadata as m, importlib.util, sys\n"
          "if importlib.util.find_spec('bpy') is None: sys.exit(3)\n"
          "try: print(m.version('bpy'))\nexcept m.PackageNotFoundError: print('')")


@functools.cache
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


def bpy_places() -> list[str]:
    """Where :func:`bpy_python` looks: ``$ROCKDOVE_BPY_PYTHON`` if set, else ``.venv-bpy`` by the venv and checkout."""
    if exe := os.environ.get(BPY_PYTHON_ENV, "").strip():
        return [exe]
    roots = [os.path.dirname(os.path.abspath(sys.prefix)), str(resources.folder("materials").parent)]
    return list(dict.fromkeys(os.path.join(r, BPY_VENV, "bin", "python") for r in roots))


def _find() -> tuple[str | None, str | None]:
    """(the Python with bpy, None) or (None, why there is none)."""
    if importlib.util.find_spec("bpy") is not None:
        return sys.executable, None
    places, tried, setting = bpy_places(), [], os.environ.get(BPY_PYTHON_ENV, "").strip()
    for exe in places:
        if exe == setting or os.path.exists(exe):
            if (why := _probe(exe)) is None:
                return exe, None
            tried.append(f"{'$' + BPY_PYTHON_ENV + '=' if exe == setting else ''}{exe} {why}")
    if not tried:
        tried = [f"no {BPY_VENV} at {', '.join(os.path.dirname(os.path.dirname(e)) for e in places)}"]
    return None, f"bpy is not in this Python and {'; '.join(tried)}; {BPY_HOW}"


def unavailable() -> str | None:
    """None when bpy (4.4 or later) can run, here or in a Python :func:`bpy_python` finds; else why not and how."""
    return _find()[1]


def bpy_python(host: str = "blender") -> str:
    """The Python that runs the job scripts (this one when it has bpy); HostError (``host``) naming why none can."""
    exe, why = _find()
    if why or exe is None:
        raise HostError(host, str(why))
    return exe


def run_job(job: Job, work: str, script: str | None, timeout_s: float = TIMEOUT_S, *, host: str = "blender",
            renderer: str = "Blender") -> None:
    """Run the job ``script`` (by a literal ``find_spec("rockdove.hosts.x_job").origin``, so the verification's cache
    key follows it) on ``job`` (its :mod:`.jobs` record) with :func:`bpy_python`, its
    log in ``work``. HostError when it fails or times out."""
    python = bpy_python(host)
    job_path = os.path.join(work, "job.json")
    with open(job_path, "w", encoding="utf-8") as fh:
        fh.write(job.to_json())
    user = os.path.join(work, "user")  # Blender's user folders (installed add-ons, preferences) stay in here
    env = dict(os.environ, BLENDER_USER_RESOURCES=user, BLENDER_USER_CONFIG=os.path.join(user, "config"),
               BLENDER_USER_SCRIPTS=os.path.join(user, "scripts"),
               BLENDER_USER_EXTENSIONS=os.path.join(user, "extensions"))
    # in a process group of its own, ended whole when rockdove is interrupted (Ctrl-C, SIGTERM) or it times out
    proc = subprocess.Popen([python, str(script), job_path], env=env, text=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, cwd=work, process_group=0)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except BaseException as exc:
        with contextlib.suppress(ProcessLookupError):  # the group may have ended already
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


def job_views(views, *, sun: bool = False) -> list[JobView]:
    """The views as a job reads them; ``sun``: each one's light as the beauty's ``sun_direction`` too."""
    return [JobView(**v.to_dict(), sun_direction=v.light_direction.tolist() if sun else None) for v in views]


def work_folder(folder: str, views: list, out_dir: str, ext: str = "exr") -> str:
    """``out_dir/<folder>``, made, without the ``views``' earlier images (so a job that writes none is caught)."""
    if not views:
        raise UsageError("views must hold at least one View, got none")
    work = os.path.join(os.path.abspath(out_dir), folder)
    os.makedirs(work, exist_ok=True)
    for v in views:
        with contextlib.suppress(FileNotFoundError):
            os.remove(os.path.join(work, f"{v.name}.{ext}"))
    return work


def read_views(host: str, renderer: str, views, work: str, ext: str = "exr") -> dict[str, np.ndarray]:
    """View name -> image a job wrote into ``work`` (EXR: (H, W, 3) float32 RGB of its RGBA, premultiplied:
    background 0; saved as PNG too); HostError if missing/wrong."""
    import OpenEXR
    from PIL import Image

    out = {}
    for v in views:
        path = os.path.join(work, f"{v.name}.{ext}")
        if not os.path.isfile(path):
            raise HostError(host, f"{renderer} wrote no image for view {v.name!r} ({path}; log: {work}/blender.log)")
        if ext != "exr":
            img = np.asarray(Image.open(path).convert("RGB"))
        else:
            with OpenEXR.File(path) as f:  # R, G, B(, A) come as one channel "RGBA" (or "RGB")
                channels = f.channels()
                if (rgb := channels.get("RGBA", channels.get("RGB"))) is None:
                    raise HostError(host, f"{path}: no RGB channels (has {sorted(channels)})")
                img = np.ascontiguousarray(np.array(rgb.pixels)[..., :3], dtype=np.float32)
        if img.shape != (v.height, v.width, 3):
            raise HostError(host, f"view {v.name!r}: {renderer} image is {img.shape[:2]}, expected "
                                  f"{(v.height, v.width)}")
        if ext == "exr":
            save_png(linear_to_srgb8(img), os.path.join(work, f"{v.name}.png"))
        out[v.name] = img
    return out

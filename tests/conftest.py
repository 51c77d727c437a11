"""Shared test set-up. Offscreen GL (EGL) is chosen before anything imports OpenGL.

The tests import ``rockdove`` as installed in the venv (``make test`` installs it editable); nothing here puts
the checkout on ``sys.path``, and command-line tests run the installed ``rockdove`` from a folder outside the
checkout (:data:`OUTSIDE`), so a file missing from the package fails them.
"""

import os
import tempfile

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
# Where make installs bpy (a venv of its own: it pins numpy < 2); `make test` exports the same setting.
_BPY = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), ".venv-bpy", "bin", "python")
if os.path.exists(_BPY):
    os.environ.setdefault("ROCKDOVE_BPY_PYTHON", _BPY)

#: A working directory outside the checkout for subprocesses (``python -m`` puts its cwd on sys.path).
OUTSIDE = tempfile.gettempdir()


# ------------------------------------------------------------------------------ small real builds (issue 11)
import json  # noqa: E402
import shutil  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

#: The settings of the small real builds the tests share: a coarse body (8 mm: k = 0 subdivisions), 200 cards,
#: small textures and LUT, a small beauty render. Everything else is the preset's, so these are the assets
#: ``rockdove build`` writes.
SMALL_BUILD = ("geometry.body_voxel_m=0.008", "geometry.card_count=200", "textures.body_resolution=64",
               "textures.feather_resolution=32", "lut.angles=32", "lut.thicknesses=8", "beauty.width=128",
               "beauty.height=96")


def real_build(out, cache, *sets, preset="measured", verify=False) -> Path:
    """Build an asset with the real build graph, in process, through :func:`rockdove.api.build` (what
    ``rockdove build`` runs), with :data:`SMALL_BUILD` and ``sets`` (``KEY=VALUE``) over ``preset``; ``cache``
    is the stage cache (share one to build the body once). Returns the asset folder."""
    from rockdove import api

    config = api.load_config(preset=preset, overrides=[*SMALL_BUILD, *sets])
    return api.build(config, out, cache=cache, verify=verify).out


def built_value(asset, stage: str, cache=None):
    """The value a stage of the build of ``asset`` computed (e.g. ``"bird"``, ``"lut"``), loaded from the
    stage cache (default: the session's, ``<build_root>/cache`` beside ``<build_root>/<name>/pigeon``) by the key
    recorded in the asset's marker: what the generator had in memory, to compare with what a reader gets back
    from the files."""
    from rockdove.graph import stages as S
    from rockdove.graph.engine import Cache
    from rockdove.config import load_config

    asset = Path(asset)
    marker = json.loads((asset / ".rockdove-asset.json").read_text())
    config = load_config(overrides=list(SMALL_BUILD))  # codecs only: any config
    codec = {s.name: s.codec for s in S.make_stages(config)}[stage]
    cache = Path(cache) if cache is not None else asset.parent.parent / "cache"
    return codec.load(Cache(cache).entry(stage, marker["stages"][stage]) / "value")


@pytest.fixture(scope="session", autouse=True)
def user_cache(tmp_path_factory):
    """The tests' own user cache (``$XDG_CACHE_HOME``, inherited by every subprocess): the developer's
    ``~/.cache/rockdove`` is never read or written by the suite."""
    mp = pytest.MonkeyPatch()
    folder = tmp_path_factory.mktemp("xdg-cache")
    mp.setenv("XDG_CACHE_HOME", str(folder))
    yield folder
    mp.undo()


@pytest.fixture(scope="session")
def build_root(tmp_path_factory):
    """One folder for the session's small builds, with one stage cache (``cache/``) they all share."""
    return tmp_path_factory.mktemp("builds")


@pytest.fixture(scope="session")
def small_asset(build_root):
    """The default asset (measured preset: keratin film, thickness 480-700 nm, both shading variants, baked
    selected), small. Read-only: tests that edit files copy it (:func:`copy_asset`)."""
    return real_build(build_root / "measured" / "pigeon", build_root / "cache")


@pytest.fixture(scope="session")
def paper_asset(build_root):
    """The paper preset (650 nm everywhere, n = 1.5: a one-texel-high LUT), small. Read-only."""
    return real_build(build_root / "paper" / "pigeon", build_root / "cache", preset="paper")


@pytest.fixture(scope="session")
def physical_asset(build_root):
    """The default (measured) preset with ``shading.variant = physical``: no LUT. Read-only."""
    return real_build(build_root / "physical" / "pigeon", build_root / "cache", 'shading.variant="physical"')


def copy_asset(asset, dest) -> Path:
    """A writable copy of a shared asset folder (for tests that edit files)."""
    shutil.copytree(asset, dest)
    return Path(dest)

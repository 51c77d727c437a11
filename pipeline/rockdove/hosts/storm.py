"""The ``storm`` hosts: the written asset, unchanged, drawn by Hydra Storm (usdview's renderer) of the bpy wheel
(:mod:`rockdove.hosts.storm_job`, headless EGL), its additions all in the session layer: one host per network a Storm
user sees (:data:`VARIANTS`). Measurements, and why thinfilm.mtlx lets no parameter reach a texture coordinate
(Mesa llvmpipe's helper invocations): docs/hosts.md and docs/design.md, "Hosts"."""

from __future__ import annotations

import importlib.util
import os

import numpy as np

from ..png import save_png
from . import bpy_runner
from .base import ENVIRONMENT_RADIANCE, HostError
from .jobs import StormJob
from .materialx import VariantHost

LOBE = "view_angle"
#: Seconds before a Storm run is given up (a 512 px frame: 5-45 s, mostly shader compilation).
TIMEOUT_S = 900
#: host name -> (network drawn, session-layer overrides of the feather material: shader.input -> value)
VARIANTS = {
    "storm": ("baked", {"StructuralMix.bg": [0.0, 0.0, 0.0]}),
    "storm_physical": ("physical", {"MtlxPhysicalSurface.base_color": [0.0, 0.0, 0.0]}),
    "storm_preview": ("preview", {}),
}
#: The feather material's prim name (rockdove.usd.stage).
FEATHER_MATERIAL = "FeatherMaterial"


class StormHost(VariantHost):
    """Hydra Storm of the bpy wheel drawing one of the asset's networks (module docstring)."""

    def unavailable(self) -> str | None:
        return bpy_runner.unavailable()

    def render(self, asset_path: str, views, out_dir: str) -> dict:
        """:meth:`Host.render` in Storm. HostError when bpy is missing, Storm cannot start or writes no image."""
        name, views = self.name, list(views)
        asset_path = os.path.abspath(os.fspath(asset_path))
        if not os.path.isfile(asset_path):
            raise HostError(name, f"no asset at {asset_path!r}")
        if code := _code_values(asset_path):
            raise HostError(name, f"Storm would paste into its shaders: {code}")
        work = bpy_runner.work_folder(name, views, out_dir)
        save_png(np.full((2, 4, 3), 255, np.uint8), os.path.join(work, "white.png"))  # the dome light's texture
        job = StormJob(asset=asset_path, variant=self.variant, overrides={FEATHER_MATERIAL: VARIANTS[name][1]},
                       environment_radiance=ENVIRONMENT_RADIANCE, out_dir=work, views=bpy_runner.job_views(views))
        bpy_runner.run_job(job, work, importlib.util.find_spec("rockdove.hosts.storm_job").origin, TIMEOUT_S,
                           host=name, renderer="Storm")
        return bpy_runner.read_views(name, "Storm", views, work)


def _code_values(asset_path: str) -> str | None:
    """The first shader value, in any variant, that Storm's generator would paste into code, or None."""
    from pxr import Tf, Usd

    from ..usd.stage import variant_combinations
    from ..usd.validate import CODE_CHECK, check_mtlx_shaders

    try:
        stage = Usd.Stage.Open(asset_path, Usd.Stage.LoadAll)
    except Tf.ErrorException:
        return None  # not a stage: Storm's job says so itself
    for combo in variant_combinations(stage):
        with Usd.EditContext(stage, stage.GetSessionLayer()):
            for set_name, value in combo.items():
                stage.GetDefaultPrim().GetVariantSet(set_name).SetVariantSelection(value)
        found = [f"{i.path}: {i.message}" for i in check_mtlx_shaders(stage)[0] if i.check == CODE_CHECK]
        if found:
            return found[0]
    return None


#: The registry's hosts, one per network (rockdove.hosts.HOSTS).
BAKED, PHYSICAL, PREVIEW = HOSTS = tuple(StormHost(n, v, LOBE) for n, (v, _) in VARIANTS.items())

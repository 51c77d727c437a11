"""The ``storm`` hosts: the written asset, unchanged, drawn by Hydra Storm (usdview's renderer).

Storm is the one in the bpy wheel (USD 25.08 with imaging, HdMtlx, MaterialX 1.39.3), run by
:mod:`rockdove.hosts.storm_job` in the Python that has bpy, headless in an EGL pbuffer. Everything the host adds
is in the session layer (the asset's files are never written): cameras, a white dome light, the ``shading``
variant, the feather's base colour and every part without a MaterialX material black (the film lobe alone).
Three hosts, one per network a Storm user sees (:data:`VARIANTS`): ``storm`` (the LUT, held to the dE goals),
``storm_physical`` (OpenPBR's thin film) and ``storm_preview`` (the UsdPreviewSurface network as a Storm without
MaterialX draws it: its atlas holds each thickness's colour at one angle, so green and purple are checked only).

On Mesa llvmpipe (22.3) an SSBO load in a helper invocation returns 0, and Storm keeps every MaterialX input
in such a buffer (``shaderData``): a texture coordinate that passed through one (``ND_image``'s ``uv_scale``,
a constant, a ``clamp`` bound) got a garbage level of detail in the 2x2 quads straddling triangle edges, the
white-grey speckle of the old network (median dE2000 0.41, p95 31.6 at 512 px). thinfilm.mtlx therefore builds
the LUT coordinate from interpolants and a matrix constant, which Storm writes into the shader (see there).
Storm still warns ``thinfilm_lut.exr mip level 1 does not exist``: HdStTextureUtils::GetAllMipImages opens levels
until one fails (OpenUSD 24.11 source: any EXR warns at its level count), then generates the chain; harmless.
"""

from __future__ import annotations

import importlib.util
import os

import numpy as np

from ..png import save_png
from . import bpy_runner
from .base import ENVIRONMENT_RADIANCE, Host, HostError
from .materialx import missing_variant

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


class StormHost(Host):
    """Hydra Storm of the bpy wheel drawing one of the asset's networks (module docstring)."""

    def unavailable(self) -> str | None:
        return bpy_runner.unavailable()

    def cannot_draw(self, asset_path: str) -> str | None:
        return None if self.variant == "preview" else missing_variant(asset_path, self.variant)

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
        job = {"asset": asset_path, "variant": self.variant, "overrides": {FEATHER_MATERIAL: VARIANTS[name][1]},
               "environment_radiance": ENVIRONMENT_RADIANCE, "out_dir": work, "views": [v.to_dict() for v in views]}
        # the bpy Python, found and run as the Blender host runs its job (log: work/blender.log)
        bpy_runner.run_job(job, work, importlib.util.find_spec("rockdove.hosts.storm_job").origin, TIMEOUT_S,
                           host=name, renderer="Storm")
        return bpy_runner.read_views(name, "Storm", views, work)


def _code_values(asset_path: str) -> str | None:
    """The first shader value, in any variant, that Storm's generator would paste into code, or None."""
    from pxr import Tf, Usd

    from ..usd.stage import variant_combinations
    from ..usd.validate import check_mtlx_shaders

    try:
        stage = Usd.Stage.Open(asset_path, Usd.Stage.LoadAll)
    except Tf.ErrorException:
        return None  # not a stage: Storm's job says so itself
    for combo in variant_combinations(stage):
        with Usd.EditContext(stage, stage.GetSessionLayer()):
            for set_name, value in combo.items():
                stage.GetDefaultPrim().GetVariantSet(set_name).SetVariantSelection(value)
        found = [f"{i.path}: {i.message}" for i in check_mtlx_shaders(stage)[0] if "would paste" in i.message]
        if found:
            return found[0]
    return None


#: The registry's hosts, one per network (rockdove.hosts.HOSTS).
BAKED, PHYSICAL, PREVIEW = HOSTS = tuple(StormHost(n, v, LOBE) for n, (v, _) in VARIANTS.items())

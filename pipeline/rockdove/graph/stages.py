"""The real build stages: each wires one module of the pipeline into the graph (:mod:`rockdove.graph.engine`);
:func:`make_stages` lists them, dependencies first, with the configuration and inputs of each.

Keys use the *content* of upstream outputs, so a new seed that leaves the thickness range unchanged re-bakes
nothing, and a film change re-bakes the LUT and rewrites film_textures and the small layers but reuses the bird,
the film-independent textures and the geometry layer. The verification reruns whenever a published file changes,
but renders only what the change reaches (:mod:`rockdove.verify.verification`)."""

from __future__ import annotations

import math
import shutil
import types
from pathlib import Path

from .. import __version__
from ..geometry.params import CONFIG_KEYS, BirdParams
from ..resources import load_npz
from ..verify.results import Verdict
from .engine import FILES, JSON, Codec, Context, Stage


# ----------------------------------------------------------------------------------------------- codecs
def _images_save(value, folder: Path) -> None:
    import numpy as np

    feathers, body = value
    np.savez(folder / "images.npz", body=body, **{f"feather_{k}": v for k, v in feathers.items()})


def _images_load(folder: Path):
    arrays = load_npz(folder / "images.npz")
    feathers = {k[len("feather_"):]: v for k, v in arrays.items() if k.startswith("feather_")}
    return types.MappingProxyType(feathers), arrays["body"]


def _lut_save(lut, folder: Path) -> None:
    lut.save(folder)


def _lut_load(folder: Path):
    from ..lut.table import ThinFilmLUT

    return ThinFilmLUT.load(folder)


def _bird_save(bird, folder: Path) -> None:
    from ..geometry.io import save_bird

    save_bird(bird, folder)


def _bird_load(folder: Path):
    from ..geometry.io import load_bird

    return load_bird(folder)


def _body_save(body, folder: Path) -> None:
    from ..geometry.io import save_body

    save_body(body, folder)


def _body_load(folder: Path):
    from ..geometry.io import load_body

    return load_body(folder)


# frozen dataclasses of read-only arrays, a read-only mapping of read-only arrays: no stage edits them
BIRD = Codec("bird", _bird_save, _bird_load, shared=True)
BODY = Codec("body", _body_save, _body_load, shared=True)
LUT = Codec("lut", _lut_save, _lut_load)
IMAGES = Codec("images", _images_save, _images_load, shared=True)

#: Random points at which the build measures its LUT, as shipped (after any half rounding), against the exact
#: reference (rockdove.lut.reference.lut_error), recorded in the EXR header (rockdove:estimatedMaxDeltaE2000,
#: ...P99...). 200 points add ~0.05 s to the default 256 x 64 keratin bake (50 points: 0.012-0.018 s).
LUT_ERROR_POINTS = 200


# ----------------------------------------------------------------------------------------------- stages
def run_body(ctx: Context):
    from ..geometry import build_body

    return build_body(BirdParams(body_voxel_m=ctx.config.geometry.body_voxel_m,
                                 body_texture_resolution=ctx.config.textures.body_resolution))


def run_bird(ctx: Context):
    from ..geometry import build_bird

    return build_bird(BirdParams.from_config(ctx.config), body=ctx.inputs.body)


def run_thickness_range(ctx: Context):
    """(lo, hi) nm present on the feathers, rounded outward to whole nm (the LUT's thickness axis)."""
    import numpy as np

    d = np.asarray(ctx.inputs.bird.part("NeckFeathers").primvars["thickness"].values, dtype=np.float64)
    return [float(math.floor(d.min())), float(math.ceil(d.max()))]


def run_lut(ctx: Context):
    """Bake over the mesh's thickness range, round to half floats when ``lut.precision = "half"``, then measure
    the table as shipped against the exact reference (:data:`LUT_ERROR_POINTS`)."""
    from ..films import film_from_config
    from ..lut.bake import as_shipped, bake

    lo, hi = ctx.inputs.thickness_range
    cfg, film = ctx.config.lut, film_from_config(ctx.config.film)
    lut = bake(angles=cfg.angles, thicknesses=1 if lo == hi else cfg.thicknesses, thickness_range=(lo, hi),
               film=film, method=cfg.method, angle_warp_gamma=cfg.angle_warp_gamma, colour_space=cfg.colour_space)
    return as_shipped(lut, film, cfg.precision, LUT_ERROR_POINTS)


def run_texture_images(ctx: Context):
    from .. import textures

    params = BirdParams.from_config(ctx.config)
    return textures.feather_textures(params), textures.body_base_colour(params, ctx.inputs.bird)


def run_textures(ctx: Context):
    """The textures that do not depend on the film (feather base and mask, body colour)."""
    from ..usd.textures_io import write_base_textures

    feathers, body = ctx.inputs.texture_images
    write_base_textures(str(ctx.workdir), feathers, body)


def run_film_textures(ctx: Context):
    """The LUT EXR and the preview atlas; physical-only: no LUT EXR, the film's exact preview colours."""
    from ..films import film_from_config
    from ..usd.textures_io import write_film_textures

    feathers, _ = ctx.inputs.texture_images
    span = tuple(ctx.inputs.thickness_range)  # the preview atlas spans the mesh's range, as previewST does
    lut = ctx.inputs.lut if "lut" in ctx.inputs else None
    film = film_from_config(ctx.config.film) if lut is None else None
    write_film_textures(str(ctx.workdir), lut, feathers, film=film, thickness_range_nm=span)


def run_usd_geometry(ctx: Context):
    """The geometry layer (crate), which depends on the bird alone: a film change leaves its bytes as they were."""
    from ..usd.stage import write_geometry

    write_geometry(str(ctx.workdir), ctx.inputs.bird)


def run_usd_rig(ctx: Context):
    """The rig layer (skeleton, weights, motions): it depends on the bird and the rig alone."""
    from ..usd.stage import write_rig

    write_rig(str(ctx.workdir), ctx.inputs.bird)


#: The configuration sections the looks layer records (:data:`rockdove.usd.stage.BUILD_CONFIG_KEY`): what shapes the
#: neck's thickness and the LUT, so the viewer prints a build command of the film it shows with the rest as built.
BUILD_CONFIG_SECTIONS = ("film", "thickness", "geometry", "lut")


def run_usd_layers(ctx: Context):
    """Every other layer (interface, payload, looks), authored over the cached geometry layer."""
    from ..films import film_from_config
    from ..usd.material import lut_info
    from ..usd.stage import GEOMETRY_LAYER, write_looks

    lut = lut_info(ctx.inputs.lut) if "lut" in ctx.inputs else None
    write_looks(str(ctx.workdir), ctx.inputs.bird, film_from_config(ctx.config.film), lut, version=__version__,
                geometry=str(ctx.inputs.usd_geometry / GEOMETRY_LAYER), shading=ctx.config.shading.variant,
                config={k: ctx.config[k] for k in BUILD_CONFIG_SECTIONS})


def run_usdz(ctx: Context):
    from ..usd.usdz import AR_USDZ_NAME, USDZ_NAME, write_ar_usdz, write_usdz

    scratch = ctx.workdir / "layout"
    for dep in ASSET_FILES:
        shutil.copytree(ctx.inputs[dep], scratch, dirs_exist_ok=True)
    write_usdz(str(scratch), in_place=True)  # scratch holds copies: package them without a second copy
    write_ar_usdz(str(scratch))  # the flattened UsdPreviewSurface package for AR Quick Look
    for name in (USDZ_NAME, AR_USDZ_NAME):
        (scratch / name).rename(ctx.workdir / name)
    shutil.rmtree(scratch)


def run_gltf(ctx: Context) -> None:
    """``pigeon.glb``: the assembled (written) USD asset exported to glTF 2.0 (rockdove.web.gltf)."""
    from ..web.gltf import GLB_NAME, export_glb

    export_glb(str(ctx.asset_dir), ctx.workdir / GLB_NAME, version=__version__)


def run_verify(ctx: Context) -> dict:
    """The verification of the assembled asset with the build's hosts and the stage cache (so ``rockdove verify``
    reuses its renders), its report and viewer in the stage's folder (published as ``verify/``); a verdict."""
    from ..usd.layout import resolve_root_layer
    from ..verify.verification import BUILD_HOSTS, verify
    from .publish import published_path

    layer = resolve_root_layer(ctx.asset_dir)
    skipped = []
    if "gltf" in ctx.inputs:  # the interactive view of the report (verify/viewer.html)
        from ..errors import ResourceMissing
        from ..web.gltf import GLB_NAME
        from ..web.viewer import write_viewer

        try:
            write_viewer(str(ctx.asset_dir), ctx.inputs.gltf / GLB_NAME, ctx.workdir,
                         asset_name=str(published_path(layer)))
        except ResourceMissing as exc:  # e.g. a wheel install without npm's three.js: the report, without it
            skipped.append(f"no interactive viewer in the report: {exc}")
    v = ctx.config.verify
    report = verify(layer, BUILD_HOSTS, cache=ctx.cache, out_dir=ctx.workdir, width=v.width, height=v.height,
                    n_views=v.views, published_asset=str(published_path(layer)), beauty=dict(ctx.config.beauty))
    return Verdict.of(report, skipped).to_json()


#: The stages whose files make the assembled asset.
ASSET_FILES = ("usd_geometry", "usd_rig", "usd_layers", "textures", "film_textures")
#: The verification stage: its value is a :class:`rockdove.verify.results.Verdict`.
VERIFY = "verify"


def verdict(graph) -> Verdict | None:
    """The verdict of a graph's verification stage, None when it has none (built without verification)."""
    return Verdict.from_json(graph.value(VERIFY)) if VERIFY in graph.records else None


def make_stages(config: dict, *, verify: bool = True) -> list[Stage]:
    """The build graph for ``config``: only the stages the scene needs (no bake for physical-only shading)."""
    baked = config["shading"]["variant"] != "physical"  # physical-only shading needs no bake
    bird_keys = tuple(CONFIG_KEYS.values())
    schema = ("schemas/plugInfo.json", "schemas/generatedSchema.usda")
    stages = [
        Stage("body", run_body, config=("geometry.body_voxel_m", "textures.body_resolution"), codec=BODY),
        Stage("bird", run_bird, config=bird_keys, deps=("body",), codec=BIRD),
        Stage("thickness_range", run_thickness_range, deps=("bird",), codec=JSON),
    ]
    if baked:
        stages.append(Stage("lut", run_lut, config=("film", "lut"), deps=("thickness_range",), codec=LUT))
    stages.append(Stage("texture_images", run_texture_images, config=bird_keys, deps=("bird",), codec=IMAGES))
    stages.append(Stage("textures", run_textures, deps=("texture_images",), codec=FILES, publish=""))
    # physical-only: the preview colours are computed from the film (rockdove.lut.reference) over the thickness range
    stages.append(Stage("film_textures", run_film_textures, config=() if baked else ("film",),
                        deps=(("lut",) if baked else ()) + ("thickness_range", "texture_images"), codec=FILES,
                        publish=""))
    stages.append(Stage("usd_geometry", run_usd_geometry, deps=("bird",), data=schema, codec=FILES, publish=""))
    stages.append(Stage("usd_rig", run_usd_rig, deps=("bird",), data=schema, codec=FILES, publish=""))
    stages.append(Stage("usd_layers", run_usd_layers, config=("shading", *BUILD_CONFIG_SECTIONS),
                        deps=("bird", "lut", "usd_geometry") if baked else ("bird", "usd_geometry"),
                        data=("materials", *schema), codec=FILES, publish=""))
    if config["usd"]["usdz"]:
        stages.append(Stage("usdz", run_usdz, deps=ASSET_FILES, codec=FILES, publish=""))
    if config["gltf"]["glb"]:
        # reads the written asset (so it runs once it is assembled); keyed by the files it translates
        stages.append(Stage("gltf", run_gltf, deps=ASSET_FILES, codec=FILES, needs_asset=True, publish=""))
    if verify:  # reruns when any published file changes; its renders are cached by what each reads
        stages.append(Stage(VERIFY, run_verify, config=("verify", "beauty"),
                            deps=tuple(s.name for s in stages if s.publish is not None), data=("materials", *schema),
                            codec=JSON, needs_asset=True, publish="verify"))
    return stages

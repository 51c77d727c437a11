"""Build the whole asset into a folder, uncached and in memory: the reference chain of the build stages.

``assemble(out_dir, ...)`` chains the pure stage functions (geometry -> LUT -> textures -> USD layers -> usdz)
with keyword parameters and no configuration file. The build graph (``rockdove build``, issue 6) calls the
same stage functions one by one with caching; tests call this.

Publication is atomic at the folder level: everything is written into a temporary folder beside ``out_dir``
(same file system), which then replaces ``out_dir`` by rename; a failure removes the temporary folder and
leaves any previous ``out_dir`` untouched. (Locking against concurrent builds is the build graph's job.)
"""

from __future__ import annotations

import os
import shutil
import tempfile

#: preset name -> film model (pipeline.films.FILMS key); thickness ranges come from BirdParams presets.
PRESET_FILMS = {"measured": "keratin", "paper": "paper"}


def _bird_params(preset: str, card_count: int | None, seed: int):
    from pipeline.geometry.params import BirdParams

    overrides = {"seed": seed}
    if card_count is not None:
        overrides["card_count"] = card_count
    return getattr(BirdParams, preset)(**overrides)


def thickness_domain_nm(bird) -> tuple[float, float]:
    """(min, max) film thickness in nm over the bird's feather parts: the LUT's thickness range."""
    import numpy as np

    values = [np.asarray(p.primvars["thickness"].values, np.float64) for p in bird.parts
              if p.material == "feather"]
    if not values or not any(v.size for v in values):
        raise ValueError("bird has no feather part with a 'thickness' primvar")
    d = np.concatenate(values)
    return float(d.min()), float(d.max())


def publish_dir(out_dir: str, fill) -> dict:
    """Call ``fill(tmp_dir) -> dict of paths`` in a temporary folder beside ``out_dir``, then swap it in.

    Returns ``fill``'s dict with every path under ``tmp_dir`` rewritten to lie under ``out_dir``.
    """
    out_dir = os.path.abspath(out_dir)
    parent, name = os.path.split(out_dir)
    os.makedirs(parent, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix=f".{name}.assemble-", dir=parent)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes 0700; the published folder gets ordinary permissions
    try:
        written = fill(tmp)
        old = None
        if os.path.exists(out_dir):
            old = tempfile.mkdtemp(prefix=f".{name}.old-", dir=parent)
            os.rmdir(old)
            os.rename(out_dir, old)
        os.rename(tmp, out_dir)
        if old:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return {k: (out_dir + v[len(tmp):] if isinstance(v, str) and v.startswith(tmp) else v)
            for k, v in written.items()}


def assemble(out_dir, *, preset: str = "measured", card_count: int | None = None, seed: int = 0,
             lut_angles: int = 64, lut_thicknesses: int = 32, lut_method: str = "auto",
             angle_warp_gamma: float | None = None, usdz: bool = True, shading: str = "both",
             bird=None, lut=None, feather_textures=None, body_texture=None, film=None) -> dict:
    """Build the asset into ``out_dir`` (replacing it atomically).

    Parameters
    ----------
    out_dir : str or os.PathLike
        Asset folder to create or replace.
    preset : {"measured", "paper"}
        Film model and thickness preset (``BirdParams.measured`` / ``.paper``; keratin / paper film).
    card_count : int, optional
        Number of neck feather cards (default: BirdParams' default).
    seed : int
        Seed of the geometry.
    lut_angles, lut_thicknesses : int
        LUT size; the thickness axis spans the bird's thickness range, one texel high when that range is a
        single value (paper preset).
    lut_method : str
        :func:`pipeline.lut.bake.bake` method.
    angle_warp_gamma : float, optional
        LUT angle warp (default: the baker's).
    usdz : bool
        Also write ``pigeon.usdz``.
    shading : {"both", "baked", "physical"}
        The shading variants (:func:`pipeline.usd.stage.shading_variants`); ``"physical"`` bakes no LUT (a
        ``lut`` given is ignored) and writes an asset without one.
    bird, lut, feather_textures, body_texture, film
        Ready-made stage outputs (tests inject small synthetic ones); computed from the parameters when None.

    Returns
    -------
    dict[str, str]
        ``dir``, ``interface``, ``payload``, ``usdz`` (if written) and one entry per texture role
        (``lut`` unless physical-only, ``feather_base``, ``feather_mask``, ``feather_preview``, ``body_base``):
        absolute paths.
    """
    from pipeline import __version__
    from pipeline.films import get_film

    from .usd.material import lut_info
    from .usd.stage import shading_variants, write_layers
    from .usd.textures_io import write_base_textures, write_film_textures
    from .usd.usdz import write_usdz

    if preset not in PRESET_FILMS:
        raise ValueError(f"preset={preset!r}; allowed: {sorted(PRESET_FILMS)}")
    physical_only = "baked" not in shading_variants(shading)
    film = film if film is not None else get_film(PRESET_FILMS[preset])
    params = None
    if bird is None:
        from pipeline.geometry import build_bird

        params = _bird_params(preset, card_count, seed)
        bird = build_bird(params)
    lo, hi = thickness_domain_nm(bird)
    if physical_only:
        lut = None
    elif lut is None:
        from pipeline.lut.bake import bake

        kw = {} if angle_warp_gamma is None else {"angle_warp_gamma": angle_warp_gamma}
        lut = bake(angles=lut_angles, thicknesses=1 if lo == hi else lut_thicknesses, thickness_range=(lo, hi),
                   film=film, method=lut_method, **kw)
    if feather_textures is None or body_texture is None:
        from pipeline import textures

        params = params or _bird_params(preset, card_count, seed)
        feather_textures = feather_textures if feather_textures is not None else textures.feather_textures(params)
        body_texture = body_texture if body_texture is not None else textures.body_base_colour(params, bird)

    def fill(tmp: str) -> dict:
        written = {"dir": tmp}
        written.update(write_base_textures(tmp, feather_textures, body_texture))
        written.update(write_film_textures(tmp, lut, feather_textures, film=film, thickness_range_nm=(lo, hi)))
        written.update(write_layers(tmp, bird, film, lut_info(lut) if lut is not None else None,
                                    version=__version__, shading=shading))
        if usdz:
            written["usdz"] = write_usdz(tmp)
        return written

    return publish_dir(os.fspath(out_dir), fill)

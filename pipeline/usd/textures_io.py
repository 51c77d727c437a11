"""Write the asset's textures into ``DIR/textures/`` deterministically (docs/design.md, "Textures").

- PNG via Pillow with fixed options (``compress_level`` fixed, no ``optimize``, no text/time chunks): the same
  pixels give the same bytes.
- The LUT via :func:`pipeline.lut.exr.write_exr` (float32 or half RGB, ZIP, sorted header, no timestamp).
- ``feather_preview.png``: the universal UsdPreviewSurface network cannot look the LUT up per fragment (the
  LUT is indexed by angle and per-vertex thickness, a texture by st), so it shows a *static* preview:
  ``mix(base, LUT(cos_theta_preview, thickness_preview_nm), mask)`` with one representative structural colour
  for every feather: by default at normal incidence (cos theta = 1, light and eye along the normal) and the
  middle of the LUT's thickness range. The mix is done in linear light (sRGB decoded and re-encoded with
  colour-science, IEC 61966-2-1); out-of-gamut colours are clipped to [0, 1] for the 8-bit file.
- An asset without a LUT (physical-only shading, ``lut=None``) has no ``thinfilm_lut.exr``; its preview colour
  is the *exact* spectral colour at the same point (normal incidence, middle of the thickness range on the
  mesh): :func:`pipeline.lut.reference.reference_colour`, one Airy spectrum at 0.1 nm integrated under D65
  with the CIE 1931 2 degree observer, in lin_rec709 (:func:`preview_colour`). With a LUT the preview uses the
  LUT's value there, which differs from it by the LUT's error only.
"""

from __future__ import annotations

import os

import numpy as np

from .material import TEXTURE_FILES

#: Pillow PNG options: fixed so that encoding is reproducible (zlib level 6 is Pillow's default, made explicit).
PNG_OPTIONS = {"compress_level": 6, "optimize": False}
#: cos theta of the static structural colour in feather_preview.png (normal incidence).
PREVIEW_COS_THETA = 1.0


def _check_uint8(name: str, a, channels: tuple[int, ...]) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype != np.uint8:
        raise ValueError(f"{name} must be uint8, got dtype {a.dtype}")
    c = 1 if a.ndim == 2 else (a.shape[2] if a.ndim == 3 else -1)
    if a.ndim not in (2, 3) or c not in channels or min(a.shape[:2]) < 1:
        raise ValueError(f"{name} must have shape (H, W) or (H, W, C) with C in {channels}, got {a.shape}")
    return np.ascontiguousarray(a)


def write_png(path: str, pixels: np.ndarray) -> str:
    """Write a uint8 (H, W), (H, W, 3) or (H, W, 4) image, row 0 at the top, with fixed encoder options."""
    from PIL import Image

    pixels = np.ascontiguousarray(pixels)
    if pixels.ndim == 3 and pixels.shape[2] == 1:
        pixels = np.ascontiguousarray(pixels[..., 0])
    if pixels.dtype != np.uint8 or not (pixels.ndim == 2 or (pixels.ndim == 3 and pixels.shape[2] in (3, 4))):
        raise ValueError(f"pixels must be uint8 (H, W), (H, W, 3) or (H, W, 4), got {pixels.dtype} {pixels.shape}")
    Image.fromarray(pixels).save(path, format="PNG", **PNG_OPTIONS)  # mode L / RGB / RGBA from the shape
    return path


def preview_colour(film, thickness_nm: float, cos_theta: float = PREVIEW_COS_THETA) -> np.ndarray:
    """The exact structural colour of ``film`` at one point, linear lin_rec709 (D65, CIE 1931 2 degree).

    Parameters
    ----------
    film : pipeline.films.FilmModel or str
    thickness_nm : float
        Film thickness, nm.
    cos_theta : float
        Cosine of the angle of incidence, in [0, 1].

    Returns
    -------
    ndarray, (3,) float64
        Unclipped linear RGB (:func:`pipeline.lut.reference.reference_colour`).
    """
    from pipeline.lut.reference import reference_colour

    if not 0.0 <= cos_theta <= 1.0:
        raise ValueError(f"cos_theta must be in [0, 1], got {cos_theta}")
    if not (np.isfinite(thickness_nm) and thickness_nm >= 0):
        raise ValueError(f"thickness_nm must be a finite thickness >= 0 nm, got {thickness_nm!r}")
    return np.asarray(reference_colour(cos_theta, float(thickness_nm), film, colour_space="lin_rec709"), np.float64)


def feather_preview(base_rgba: np.ndarray, mask: np.ndarray, lut=None, *, cos_theta: float = PREVIEW_COS_THETA,
                    thickness_nm: float | None = None, structural_rgb=None) -> np.ndarray:
    """The static preview texture: feather base mixed by the mask with one structural colour.

    Parameters
    ----------
    base_rgba : ndarray, (H, W, 4) uint8
        sRGB-encoded base colour, linear alpha (feather_base.png).
    mask : ndarray, (H, W) or (H, W, 1) uint8
        1 (255) where structural colour is drawn (feather_mask.png), raw.
    lut : ThinFilmLUT, optional
        Source of the structural colour, sampled at (``cos_theta``, ``thickness_nm``).
    cos_theta : float
        Angle of the preview colour (default normal incidence).
    thickness_nm : float, optional
        Film thickness of the preview colour; default the middle of ``lut.thickness_range_nm``.
    structural_rgb : array_like (3,), optional
        The structural colour itself (linear), instead of ``lut`` (e.g. :func:`preview_colour`).

    Returns
    -------
    ndarray, (H, W, 4) uint8
        sRGB-encoded RGB, A copied from ``base_rgba``.
    """
    from .._compat import import_colour

    colour = import_colour()

    base_rgba = _check_uint8("base_rgba", base_rgba, (4,))
    mask = _check_uint8("mask", mask, (1,))
    mask = mask.reshape(mask.shape[:2])
    if mask.shape != base_rgba.shape[:2]:
        raise ValueError(f"mask shape {mask.shape} must match base_rgba {base_rgba.shape[:2]}")
    if not 0.0 <= cos_theta <= 1.0:
        raise ValueError(f"cos_theta must be in [0, 1], got {cos_theta}")
    if (lut is None) == (structural_rgb is None):
        raise ValueError("give exactly one of lut and structural_rgb, got "
                         f"lut={type(lut).__name__}, structural_rgb={structural_rgb!r}")
    if lut is not None:
        lo, hi = lut.thickness_range_nm
        d = 0.5 * (lo + hi) if thickness_nm is None else float(thickness_nm)
        structural = np.clip(lut.sample(cos_theta, d), 0.0, 1.0)  # (3,) linear
    else:
        structural = np.asarray(structural_rgb, np.float64).reshape(-1)
        if structural.shape != (3,) or not np.all(np.isfinite(structural)):
            raise ValueError(f"structural_rgb must be 3 finite linear values, got {structural_rgb!r}")
        structural = np.clip(structural, 0.0, 1.0)
    base_lin = colour.cctf_decoding(base_rgba[..., :3] / 255.0, function="sRGB")
    m = (mask / 255.0)[..., None]
    mixed = base_lin * (1.0 - m) + structural * m
    srgb = colour.cctf_encoding(np.clip(mixed, 0.0, 1.0), function="sRGB")
    out = np.empty_like(base_rgba)
    out[..., :3] = np.round(srgb * 255.0).astype(np.uint8)
    out[..., 3] = base_rgba[..., 3]
    return out


def write_textures(out_dir: str, lut, feather_textures: dict, body_texture: np.ndarray, *,
                   preview_cos_theta: float = PREVIEW_COS_THETA,
                   preview_thickness_nm: float | None = None, film=None,
                   thickness_range_nm: tuple[float, float] | None = None) -> dict[str, str]:
    """Write every texture of the asset into ``out_dir/textures/``.

    Parameters
    ----------
    out_dir : str
        Asset folder; ``textures/`` is created inside.
    lut : ThinFilmLUT or None
        Written as ``thinfilm_lut.exr`` (:func:`pipeline.lut.exr.write_exr`, its precision from the LUT's
        metadata). None for an asset without a LUT (physical-only shading): no EXR, and the preview's
        structural colour is :func:`preview_colour` of ``film``.
    feather_textures : dict
        ``"base"``: (H, W, 4) uint8 sRGB RGBA (A = silhouette); ``"mask"``: (H, W) uint8 raw.
    body_texture : ndarray, (H, W, 3) uint8
        sRGB body colour in the body's UVs.
    preview_cos_theta, preview_thickness_nm
        See :func:`feather_preview`.
    film : pipeline.films.FilmModel, optional
        Required when ``lut`` is None: the film of the preview colour.
    thickness_range_nm : (float, float), optional
        Required when ``lut`` is None (unless ``preview_thickness_nm`` is given): the thickness range on the
        mesh, nm; the preview uses its middle.

    Returns
    -------
    dict[str, str]
        Texture role (``lut`` when written, ``feather_base``, ``feather_mask``, ``feather_preview``,
        ``body_base``) -> absolute path written; keys sorted.
    """
    from pipeline.lut.exr import write_exr

    missing = {"base", "mask"} - set(feather_textures)
    if missing:
        raise ValueError(f"feather_textures lacks {sorted(missing)}; it needs 'base' (RGBA) and 'mask' (grey)")
    base = _check_uint8("feather_textures['base']", feather_textures["base"], (4,))
    mask = _check_uint8("feather_textures['mask']", feather_textures["mask"], (1,))
    body = _check_uint8("body_texture", body_texture, (3,))
    if lut is not None:
        preview = feather_preview(base, mask, lut, cos_theta=preview_cos_theta, thickness_nm=preview_thickness_nm)
    else:
        if film is None or (preview_thickness_nm is None and thickness_range_nm is None):
            raise ValueError("lut=None needs film and thickness_range_nm (or preview_thickness_nm) for the static "
                             f"preview colour, got film={film!r}, thickness_range_nm={thickness_range_nm!r}")
        d = (0.5 * (float(thickness_range_nm[0]) + float(thickness_range_nm[1])) if preview_thickness_nm is None
             else float(preview_thickness_nm))
        preview = feather_preview(base, mask, cos_theta=preview_cos_theta,
                                  structural_rgb=preview_colour(film, d, preview_cos_theta))
    tex_dir = os.path.join(os.path.abspath(out_dir), "textures")
    os.makedirs(tex_dir, exist_ok=True)
    paths = {role: os.path.join(tex_dir, name) for role, name in TEXTURE_FILES.items()}
    if lut is not None:
        write_exr(lut, paths["lut"])
    else:
        del paths["lut"]
    write_png(paths["feather_base"], base)
    write_png(paths["feather_mask"], mask)
    write_png(paths["feather_preview"], preview)
    write_png(paths["body_base"], body)
    return dict(sorted(paths.items()))

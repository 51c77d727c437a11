"""Write the asset's textures into ``DIR/textures/`` deterministically (docs/design.md, "Textures").

- PNG via Pillow with fixed options (``compress_level`` fixed, no ``optimize``, no text/time chunks): the same
  pixels give the same bytes.
- The LUT via :func:`pipeline.lut.exr.write_exr` (float32 RGB, ZIP, sorted header, no timestamp).
- ``feather_preview.png``: the universal UsdPreviewSurface network cannot look the LUT up per fragment (the
  LUT is indexed by angle and per-vertex thickness, a texture by st), so it shows a *static* preview:
  ``mix(base, LUT(cos_theta_preview, thickness_preview_nm), mask)`` with one representative structural colour
  for every feather: by default at normal incidence (cos theta = 1, light and eye along the normal) and the
  middle of the LUT's thickness range. The mix is done in linear light (sRGB decoded and re-encoded with
  colour-science, IEC 61966-2-1); out-of-gamut colours are clipped to [0, 1] for the 8-bit file.
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


def feather_preview(base_rgba: np.ndarray, mask: np.ndarray, lut, *, cos_theta: float = PREVIEW_COS_THETA,
                    thickness_nm: float | None = None) -> np.ndarray:
    """The static preview texture: feather base mixed by the mask with one structural colour.

    Parameters
    ----------
    base_rgba : ndarray, (H, W, 4) uint8
        sRGB-encoded base colour, linear alpha (feather_base.png).
    mask : ndarray, (H, W) or (H, W, 1) uint8
        1 (255) where structural colour is drawn (feather_mask.png), raw.
    lut : ThinFilmLUT
    cos_theta : float
        Angle of the preview colour (default normal incidence).
    thickness_nm : float, optional
        Film thickness of the preview colour; default the middle of ``lut.thickness_range_nm``.

    Returns
    -------
    ndarray, (H, W, 4) uint8
        sRGB-encoded RGB, A copied from ``base_rgba``.
    """
    import colour

    base_rgba = _check_uint8("base_rgba", base_rgba, (4,))
    mask = _check_uint8("mask", mask, (1,))
    mask = mask.reshape(mask.shape[:2])
    if mask.shape != base_rgba.shape[:2]:
        raise ValueError(f"mask shape {mask.shape} must match base_rgba {base_rgba.shape[:2]}")
    if not 0.0 <= cos_theta <= 1.0:
        raise ValueError(f"cos_theta must be in [0, 1], got {cos_theta}")
    lo, hi = lut.thickness_range_nm
    d = 0.5 * (lo + hi) if thickness_nm is None else float(thickness_nm)
    structural = np.clip(lut.sample(cos_theta, d), 0.0, 1.0)  # (3,) linear
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
                   preview_thickness_nm: float | None = None) -> dict[str, str]:
    """Write every texture of the asset into ``out_dir/textures/``.

    Parameters
    ----------
    out_dir : str
        Asset folder; ``textures/`` is created inside.
    lut : ThinFilmLUT
    feather_textures : dict
        ``"base"``: (H, W, 4) uint8 sRGB RGBA (A = silhouette); ``"mask"``: (H, W) uint8 raw.
    body_texture : ndarray, (H, W, 3) uint8
        sRGB body colour in the body's UVs.
    preview_cos_theta, preview_thickness_nm
        See :func:`feather_preview`.

    Returns
    -------
    dict[str, str]
        Texture role (``lut``, ``feather_base``, ``feather_mask``, ``feather_preview``, ``body_base``) ->
        absolute path written; keys sorted.
    """
    from pipeline.lut.exr import write_exr

    missing = {"base", "mask"} - set(feather_textures)
    if missing:
        raise ValueError(f"feather_textures lacks {sorted(missing)}; it needs 'base' (RGBA) and 'mask' (grey)")
    base = _check_uint8("feather_textures['base']", feather_textures["base"], (4,))
    mask = _check_uint8("feather_textures['mask']", feather_textures["mask"], (1,))
    body = _check_uint8("body_texture", body_texture, (3,))
    tex_dir = os.path.join(os.path.abspath(out_dir), "textures")
    os.makedirs(tex_dir, exist_ok=True)
    paths = {role: os.path.join(tex_dir, name) for role, name in TEXTURE_FILES.items()}
    write_exr(lut, paths["lut"])
    write_png(paths["feather_base"], base)
    write_png(paths["feather_mask"], mask)
    write_png(paths["feather_preview"], feather_preview(base, mask, lut, cos_theta=preview_cos_theta,
                                                         thickness_nm=preview_thickness_nm))
    write_png(paths["body_base"], body)
    return dict(sorted(paths.items()))

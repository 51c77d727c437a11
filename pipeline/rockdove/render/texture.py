"""Texture images as the renderers see them: decode a PNG to linear float, sample it at USD ``st``.

Conventions (docs/design.md, "Conventions"): :func:`read_texture` returns row 0 at the *top* of the image (file
order); :func:`sample_texture` looks up USD ``st`` (t = 0 at the bottom) the way OpenGL does with an image
uploaded bottom-row-first: bilinear, texel centres at ``(k + 0.5) / N``, clamp-to-edge. sRGB textures are
decoded to linear with the IEC 61966-2-1 EOTF (:func:`rockdove.spectral.srgb_decode`); raw textures are not.
"""

from __future__ import annotations

import numpy as np


def read_texture(path, srgb: bool) -> np.ndarray:
    """Read a PNG (any Pillow format) as linear float32, (H, W, C), row 0 = top of the image.

    ``srgb``: decode the colour channels with the sRGB EOTF (alpha, a 4th channel, stays linear). Values in
    [0, 1]. Grey images give C = 1, grey+alpha C = 2.
    """
    from PIL import Image

    with Image.open(path) as im:
        mode = im.mode
        if mode in ("P", "CMYK", "YCbCr", "LAB", "HSV", "1"):
            im = im.convert("RGBA" if "transparency" in im.info else "RGB")
        arr = np.asarray(im)
    if arr.dtype == np.uint16 or arr.dtype == np.int32:
        a = arr.astype(np.float32) / 65535.0
    elif arr.dtype == np.uint8:
        a = arr.astype(np.float32) / 255.0
    elif arr.dtype == np.bool_:
        a = arr.astype(np.float32)
    else:
        a = arr.astype(np.float32)
    if a.ndim == 2:
        a = a[:, :, None]
    if srgb:
        from ..spectral import srgb_decode

        nc = 3 if a.shape[2] >= 3 else 1
        a = a.copy()
        if arr.dtype == np.uint8:  # 256 possible codes: decode each once (same values, element by element)
            table = srgb_decode(np.arange(256).astype(np.float32) / 255.0).astype(np.float32)
            codes = arr if arr.ndim == 3 else arr[:, :, None]
            a[:, :, :nc] = table[codes[:, :, :nc]]
        else:
            a[:, :, :nc] = srgb_decode(a[:, :, :nc])
    return np.ascontiguousarray(a, dtype=np.float32)


def sample_texture(image, st) -> np.ndarray:
    """Bilinear, clamp-to-edge lookup of ``image`` at USD ``st``, as OpenGL does (texel centres at (k+.5)/N).

    Parameters
    ----------
    image : ndarray, (H, W, C)
        Row 0 = top of the image (as :func:`read_texture` returns it); ``t = 0`` is the bottom row.
    st : ndarray, (..., 2)

    Returns
    -------
    ndarray, (..., C) float64
    """
    img = np.asarray(image, dtype=np.float64)
    h, w = img.shape[:2]
    st = np.asarray(st, dtype=np.float64)
    x = np.clip(st[..., 0] * w - 0.5, 0, w - 1)
    y = np.clip(st[..., 1] * h - 0.5, 0, h - 1)  # from the bottom
    x0 = np.minimum(np.floor(x).astype(np.intp), max(w - 2, 0))
    y0 = np.minimum(np.floor(y).astype(np.intp), max(h - 2, 0))
    x1 = np.minimum(x0 + 1, w - 1)
    y1 = np.minimum(y0 + 1, h - 1)
    tx = (x - x0)[..., None]
    ty = (y - y0)[..., None]
    rows0, rows1 = h - 1 - y0, h - 1 - y1  # bottom-up -> top-down rows
    c0 = img[rows0, x0] * (1 - tx) + img[rows0, x1] * tx
    c1 = img[rows1, x0] * (1 - tx) + img[rows1, x1] * tx
    return c0 * (1 - ty) + c1 * ty

"""Texture images as the renderers see them: decode a PNG to linear float, sample it at USD ``st``.

Conventions (docs/design.md, "Conventions"): :func:`read_texture` returns row 0 at the *top* of the image (file
order); :func:`sample_texture` looks up USD ``st`` (t = 0 at the bottom) the way OpenGL does with an image
uploaded bottom-row-first: bilinear, texel centres at ``(k + 0.5) / N``, clamp-to-edge. sRGB textures are
decoded to linear with the IEC 61966-2-1 EOTF (:func:`rockdove.srgb.srgb_decode`); raw textures are not."""

from __future__ import annotations

import numpy as np


def read_texture(path, srgb: bool) -> np.ndarray:
    """A PNG (any Pillow format) as linear float32 (H, W, C) in [0, 1], row 0 = top; grey gives C = 1, grey+alpha
    C = 2. ``srgb``: decode the colour channels with the sRGB EOTF (alpha stays linear)."""
    from PIL import Image

    with Image.open(path) as im:
        if im.mode in ("P", "CMYK", "YCbCr", "LAB", "HSV", "1"):
            im = im.convert("RGBA" if "transparency" in im.info else "RGB")
        arr = np.asarray(im)
    a = arr.astype(np.float32) / {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0,
                                  np.dtype(np.int32): 65535.0}.get(arr.dtype, 1.0)
    if a.ndim == 2:
        a = a[:, :, None]
    if srgb:
        from ..srgb import srgb_decode

        nc = 3 if a.shape[2] >= 3 else 1
        if arr.dtype == np.uint8:  # 256 possible codes: decode each once (same values, element by element)
            table = srgb_decode(np.arange(256).astype(np.float32) / 255.0).astype(np.float32)
            codes = arr if arr.ndim == 3 else arr[:, :, None]
            a[:, :, :nc] = table[codes[:, :, :nc]]
        else:
            a[:, :, :nc] = srgb_decode(a[:, :, :nc])
    return np.ascontiguousarray(a, dtype=np.float32)


def sample_texture(image, st) -> np.ndarray:
    """Bilinear, clamp-to-edge lookup, (..., C) float64, of ``image`` (H, W, C; row 0 at the top, as
    :func:`read_texture` returns it) at USD ``st`` (..., 2; t = 0 at the bottom), as OpenGL does."""
    img = np.asarray(image, dtype=np.float64)
    h, w = img.shape[:2]
    st = np.asarray(st, dtype=np.float64)
    x = np.clip(st[..., 0] * w - 0.5, 0, w - 1)
    y = np.clip(st[..., 1] * h - 0.5, 0, h - 1)  # from the bottom
    x0 = np.minimum(np.floor(x).astype(np.intp), max(w - 2, 0))
    y0 = np.minimum(np.floor(y).astype(np.intp), max(h - 2, 0))
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    tx, ty = (x - x0)[..., None], (y - y0)[..., None]
    rows0, rows1 = h - 1 - y0, h - 1 - y1  # bottom-up -> top-down rows
    c0 = img[rows0, x0] * (1 - tx) + img[rows0, x1] * tx
    c1 = img[rows1, x0] * (1 - tx) + img[rows1, x1] * tx
    return c0 * (1 - ty) + c1 * ty

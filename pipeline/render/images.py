"""Display images from linear renders: sRGB 8-bit PNGs and a contact sheet.

Display convention (docs/design.md "Conventions"): the sRGB OETF (IEC 61966-2-1) of the linear value clipped
to [0, 1] (colour-science's ``cctf_encoding``); the float data keeps out-of-gamut colours.
"""

from __future__ import annotations

import os

import numpy as np


def linear_to_srgb8(rgb) -> np.ndarray:
    """(..., 3) linear lin_rec709 -> (..., 3) uint8: sRGB OETF (IEC 61966-2-1) of the value clipped to [0, 1].

    This is docs/design.md's display transform, the same as the CPU reference's ``to_display8``, so GL and
    reference PNGs are comparable. (``pipeline.spectral.RGB_to_preview8`` desaturates out-of-gamut colours
    instead of clipping them; it is not used here.) NaN shows as black, +inf as 1.
    """
    from .._compat import import_colour

    colour = import_colour()

    rgb = np.nan_to_num(np.asarray(rgb, dtype=np.float64), nan=0.0, posinf=1.0, neginf=0.0)
    enc = colour.cctf_encoding(np.clip(rgb, 0.0, 1.0), function="sRGB")
    return np.round(np.clip(enc, 0.0, 1.0) * 255.0).astype(np.uint8)


def box_downsample(image, factor: int) -> np.ndarray:
    """Average ``factor`` x ``factor`` blocks of an (H, W[, C]) image (H, W multiples of ``factor``).

    Used for anti-aliased previews: render at ``factor`` times the size, average the *linear* radiance (and
    the coverage), then encode.
    """
    a = np.asarray(image, dtype=np.float32)
    if factor == 1:
        return a
    h, w = a.shape[:2]
    if factor < 1 or h % factor or w % factor:
        raise ValueError(f"factor must be a positive divisor of the image size {w}x{h}, got {factor}")
    return a.reshape(h // factor, factor, w // factor, factor, *a.shape[2:]).mean(axis=(1, 3))


def save_png(image: np.ndarray, path) -> str:
    """Write a uint8 (H, W, 3|4) image; returns the path."""
    from PIL import Image

    img = np.ascontiguousarray(image, dtype=np.uint8)
    Image.fromarray(img, "RGBA" if img.shape[2] == 4 else "RGB").save(os.fspath(path))
    return os.fspath(path)


def contact_sheet(images, labels, path, columns: int = 4, background=(40, 40, 40)) -> str:
    """Tile uint8 RGBA/RGB images (composited over ``background``) with a label under each; returns path."""
    from PIL import Image, ImageDraw

    images = list(images)
    labels = list(labels)
    if not images or len(images) != len(labels):
        raise ValueError(f"need one label per image, got {len(images)} images and {len(labels)} labels")
    label_h = 16
    cw = max(i.shape[1] for i in images)
    ch = max(i.shape[0] for i in images) + label_h
    cols = min(columns, len(images))
    rows = -(-len(images) // cols)
    sheet = Image.new("RGB", (cols * cw, rows * ch), background)
    draw = ImageDraw.Draw(sheet)
    for k, (img, lab) in enumerate(zip(images, labels)):
        tile = Image.fromarray(np.ascontiguousarray(img, dtype=np.uint8))
        x, y = (k % cols) * cw, (k // cols) * ch
        if tile.mode == "RGBA":
            sheet.paste(tile.convert("RGB"), (x, y), tile)
        else:
            sheet.paste(tile, (x, y))
        draw.text((x + 4, y + img.shape[0] + 2), str(lab), fill=(230, 230, 230))
    sheet.save(os.fspath(path))
    return os.fspath(path)

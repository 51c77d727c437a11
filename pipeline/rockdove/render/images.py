"""Display images from linear renders: sRGB 8-bit PNGs and a contact sheet.

Display convention (docs/design.md "Conventions"): the sRGB OETF (IEC 61966-2-1) of the linear value clipped
to [0, 1] (colour-science's ``cctf_encoding``); the float data keeps out-of-gamut colours.
"""

from __future__ import annotations

import os

import numpy as np


#: `rockdove render`'s largest rendered side, pixels: --width (--height) x --supersample. One view's buffers (~46 bytes a pixel) and
#: the GL context's at 4096 x 4096 stay within the 4 GiB memory budget; views are rendered one at a time, and
#: the 8-bit images the contact sheet gathers (4 bytes a pixel) are bounded by MAX_SHEET_PX.
MAX_SIDE_PX = 4096
MAX_SHEET_PX = 2**27

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


#: zlib level of the display PNGs (renders, verification images, contact sheets; not the asset's textures,
#: which :mod:`rockdove.usd.textures_io` writes with fixed options of its own). Level 1 against Pillow's
#: default 6, measured on one verification's 14 images (33 MB of pixels): 2.2x faster, 23 % larger (1.6 MB).
DISPLAY_PNG_LEVEL = 1


def save_png(image: np.ndarray, path) -> str:
    """Write a uint8 (H, W, 3|4) image as PNG (:func:`encode_png`); returns the path."""
    data = encode_png(image)
    with open(os.fspath(path), "wb") as f:
        f.write(data)
    return os.fspath(path)


def encode_png(image: np.ndarray) -> bytes:
    """A uint8 (H, W, 3|4) image as PNG bytes: 8-bit RGB or RGBA, non-interlaced, every row with the "Up" filter
    (type 2: the byte minus the one above it, mod 256), zlib at :data:`DISPLAY_PNG_LEVEL` (PNG specification,
    ISO/IEC 15948:2004, sections 6, 9.2 and 11.2).

    Written here rather than by Pillow because Pillow's PNG encoder holds the GIL while it filters and
    compresses, so the verification's writer thread (:func:`rockdove.verify.run.render_and_check`) gained
    nothing from it, while :func:`zlib.compress` and numpy's subtraction run outside it. One filter for every
    row in place of Pillow's per-row choice among the five: on one verification's 40 PNGs (renders, dE maps,
    charts, contact sheet) the files are within -3 %..+7 % of Pillow's at the same level and the encodes take
    0.25 s against 0.71 s (2.0-5.3x faster each). Pixels are what they were; the bytes are a function of the
    pixels alone (no time or software chunk).
    """
    import struct
    import zlib

    img = np.ascontiguousarray(image, dtype=np.uint8)
    if img.ndim != 3 or img.shape[2] not in (3, 4) or img.shape[0] < 1 or img.shape[1] < 1:
        raise ValueError(f"image must be a non-empty (H, W, 3) or (H, W, 4) array, got shape {img.shape}")
    h, w, c = img.shape
    rows = img.reshape(h, w * c)
    scanlines = np.empty((h, 1 + w * c), np.uint8)
    scanlines[:, 0] = 2  # filter type "Up"; the row above the first is zero
    scanlines[0, 1:] = rows[0]
    np.subtract(rows[1:], rows[:-1], out=scanlines[1:, 1:])  # uint8: wraps mod 256, as the filter is defined

    def chunk(kind: bytes, payload: bytes) -> bytes:
        return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))

    header = struct.pack(">IIBBBBB", w, h, 8, 6 if c == 4 else 2, 0, 0, 0)  # depth 8, RGB(A), deflate, no interlace
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(scanlines, DISPLAY_PNG_LEVEL)) + chunk(b"IEND", b""))


def label_font(px: int):
    """The font of the project's image labels (contact-sheet titles, dE-map titles and colour bars): Pillow's
    bundled sans (no system font needed) at ``px`` pixels."""
    from PIL import ImageFont

    return ImageFont.load_default(size=max(1, int(px)))


def contact_sheet(path, rows, label_px: int = 28, background=(32, 32, 32)) -> str:
    """Tile rows of titled uint8 images into one PNG; returns the path.

    Parameters
    ----------
    path : path
        The PNG to write.
    rows : sequence of sequences of (str, ndarray)
        Each row's tiles, ``(title, image)``: (H, W, 3) RGB or (H, W, 4) RGBA uint8 (composited over
        ``background``). Every tile is shown at the size of the first one.
    label_px : int
        Height of the header above each row, holding each tile's title in a font sized to it (legible at a
        report's width).
    """
    from PIL import Image, ImageDraw

    rows = [list(r) for r in rows]
    if not rows or not all(rows):
        raise ValueError("rows must hold at least one row, each of at least one (title, image) tile")
    h, w = rows[0][0][1].shape[:2]
    ncol = max(len(r) for r in rows)
    sheet = Image.new("RGB", (ncol * w, len(rows) * (h + label_px)), background)
    draw = ImageDraw.Draw(sheet)
    font = label_font(max(10, int(label_px * 0.6)))
    for r, row in enumerate(rows):
        y = r * (h + label_px)
        for c, (title, img) in enumerate(row):
            draw.text((c * w + 4, y + label_px * 0.15), str(title).strip(), fill=(235, 235, 235), font=font)
            tile = Image.fromarray(np.ascontiguousarray(img, dtype=np.uint8)).resize((w, h))
            if tile.mode == "RGBA":
                sheet.paste(tile.convert("RGB"), (c * w, y + label_px), tile)
            else:
                sheet.paste(tile, (c * w, y + label_px))
    return save_png(np.asarray(sheet), path)

"""Display images from linear renders: sRGB 8-bit PNGs and a contact sheet.

Display convention (docs/design.md "Conventions"): the sRGB OETF (IEC 61966-2-1) of the linear value clipped
to [0, 1] (colour-science's ``cctf_encoding``); the float data keeps out-of-gamut colours."""

from __future__ import annotations

import numpy as np

from ..errors import UsageError
from ..png import save_png

#: `rockdove render`'s largest rendered side, pixels: --width (--height) x --supersample. One view's buffers (~46 bytes a pixel) and
#: the GL context's at 4096 x 4096 stay within the 4 GiB memory budget; views are rendered one at a time, and
#: the 8-bit images the contact sheet gathers (4 bytes a pixel) are bounded by MAX_SHEET_PX.
MAX_SIDE_PX = 4096
MAX_SHEET_PX = 2**27

def box_downsample(image, factor: int) -> np.ndarray:
    """Average ``factor`` x ``factor`` blocks of an (H, W[, C]) image (H, W multiples of ``factor``): anti-aliased
    previews render at ``factor`` times the size and average the *linear* radiance (and coverage)."""
    a = np.asarray(image, dtype=np.float32)
    if factor == 1:
        return a
    h, w = a.shape[:2]
    if factor < 1 or h % factor or w % factor:
        raise UsageError(f"factor must be a positive divisor of the image size {w}x{h}, got {factor}")
    return a.reshape(h // factor, factor, w // factor, factor, *a.shape[2:]).mean(axis=(1, 3))


def label_font(px: int):
    """The font of the project's image labels (contact-sheet titles, dE-map titles and colour bars): Pillow's
    bundled sans (no system font needed) at ``px`` pixels."""
    from PIL import ImageFont

    return ImageFont.load_default(size=max(1, int(px)))


def contact_sheet(path, rows, label_px: int = 28, background=(32, 32, 32)) -> str:
    """Tile rows of ``(title, image)`` tiles (uint8 RGB, or RGBA composited over ``background``; each shown at the
    size of the first) into one PNG under a ``label_px`` header per row; returns the path."""
    from PIL import Image, ImageDraw

    rows = [list(r) for r in rows]
    if not rows or not all(rows):
        raise UsageError("rows must hold at least one row, each of at least one (title, image) tile")
    h, w = rows[0][0][1].shape[:2]
    sheet = Image.new("RGB", (max(len(r) for r in rows) * w, len(rows) * (h + label_px)), background)
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


def write_webp(frames, path, fps: float, *, quality: int = 90, lossless: bool = False) -> str:
    """Write ``frames`` (at least one uint8 (H, W, 3) image, all one size, row 0 at the top) to ``path`` atomically
    as an animated WebP looping at ``fps`` (Pillow, ``save_all``; lossy at ``quality`` 0-100, or ``lossless``),
    which browsers play inline in an ``<img>``. Returns the path."""
    from PIL import Image

    from ..resources import atomic_path

    frames = [np.asarray(f) for f in frames]
    if not frames or any(f.dtype != np.uint8 or f.ndim != 3 or f.shape[2] != 3 or f.shape != frames[0].shape
                         for f in frames):
        raise UsageError("frames must be one or more uint8 (H, W, 3) images of one size, got "
                         f"{sorted({(str(f.dtype), f.shape) for f in frames})}")
    if not 0 < fps <= 100:
        raise UsageError(f"fps must be in (0, 100], got {fps!r}")
    first, *rest = (Image.fromarray(np.ascontiguousarray(f)) for f in frames)
    with atomic_path(path) as tmp:
        first.save(tmp, format="WEBP", save_all=True, append_images=rest, duration=round(1000 / fps), loop=0,
                   quality=quality, lossless=lossless, method=4)
    return str(path)

"""sRGB PNG preview of a thin-film LUT, for people (the data is the EXR).

Layout as the EXR (x: cos theta from 0 at the left; bottom row: the thinnest film), 8 bits by
:func:`rockdove.spectral.RGB_to_preview8`; tables lower than :data:`MIN_PREVIEW_HEIGHT` rows repeat each row."""

from __future__ import annotations

import numpy as np

from .. import spectral
from ..errors import UsageError
from ..png import save_png
from .table import ThinFilmLUT

MIN_PREVIEW_HEIGHT = 32  # px


def write_preview_png(lut: ThinFilmLUT, path) -> str:
    """Write the sRGB preview PNG of ``lut`` to ``path``, top row = thickest film (deterministic bytes: no time
    stamp); returns the path."""
    if not isinstance(lut, ThinFilmLUT):
        raise UsageError(f"lut must be a ThinFilmLUT, got {type(lut).__name__}")
    img = spectral.RGB_to_preview8(lut.rgb[::-1], colour_space=lut.colour_space)
    if img.shape[0] < MIN_PREVIEW_HEIGHT:
        img = np.repeat(img, -(-MIN_PREVIEW_HEIGHT // img.shape[0]), axis=0)
    return save_png(img, path, level=6)

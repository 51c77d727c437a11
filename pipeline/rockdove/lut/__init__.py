"""Thin-film colour LUTs over (cos theta, thickness): the table and its lookup (:mod:`.table`), the bakers
(:mod:`.bake`, :mod:`.fourier`, :mod:`.quadrature`), the exact reference (:mod:`.reference`) and the weights they
integrate with (:mod:`.weights`), OpenEXR I/O (:mod:`.exr`) and the PNG preview (:mod:`.preview`).

These modules import only numpy and :mod:`rockdove.config` at load time (the bakers' defaults are the config
schema's, read once, ~20 ms; OpenEXR, scipy, Pillow and colour-science are imported inside the functions that use
them), so ``import rockdove.lut`` stays light. Note that ``rockdove.lut.bake`` is the
function; import the module's other names with ``from rockdove.lut.bake import ...``."""

from .bake import BAKE_METHODS, bake, fourier_supported
from .exr import read_exr, write_exr
from .preview import write_preview_png
from .reference import lut_error, reference_colour
from .table import ThinFilmLUT

__all__ = ["BAKE_METHODS", "ThinFilmLUT", "bake", "fourier_supported", "lut_error", "read_exr", "reference_colour",
           "write_exr", "write_preview_png"]

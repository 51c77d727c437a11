"""Thin-film colour LUTs over (cos theta, thickness): the table and its lookup (:mod:`.table`), the bakers,
the exact reference and OpenEXR I/O."""

from .table import ThinFilmLUT

__all__ = ["ThinFilmLUT"]

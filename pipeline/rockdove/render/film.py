"""The thin film a written asset records, as the renderers use it: the film model, its thickness primvar, its LUT.

:func:`read_film` reads ``RockDoveThinFilmAPI`` through the schema's one reader
(:func:`rockdove.usd.schema.read_thin_film`) into a :class:`ThinFilmParams`: the :class:`rockdove.films.FilmModel`
plus the thickness primvar and the LUT's file and layout. An asset without a LUT (``shading.variant = "physical"``)
reads with ``lut_file = None``; :func:`lut_to_draw` then bakes one in memory, so the GL renderer and the viewer can
still draw the paper's LUT method (its metadata says it is not part of the asset)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from ..films import FilmModel
from ..usd.schema import has_thin_film, read_thin_film

#: ``metadata["purpose"]`` of that LUT (the report and the web viewer show it).
IN_MEMORY_LUT_PURPOSE = "verification only (rockdove verify, in memory): the asset has no LUT"
#: The film's keys of :func:`rockdove.usd.schema.read_thin_film` that an applied schema must hold.
_REQUIRED = ("model", "cauchy_a", "cauchy_b_nm2", "incident_index", "substrate_index", "thickness_primvar",
             "thickness_units")
_LUT_REQUIRED = ("lut_colour_space", "angle_warp_gamma", "thickness_range_nm")


@dataclass(frozen=True)
class ThinFilmParams:
    """The thin film authored on the feathers with ``RockDoveThinFilmAPI``, as read back; the ``lut_*`` fields,
    ``angle_warp_gamma`` and ``thickness_range_nm`` are None for an asset without a LUT (physical-only shading)."""

    model: FilmModel  # the physics: Cauchy index n(lambda) = A + B / lambda_nm**2 (+ i k), incident/substrate indices
    thickness_primvar: str = "thickness"  # the primvar holding the thickness (without "primvars:")
    thickness_units: str = "nm"
    lut_file: str | None = None  # absolute path of the LUT EXR
    lut_colour_space: str | None = None  # lin_rec709 or acescg
    angle_warp_gamma: float | None = None  # the LUT's angle axis: cos_theta = x ** gamma
    thickness_range_nm: tuple | None = None  # the LUT's thickness axis (lo, hi)
    illuminant: str = "D65"  # colorimetry the LUT was baked with
    observer: str = "CIE 1931 2 Degree Standard Observer"

    def to_dict(self) -> dict:
        """The record as plain values (report.json's ``film``): the film model's fields by their schema names."""
        m = self.model  # keys in the order report.json has always had
        return {"model": m.name, "cauchy_a": m.cauchy_a, "cauchy_b_nm2": m.cauchy_b_nm2,
                "incident_index": m.n_incident, "substrate_index": m.n_substrate,
                "thickness_primvar": self.thickness_primvar, "thickness_units": self.thickness_units,
                "lut_file": self.lut_file, "lut_colour_space": self.lut_colour_space,
                "angle_warp_gamma": self.angle_warp_gamma,
                "thickness_range_nm": list(self.thickness_range_nm) if self.thickness_range_nm else None,
                "illuminant": self.illuminant, "observer": self.observer, "k": m.k}


def read_film(prim) -> ThinFilmParams | None:
    """The film a mesh prim records with ``RockDoveThinFilmAPI`` (:func:`rockdove.usd.schema.read_thin_film`), else
    None; ValueError when a film attribute is missing or invalid, or ``rockdove:lut:file`` names no file."""
    if not has_thin_film(prim):
        return None
    rec = read_thin_film(prim)
    missing = [k for k in _REQUIRED if rec[k] is None]
    if missing:
        raise UsageError(f"{prim.GetPath()}: RockDoveThinFilmAPI attributes {missing} are missing")
    if rec["thickness_units"] != "nm":
        raise UsageError(f"{prim.GetPath()}: rockdove:film:thicknessUnits={rec['thickness_units']!r}; only 'nm' is "
                         "allowed")
    lut_file = None
    if rec["lut_file"]:
        lut_file = rec["lut_file_resolved"] and os.path.abspath(rec["lut_file_resolved"])
        if not lut_file or not os.path.isfile(lut_file):
            raise UsageError(f"{prim.GetPath()}: rockdove:lut:file {rec['lut_file']!r} does not resolve to a file")
        missing = [k for k in _LUT_REQUIRED if rec[k] is None]
        if missing:
            raise UsageError(f"{prim.GetPath()}: rockdove:lut:file is set but {missing} are missing")
    try:
        model = FilmModel(rec["model"], rec["cauchy_a"], rec["cauchy_b_nm2"], k=rec["k"],
                          n_incident=rec["incident_index"], n_substrate=rec["substrate_index"])
    except ValueError as exc:
        raise UsageError(f"{prim.GetPath()}: RockDoveThinFilmAPI film: {exc}") from None
    return ThinFilmParams(
        model=model, thickness_primvar=rec["thickness_primvar"], thickness_units=rec["thickness_units"],
        lut_file=lut_file, lut_colour_space=rec["lut_colour_space"], angle_warp_gamma=rec["angle_warp_gamma"],
        thickness_range_nm=rec["thickness_range_nm"],
        illuminant=rec["illuminant"] or "D65", observer=rec["observer"] or ThinFilmParams.observer)


def thickness_range_nm(film: ThinFilmParams, thickness_nm) -> tuple:
    """The thickness range to draw ``film`` over, nm: its LUT's, or for a LUT-less film the range of the
    authored thicknesses ``thickness_nm`` (array_like, nm) rounded outward to whole nm (as the build's LUT)."""
    if film.thickness_range_nm is not None:
        return tuple(float(v) for v in film.thickness_range_nm)
    d = np.asarray(thickness_nm, np.float64)
    if d.size == 0 or not np.all(np.isfinite(d)):
        raise UsageError("the film records no LUT and the feathers no finite thickness primvar")
    return float(math.floor(d.min())), float(math.ceil(d.max()))


def lut_to_draw(film: ThinFilmParams, thickness_range: tuple):
    """The :class:`rockdove.lut.ThinFilmLUT` to draw ``film`` with: its LUT EXR, or for a LUT-less film one baked in
    memory over ``thickness_range`` (nm, the scene's :func:`thickness_range_nm`; the build's default size, the
    schema's, ``metadata["purpose"] = IN_MEMORY_LUT_PURPOSE``)."""
    from ..lut.bake import bake
    from ..lut.exr import read_exr
    from ..lut.table import ThinFilmLUT

    if film.lut_file is not None:
        if not os.path.isfile(film.lut_file):
            raise UsageError(f"LUT file {film.lut_file!r} (rockdove:lut:file) does not exist")
        return read_exr(film.lut_file)
    lo, hi = (float(v) for v in thickness_range)
    lut = bake(thickness_range=(lo, hi), film=film.model)  # one thickness row where lo == hi
    return ThinFilmLUT(lut.rgb, lut.thickness_range_nm, angle_warp_gamma=lut.angle_warp_gamma,
                       colour_space=lut.colour_space, metadata={**lut.metadata, "purpose": IN_MEMORY_LUT_PURPOSE})

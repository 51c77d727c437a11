"""The specs of the bpy jobs (:mod:`.bpy_runner`), a frozen record per ``*_job.py`` script: its host writes one with
``to_json``, the script reads it with ``read``. Standard library only: a script imports this module as its sibling
file (its folder is ``sys.path[0]``), in a Python that has bpy and no rockdove."""

from __future__ import annotations

import dataclasses
import json
import os
import typing
from dataclasses import dataclass


@dataclass(frozen=True)
class JobView:
    """A :class:`rockdove.render.views.View` as its ``to_dict`` writes it, with what some jobs add to a view."""

    name: str
    camera_to_world: list[list[float]]
    yfov_rad: float
    width: int
    height: int
    light_direction: list[float]
    light_rgb: list[float]
    time: float | None = None  # Storm's: the time code drawn (else the default time)
    only: list[str] | None = None  # Storm's: the meshes drawn (prim names; else all)
    sun_direction: list[float] | None = None  # the beauty's: USD world, from the bird to the sun


def _fields(record) -> dict:
    """A record's fields in their order, each left out while it holds its default (a JSON object of it)."""
    values = ((f, getattr(record, f.name)) for f in dataclasses.fields(record))
    return {f.name: value for f, value in values if value != f.default}


def _decode(kind, value):
    """``value`` read from JSON as type ``kind``: a record from its fields, a list's or dict's items in turn."""
    if isinstance(kind, type) and dataclasses.is_dataclass(kind):
        hints = typing.get_type_hints(kind)
        return kind(**{name: _decode(hints[name], v) for name, v in value.items()})
    args, origin = typing.get_args(kind), typing.get_origin(kind)
    if origin in (list, tuple):
        return origin(_decode(args[0], v) for v in value)
    return {k: _decode(args[1], v) for k, v in value.items()} if origin is dict else value


class Job:
    """What a job script reads: written with :meth:`to_json`, read with :meth:`read` (a subclass per script)."""

    def to_json(self) -> str:
        return json.dumps(self, default=_fields, indent=1)

    @classmethod
    def read(cls, path: str) -> typing.Self:
        with open(path, encoding="utf-8") as fh:
            return _decode(cls, json.load(fh))


@dataclass(frozen=True, kw_only=True)
class CyclesJob(Job):
    """Blender's import of the asset (through the add-on if ``addon_zip``), drawn by Cycles on the CPU into
    ``out_dir``, an image per view (:func:`rockdove.hosts.blender.cycles_job`)."""

    asset: str
    root_object: str  # the asset's root prim: its imported object holds the importer's up-axis turn
    addon_zip: str | None
    addon_module: str
    samples: int  # per pixel
    transparent_bounces: int
    threads: int
    out_dir: str
    views: list[JobView]


@dataclass(frozen=True, kw_only=True)
class BlenderJob(CyclesJob):
    """:mod:`.blender_job`'s: the film lobe alone or the asset as imported, an animated asset at ``frame``."""

    lobe: str  # rockdove.hosts.blender.LOBES
    environment_radiance: float
    frame: int | None


@dataclass(frozen=True)
class OslShader:
    """A mesh's generated OSL: its source file, the primvars it reads, its image parameters' files."""

    source: str
    attributes: list[str]
    files: dict[str, str]

    @property
    def oso(self) -> str:  # the compiled shader, beside the source
        return os.path.splitext(self.source)[0] + ".oso"


@dataclass(frozen=True, kw_only=True)
class OslJob(CyclesJob):
    """:mod:`.osl_job`'s: a shader per mesh path, computing in ``working_space``, written in ``exr_colorspace``."""

    shaders: dict[str, OslShader]
    environment_radiance: float
    working_space: str
    exr_colorspace: str


@dataclass(frozen=True, kw_only=True)
class BeautyJob(CyclesJob):
    """:mod:`.blender_beauty_job`'s: the staging of :mod:`rockdove.render.beauty` (its constants)."""

    ground_vertices_m: list[list[float]]  # USD world
    ground_quads: list[list[int]]
    ground_albedo: float
    sky_horizon_rgb: tuple[float, float, float]
    sky_zenith_rgb: tuple[float, float, float]
    sky_strength: float
    sun_strength: float  # W/m^2
    sun_rgb: tuple[float, float, float]
    sun_angle_deg: float
    look: str  # AgX's
    exposure: float


@dataclass(frozen=True, kw_only=True)
class StormJob(Job):
    """:mod:`.storm_job`'s: the asset's ``variant`` network with session-layer ``overrides`` (material prim name ->
    ``{shader.input: value}``) under a dome light, in the ``motion`` variant (else the rest pose)."""

    asset: str
    variant: str
    overrides: dict[str, dict[str, typing.Any]]
    environment_radiance: float
    out_dir: str
    views: list[JobView]
    motion: str | None = None
    as_authored: bool = False  # every material as authored (what a usdview user sees), not the lobe

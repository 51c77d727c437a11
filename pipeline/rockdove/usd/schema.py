"""The ``RockDoveThinFilmAPI`` codeless applied API schema (``schemas/``): registration, apply and read back.

The schema records on the feather mesh the physical film a LUT was baked from and the LUT's layout, so that
renderers and validators read the physics without the build's memory (names and meanings: docs/design.md, "USD
asset"). An asset without a LUT (physical-only shading) authors no ``rockdove:lut:*`` attribute, and
:func:`read_thin_film` reports them empty, not as the schema's fallbacks.

:func:`register` registers ``schemas/plugInfo.json``, which takes effect only before USD builds its schema
registry (the first stage opened in the process). Another module may open a stage first, so nothing here needs
the registry: :func:`apply_thin_film` adds the name to ``apiSchemas`` and authors every attribute with its
declared type (:data:`ATTRIBUTE_TYPES`, checked against generatedSchema.usda by the tests), and
:func:`has_thin_film` reads ``apiSchemas`` itself.

Surviving tools that drop schemas: every value is also authored as the custom attribute
``userProperties:rockdove:<name>`` (an asset path as its string). Measured with Blender 5.0.1 (bpy, default USD
import and export): the schema's attributes, constant primvars and ``customData`` are dropped on import, while
``userProperties:rockdove:film:cauchyA`` arrives as the mesh's custom property ``rockdove:film:cauchyA`` and is
exported back as the attribute ``rockdove:film:cauchyA``.
"""

from __future__ import annotations

from .. import resources
from ..errors import UsageError

SCHEMA_NAME = "RockDoveThinFilmAPI"
#: Namespace of the copy of the schema's values that survives tools which drop applied API schemas (module
#: docstring).
USER_PROPERTIES_PREFIX = "userProperties:rockdove:"

#: Attribute (after the ``rockdove:`` namespace, in authoring order) -> (key of :func:`read_thin_film`'s dict and
#: of :func:`apply_thin_film`'s arguments, Sdf value type name as declared in generatedSchema.usda).
_ATTRS = {
    "film:model": ("model", "token"),
    "film:cauchyA": ("cauchy_a", "float"),
    "film:cauchyB_nm2": ("cauchy_b_nm2", "float"),
    "film:k": ("k", "float"),
    "film:incidentIndex": ("incident_index", "float"),
    "film:substrateIndex": ("substrate_index", "float"),
    "film:thicknessPrimvar": ("thickness_primvar", "token"),
    "film:thicknessUnits": ("thickness_units", "token"),
    "lut:file": ("lut_file", "asset"),
    "lut:colorSpace": ("lut_colour_space", "token"),
    "lut:angleWarpGamma": ("angle_warp_gamma", "float"),
    "lut:thicknessRangeNm": ("thickness_range_nm", "float2"),
    "lut:illuminant": ("illuminant", "token"),
    "lut:observer": ("observer", "string"),
}
ATTRIBUTE_TYPES = {name: type_name for name, (_, type_name) in _ATTRS.items()}


def register() -> bool:
    """Register ``schemas/`` with USD's plugin registry (idempotent); True when the schema registry knows
    ``RockDoveThinFilmAPI`` (False when a stage was opened earlier in this process: this module works either way)."""
    from pxr import Plug, Usd

    Plug.Registry().RegisterPlugins(str(resources.folder("schemas")))
    return Usd.SchemaRegistry().FindAppliedAPIPrimDefinition(SCHEMA_NAME) is not None


def has_thin_film(prim) -> bool:
    """True when ``RockDoveThinFilmAPI`` is in the prim's composed ``apiSchemas`` (registry not needed)."""
    op = prim.GetMetadata("apiSchemas")
    return op is not None and SCHEMA_NAME in op.ApplyOperations([])


def apply_thin_film(prim, *, model: str, cauchy_a: float, cauchy_b_nm2: float, incident_index: float,
                    substrate_index: float, lut_file: str | None, lut_colour_space: str | None = None,
                    angle_warp_gamma: float | None = None, thickness_range_nm: tuple[float, float] | None = None,
                    illuminant: str = "D65", k: float = 0.0,
                    observer: str = "CIE 1931 2 Degree Standard Observer",
                    thickness_primvar: str = "thickness") -> None:
    """Apply ``RockDoveThinFilmAPI`` to a Mesh prim and author every attribute (nothing left to fallbacks).

    The film's index is ``n(lambda) = cauchy_a + cauchy_b_nm2 / lambda_nm**2 + i k`` between the media of
    ``incident_index`` (above) and ``substrate_index``. ``lut_file``: the LUT EXR's asset path relative to the
    layer, with its MaterialX colour space, angle warp (``cos_theta = x ** gamma``) and thickness axis (lo, hi) nm;
    None for an asset without a LUT (then only ``film:*`` is authored).
    """
    from pxr import Gf, Sdf

    register()
    if prim.GetTypeName() != "Mesh":
        raise UsageError(f"prim must be a Mesh to carry {SCHEMA_NAME}, got {prim.GetPath()} of type "
                         f"{prim.GetTypeName()!r}")
    if not prim.AddAppliedSchema(SCHEMA_NAME):
        raise RuntimeError(f"could not apply {SCHEMA_NAME} to {prim.GetPath()}")
    given = locals() | {"thickness_units": "nm"}  # the arguments by _ATTRS key
    convert = {"float": float, "asset": Sdf.AssetPath, "float2": lambda v: Gf.Vec2f(*(float(x) for x in v))}
    for name, (key, type_name) in _ATTRS.items():
        if name.startswith("lut:") and lut_file is None:
            continue
        value = convert.get(type_name, str)(given[key])
        sdf_type = Sdf.ValueTypeNames.Find(type_name)
        prim.CreateAttribute(f"rockdove:{name}", sdf_type, custom=False).Set(value)
        if type_name == "asset":  # tools keep strings, not asset paths
            sdf_type, value = Sdf.ValueTypeNames.String, value.path
        prim.CreateAttribute(USER_PROPERTIES_PREFIX + name, sdf_type, custom=True).Set(value)


def read_thin_film(prim) -> dict:
    """``RockDoveThinFilmAPI``'s values on ``prim`` by :data:`_ATTRS` key (floats, strings, the thickness range as
    a (lo, hi) float tuple), plus ``lut_file_resolved`` (absolute, or "" when it does not resolve); without a LUT
    ``lut_file == ""`` and the other ``lut:*`` values None. ValueError if the schema is not applied."""
    if not has_thin_film(prim):
        op = prim.GetMetadata("apiSchemas")
        raise UsageError(f"prim {prim.GetPath()} does not apply {SCHEMA_NAME} "
                         f"(applied: {list(op.ApplyOperations([])) if op else []})")
    out = {}
    for name, (key, _) in _ATTRS.items():
        attr = prim.GetAttribute(f"rockdove:{name}")
        # lut:* only when authored: a LUT-less (physical-only) film must not read as the schema's fallbacks
        value = attr.Get() if attr and (attr.HasAuthoredValue() or not name.startswith("lut:")) else None
        if key == "lut_file":
            out["lut_file"] = value.path if value is not None else ""
            out["lut_file_resolved"] = (value.resolvedPath or "") if value is not None else ""
        elif key == "thickness_range_nm":
            out[key] = (float(value[0]), float(value[1])) if value is not None else None
        elif key == "k" and value is None:  # not authored (older assets) and no registry fallback: not absorbing
            out[key] = 0.0
        elif isinstance(value, float):
            out[key] = float(value)
        else:
            out[key] = str(value) if value is not None else None
    return out

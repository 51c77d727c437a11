"""The ``RockDoveThinFilmAPI`` codeless applied API schema (``schemas/``): registration, apply and read back.

It records on the feather mesh the film a LUT was baked from and the LUT's layout (docs/design.md, "USD asset").
``plugInfo.json`` takes effect only before USD builds its schema registry (the first stage opened), so nothing here
needs the registry. Every value is also authored as ``userProperties:rockdove:<name>``: measured with Blender
5.0.1, its USD import drops the schema's attributes, but keeps ``userProperties`` and exports them back."""

from __future__ import annotations

from .. import resources
from ..errors import UsageError

SCHEMA_NAME = "RockDoveThinFilmAPI"
#: Namespace of the copy of the schema's values that survives tools which drop applied API schemas.
USER_PROPERTIES_PREFIX = "userProperties:rockdove:"

#: Attribute (after ``rockdove:``, in authoring order) -> (read_thin_film/apply_thin_film key, Sdf value type name).
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
    """Register ``schemas/`` with USD (idempotent); False when a stage was opened first (this module works anyway)."""
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
    """Apply the schema to a Mesh, every attribute authored; ``n = cauchy_a + cauchy_b_nm2 / lambda_nm**2 + i k``."""
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
    """The schema's values on ``prim`` by :data:`_ATTRS` key, plus ``lut_file_resolved``; without a LUT, empty."""
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

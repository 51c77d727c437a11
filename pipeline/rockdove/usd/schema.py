"""The ``RockDoveThinFilmAPI`` codeless applied API schema (``schemas/``): registration, apply and read back.

The schema records on the feather mesh the physical film a LUT was baked from (film index model and Cauchy
coefficients, incident/substrate indices, thickness primvar and units) and the LUT's layout (file, colour
space, angle warp, thickness range, illuminant, observer), so that renderers and validators can read the
physics without the build's memory. An asset without a LUT (physical-only shading) records the film only: no
``rockdove:lut:*`` attribute is authored, and :func:`read_thin_film` reports them empty (not the schema's
fallbacks). Attribute names and meanings: docs/design.md, "USD asset".

USD discovers the schema through ``schemas/plugInfo.json``. :func:`register` calls
``Plug.Registry().RegisterPlugins`` on that folder, which only takes effect if it runs before USD builds its
schema registry (the first stage opened in the process); setting ``PXR_PLUGINPATH_NAME`` to include
``schemas/`` before importing pxr has the same effect. Because another module of the same process may open a
stage first, nothing here depends on the registry: :func:`apply_thin_film` adds the schema name to the
prim's ``apiSchemas`` and authors every attribute with its declared type (:data:`ATTRIBUTE_TYPES`, checked
against generatedSchema.usda by the tests), and :func:`has_thin_film` reads the ``apiSchemas`` list itself,
so the written layers and what is read back are the same whether or not the registry knows the schema.

Surviving tools that drop schemas: :func:`apply_thin_film` also authors every value as a custom attribute
``userProperties:rockdove:<name>`` (an asset path as its string). Measured with Blender 5.0.1 (``bpy``, default
USD import and export options) on a mesh carrying the three candidates: the schema's own attributes
(``custom = false``) and constant primvars (``primvars:rockdove...``, interpolation constant) are dropped on
import, and so is ``customData``; ``userProperties:rockdove:film:cauchyA`` arrives as the mesh's custom
property ``rockdove:film:cauchyA`` (namespace ``userProperties:`` stripped; token values as strings, float2 as
an array) and Blender's export writes it back as the custom attribute ``rockdove:film:cauchyA`` on the mesh:
the schema's attribute name, without the ``apiSchemas`` entry. So ``userProperties:`` is the copy kept.
"""

from __future__ import annotations

from .. import resources

SCHEMA_NAME = "RockDoveThinFilmAPI"
#: Namespace of the copy of the schema's values that survives tools which drop applied API schemas (module
#: docstring, "Surviving tools that drop schemas").
USER_PROPERTIES_PREFIX = "userProperties:rockdove:"

# attribute name (after the "rockdove:" namespace) -> key in the dict read_thin_film returns
_ATTRS = {
    "film:model": "model",
    "film:cauchyA": "cauchy_a",
    "film:cauchyB_nm2": "cauchy_b_nm2",
    "film:k": "k",
    "film:incidentIndex": "incident_index",
    "film:substrateIndex": "substrate_index",
    "film:thicknessPrimvar": "thickness_primvar",
    "film:thicknessUnits": "thickness_units",
    "lut:file": "lut_file",
    "lut:colorSpace": "lut_colour_space",
    "lut:angleWarpGamma": "angle_warp_gamma",
    "lut:thicknessRangeNm": "thickness_range_nm",
    "lut:illuminant": "illuminant",
    "lut:observer": "observer",
}


#: Attribute (without the ``rockdove:`` namespace) -> Sdf value type name, as declared in generatedSchema.usda.
ATTRIBUTE_TYPES = {
    "film:model": "token",
    "film:cauchyA": "float",
    "film:cauchyB_nm2": "float",
    "film:k": "float",
    "film:incidentIndex": "float",
    "film:substrateIndex": "float",
    "film:thicknessPrimvar": "token",
    "film:thicknessUnits": "token",
    "lut:file": "asset",
    "lut:colorSpace": "token",
    "lut:angleWarpGamma": "float",
    "lut:thicknessRangeNm": "float2",
    "lut:illuminant": "token",
    "lut:observer": "string",
}


def register() -> bool:
    """Register ``schemas/`` with USD's plugin registry (idempotent, best effort).

    Returns
    -------
    bool
        True when USD's schema registry knows ``RockDoveThinFilmAPI`` (False when a stage was opened in this
        process before the plugin was registered; the functions of this module work either way).
    """
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

    Parameters
    ----------
    prim : Usd.Prim
        A ``Mesh``.
    model : str
        Film model name (``rockdove.films.FILMS`` key).
    cauchy_a, cauchy_b_nm2 : float
        Film index ``n(lambda) = cauchy_a + cauchy_b_nm2 / lambda_nm**2``.
    incident_index, substrate_index : float
        Indices of the media above and below the film.
    k : float
        Constant extinction coefficient of the film (index ``n + i k``, ``k >= 0`` absorbs).
    lut_file : str or None
        Asset path of the LUT EXR, relative to the layer (``./textures/thinfilm_lut.exr``). None for an asset
        without a LUT (physical-only shading): then only the ``film:*`` attributes are authored, no ``lut:*``.
    lut_colour_space : str
        MaterialX colour-space name of the LUT (required with ``lut_file``).
    angle_warp_gamma : float
        LUT angle warp (``cos_theta = x ** gamma``; required with ``lut_file``).
    thickness_range_nm : (float, float)
        LUT thickness axis ``(lo, hi)`` in nm (required with ``lut_file``).
    """
    from pxr import Gf, Sdf

    register()
    if prim.GetTypeName() != "Mesh":
        raise ValueError(f"prim must be a Mesh to carry {SCHEMA_NAME}, got {prim.GetPath()} of type "
                         f"{prim.GetTypeName()!r}")
    if lut_file is not None and None in (lut_colour_space, angle_warp_gamma, thickness_range_nm):
        raise ValueError(f"lut_file={lut_file!r} needs lut_colour_space, angle_warp_gamma and thickness_range_nm, got "
                         f"{lut_colour_space!r}, {angle_warp_gamma!r}, {thickness_range_nm!r}")
    if not prim.AddAppliedSchema(SCHEMA_NAME):
        raise RuntimeError(f"could not apply {SCHEMA_NAME} to {prim.GetPath()}")
    values = {
        "film:model": model,
        "film:cauchyA": float(cauchy_a),
        "film:cauchyB_nm2": float(cauchy_b_nm2),
        "film:k": float(k),
        "film:incidentIndex": float(incident_index),
        "film:substrateIndex": float(substrate_index),
        "film:thicknessPrimvar": thickness_primvar,
        "film:thicknessUnits": "nm",
    }
    if lut_file is not None:
        lo, hi = (float(v) for v in thickness_range_nm)
        values.update({
            "lut:file": Sdf.AssetPath(lut_file),
            "lut:colorSpace": lut_colour_space,
            "lut:angleWarpGamma": float(angle_warp_gamma),
            "lut:thicknessRangeNm": Gf.Vec2f(lo, hi),
            "lut:illuminant": illuminant,
            "lut:observer": observer,
        })
    for name, value in values.items():
        type_name = Sdf.ValueTypeNames.Find(ATTRIBUTE_TYPES[name])
        prim.CreateAttribute(f"rockdove:{name}", type_name, custom=False).Set(value)
        if ATTRIBUTE_TYPES[name] == "asset":  # tools keep strings, not asset paths
            type_name, value = Sdf.ValueTypeNames.String, value.path
        prim.CreateAttribute(USER_PROPERTIES_PREFIX + name, type_name, custom=True).Set(value)


def read_thin_film(prim) -> dict:
    """Read ``RockDoveThinFilmAPI`` back from a prim.

    Returns
    -------
    dict
        ``model`` (str), ``cauchy_a``, ``cauchy_b_nm2``, ``k``, ``incident_index``, ``substrate_index`` (float),
        ``thickness_primvar``, ``thickness_units`` (str), ``lut_file`` (str, the authored asset path),
        ``lut_file_resolved`` (str, absolute path or "" when it does not resolve), ``lut_colour_space``,
        ``angle_warp_gamma`` (float), ``thickness_range_nm`` ((lo, hi) float nm), ``illuminant``, ``observer``.
        An asset without a LUT (physical-only) has ``lut_file == ""`` and None for the other ``lut:*`` values.

    Raises
    ------
    ValueError
        If the prim does not have the schema applied.
    """
    if not has_thin_film(prim):
        op = prim.GetMetadata("apiSchemas")
        raise ValueError(f"prim {prim.GetPath()} does not apply {SCHEMA_NAME} "
                         f"(applied: {list(op.ApplyOperations([])) if op else []})")
    out = {}
    for name, key in _ATTRS.items():
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

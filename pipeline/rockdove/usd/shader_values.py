"""Which authored values may reach a shader generator. MaterialX's GLSL and OSL generators, and Storm's, paste
string values into the code they write (a ``geomprop`` as an OSL string default or a Storm ``HdGet_<name>``, an
enum as a string, a colour space by name), so a value that is not plain data could add code. Only these pass:

- a ``string`` input with an ``enum`` in its MaterialX node definition: one of the enum's values;
- a primvar name (``geomprop``, UsdPrimvarReader ``varname``) and a space or layer name: an identifier, and a
  ``geomprop``/``varname`` a primvar that every mesh bound to the material has;
- any other string: printable ASCII without quotes or backslashes (MaterialX's ``note``, ``framerange``);
- a colour space: one MaterialX's default colour management converts (``ND_<space>_to_lin_rec709_*``).

File names are not code: the OSL host hands them to the shader as parameter values (:mod:`rockdove.hosts.osl`)."""

from __future__ import annotations

import functools
import re

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_LITERAL = re.compile(r"[ !#-&(-\[\]-~]*\Z")  # printable ASCII but " ' \
NAMES = ("geomprop", "varname", "fromspace", "tospace", "layer", "layerx", "layery", "layerz")


def colour_spaces(library) -> frozenset:
    """The colour spaces MaterialX converts to its working space lin_rec709 (and that space itself)."""
    return _spaces(tuple(nd.getName() for nd in library.getNodeDefs()))


@functools.lru_cache(maxsize=4)
def _spaces(names: tuple) -> frozenset:
    return frozenset({"lin_rec709"} | {m[1] for m in (re.fullmatch(r"ND_(\w+)_to_lin_rec709_color3", n) for n in names)
                                       if m})


def problem(name: str, kind: str, enum: str, value, colour_space: str, library, primvars=None) -> str | None:
    """Why input ``name`` (MaterialX type ``kind``) with ``value`` must not reach a generator, or None. ``primvars``:
    those of the meshes bound to its material (None: not known, only the identifier is checked)."""
    if colour_space and colour_space not in colour_spaces(library):
        return f"colour space {colour_space!r} is not one MaterialX knows ({', '.join(sorted(colour_spaces(library)))})"
    if kind != "string" or value is None:
        return None
    value, allowed = str(value), [e.strip() for e in enum.split(",") if e.strip()]
    if allowed and value not in allowed:
        return f"{name} {value!r} is not one of {', '.join(allowed)}"
    if name in NAMES and value and not _IDENTIFIER.match(value):
        return f"{name} {value!r} is not an identifier (letters, digits, _)"
    if name in NAMES[:2] and primvars is not None and value not in primvars:
        return f"{name} {value!r} is not a primvar of the meshes bound to its material ({', '.join(sorted(primvars))})"
    if not allowed and not _LITERAL.match(value):
        return f"{name} {value!r} holds a quote, a backslash or a character outside printable ASCII"
    return None


def bound_primvars(stage) -> dict:
    """Material path -> the primvar names every mesh bound to it has."""
    from pxr import UsdGeom, UsdShade

    out: dict = {}
    for prim in stage.Traverse():
        if prim.IsA(UsdGeom.Mesh):
            if material := UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]:
                names = {pv.GetPrimvarName() for pv in UsdGeom.PrimvarsAPI(prim).GetPrimvars()}
                out[material.GetPath()] = out.get(material.GetPath(), names) & names
    return out


def material_of(prim):
    """The path of the Material ``prim`` (a shader) belongs to, or None."""
    from pxr import UsdShade

    while prim and not prim.IsA(UsdShade.Material):
        prim = prim.GetParent()
    return prim.GetPath() if prim else None

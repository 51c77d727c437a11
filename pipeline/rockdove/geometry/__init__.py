"""Procedural rock dove: body, parts, neck band, feather cards and the film-thickness field.

Geometry knows nothing of USD: it returns numpy arrays in :class:`MeshPart` / :class:`Bird` (docs/design.md, "Geometry"
section). Entry points: :func:`build_bird`, or :func:`build_body` then :func:`build_cards` to cache the body separately.
"""

import importlib

#: Public name -> the module defining it. Imported on first use (PEP 562), so that ``rockdove.geometry.params``
#: can be read (the build graph does on every run, even a no-op) without importing numpy and the mesher.
_EXPORTS = {"Bird": "types", "BirdParams": "params", "Body": "bird", "FeatherCards": "cards", "MeshPart": "types",
            "Primvar": "types", "build_bird": "bird", "build_body": "bird", "build_cards": "cards"}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'rockdove.geometry' has no attribute {name!r}")
    return getattr(importlib.import_module(f"rockdove.geometry.{_EXPORTS[name]}"), name)


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))

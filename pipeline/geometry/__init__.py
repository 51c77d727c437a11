"""Procedural rock dove: body, parts, neck band, feather cards and the film-thickness field.

Geometry knows nothing of USD: it returns numpy arrays in :class:`MeshPart` / :class:`Bird`
(docs/design.md, "Geometry" section).
"""

from pipeline.geometry.types import Bird, MeshPart, Primvar

__all__ = ["Bird", "MeshPart", "Primvar"]

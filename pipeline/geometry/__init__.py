"""Procedural rock dove: body, parts, neck band, feather cards and the film-thickness field.

Geometry knows nothing of USD: it returns numpy arrays in :class:`MeshPart` / :class:`Bird`
(docs/design.md, "Geometry" section). Entry points: :func:`build_bird`, or :func:`build_body` then
:func:`build_cards` to cache the body separately.
"""

from pipeline.geometry.bird import Body, build_bird, build_body, build_cards
from pipeline.geometry.cards import FeatherCards
from pipeline.geometry.params import BirdParams
from pipeline.geometry.types import Bird, MeshPart, Primvar

__all__ = ["Bird", "BirdParams", "Body", "FeatherCards", "MeshPart", "Primvar", "build_bird", "build_body",
           "build_cards"]

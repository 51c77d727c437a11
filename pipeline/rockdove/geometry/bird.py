"""Assemble the rock dove: the body (one closed surface with xatlas UVs), the neck feather cards, the parts.

:func:`build_body` is separate so that a build graph can cache the body (it depends only on
``body_voxel_m`` and ``body_texture_resolution``) and redo only the cards when the card parameters or the seed change.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rockdove.geometry import body as _body
from rockdove.geometry import cards as _cards
from rockdove.geometry import neck as _neck
from rockdove.geometry import parts as _parts
from rockdove.geometry import plumage as _plumage
from rockdove.geometry import sdf as _sdf
from rockdove.geometry import uv as _uv
from rockdove.geometry.params import BirdParams
from rockdove.geometry.types import Bird, MeshPart, Primvar, triangle_part


@dataclass(frozen=True)
class Body:
    """The body in its two forms: ``mesh``, the welded closed surface (sampling, inside tests, ray casts), and
    ``part``, the ``"Body"`` MeshPart (vertices split at UV seams; primvars ``neckS``, the neck coordinate clipped
    to [0, 1], and ``neckBand``, 1 inside the neck band). ``card_band_area_m2``: the area of the band the neck
    cards are placed on, estimated once here instead of on every :func:`build_cards` (None: estimated when needed)."""

    mesh: _body.BodyMesh
    part: MeshPart
    card_band_area_m2: float | None = None


def build_body(params: BirdParams) -> Body:
    """Mesh the body (torso, breast, rump, neck, head) on the :data:`body.UNWRAP_VOXEL_M` grid, unwrap it with xatlas
    and subdivide it onto the implicit surface (:func:`body.subdivide_onto_surface`) for ``params.body_voxel_m``;
    normals are the field's gradient at the final vertices."""
    coarse = _body.build_body_mesh(_body.UNWRAP_VOXEL_M)
    at = _uv.atlas(coarse.vertices_m, coarse.faces)
    st = at.st.astype(np.float64)
    welded, to_welded, faces, st = _body.subdivide_onto_surface(
        _sdf.body_sdf, coarse.vertices_m[at.vmapping], at.faces, st, _body.subdivision_levels(params.body_voxel_m))
    normals = _sdf.sdf_gradient(_sdf.body_sdf, welded)
    mesh = _body.BodyMesh(vertices_m=welded, faces=to_welded[faces], normals=normals)
    points = welded[to_welded].astype(np.float32).astype(np.float64)
    s, _ = _neck.neck_s(points)
    part = triangle_part("Body", [(welded[to_welded], normals[to_welded], np.clip(st, 0.0, 1.0), faces)], "body",
                         _plumage.BODY_DISPLAY_COLOR, primvars={
        "neckS": Primvar(np.clip(s, 0.0, 1.0).astype(np.float32), "vertex",
                         "neck coordinate: 0 at the neck base, 1 at its top below the head, clipped"),
        "neckBand": Primvar(_neck.in_band(points).astype(np.float32), "vertex", "1 in the neck band, else 0"),
    })
    return Body(mesh=mesh, part=part, card_band_area_m2=_neck.band_area_m2(welded, mesh.faces, _cards.BAND_S_MAX))


def build_bird(params: BirdParams, body: Body | None = None) -> Bird:
    """The whole rock dove: Body, HeadFeathers, CoatFeathers, Wings, Tail, NeckFeathers, Beak, Cere, Eyes, EyeRings,
    Legs, Claws; ``body``: one already built for ``params`` (e.g. from a cache)."""
    body = build_body(params) if body is None else body
    cards = _cards.build_cards(body, params)
    plumage = _plumage.build_plumage(body.mesh.vertices_m, body.mesh.faces, params.seed)
    return Bird(parts=(body.part,) + plumage + (cards.part(),) + _parts.build_parts())

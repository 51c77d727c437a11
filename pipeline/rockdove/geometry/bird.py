"""Assemble the rock dove: the body (one closed surface with xatlas UVs), the neck feather cards, the parts.

``build_body`` and ``build_cards`` are separate so that a build graph can cache the body (it depends only on
``BirdParams.body_key()``) and redo only the cards when the card parameters or the seed change.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rockdove.geometry import body as _body
from rockdove.geometry import cards as _cards
from rockdove.geometry import neck as _neck
from rockdove.geometry import parts as _parts
from rockdove.geometry import plumage as _plumage
from rockdove.geometry import sdf as _sdf
from rockdove.geometry import uv as _uv
from rockdove.geometry.params import BirdParams
from rockdove.geometry.types import Bird, MeshPart, Primvar

#: Display colour of the body (linear RGB): rock-dove blue-grey.
BODY_DISPLAY_COLOR = (0.25, 0.28, 0.33)


@dataclass(frozen=True)
class Body:
    """The body in its two forms.

    Attributes
    ----------
    mesh : body.BodyMesh
        Welded closed surface (for sampling, inside tests and ray casts).
    part : MeshPart
        ``"Body"``: vertices split at UV seams, st from xatlas (on the coarse mesh, interpolated by subdivision),
        primvar ``neckS`` ((V,) float32 in [0, 1], the neck coordinate clipped to [0, 1]) and ``neckBand``
        ((V,) float32, 1 inside the neck band).
    wings : None
        Kept for cached bodies of earlier builds: the wings are feather cards now (:mod:`.plumage`).
    card_band_area_m2 : float or None
        Area of the band the feather cards are placed on, m^2 (:func:`rockdove.geometry.cards.band_area_m2` of
        ``mesh``): estimated once here instead of on every :func:`build_cards`; None: estimated when needed.
    """

    mesh: _body.BodyMesh
    part: MeshPart
    wings: MeshPart = None
    card_band_area_m2: float | None = None


def _check_params(params) -> BirdParams:
    if not isinstance(params, BirdParams):
        raise ValueError(f"params must be a BirdParams, got {type(params).__name__}")
    return params


def _surface_part(name, field, points, faces, st, levels):
    """Subdivide one seam-split piece of the atlas onto ``field``; (welded vertices, faces in them, MeshPart)."""
    welded, to_welded, faces, st = _body.subdivide_onto_surface(field, points, faces, st, levels)
    normals = _sdf.sdf_gradient(field, welded)
    pts = welded[to_welded]
    part = MeshPart(name=name, points_m=pts.astype(np.float32),
                    face_vertex_counts=np.full(len(faces), 3, dtype=np.int32),
                    face_vertex_indices=faces.reshape(-1).astype(np.int32),
                    normals=normals[to_welded].astype(np.float32), st=np.clip(st, 0.0, 1.0).astype(np.float32),
                    material="body", display_color=BODY_DISPLAY_COLOR, primvars={})
    return welded, to_welded[faces], normals, part


def build_body(params: BirdParams) -> Body:
    """Mesh the body (torso, breast, rump, neck, head) and give it UVs. Depends on ``params.body_key()``.

    The coarse body (surface nets at :data:`body.UNWRAP_VOXEL_M`) is unwrapped by xatlas into the texture above
    the palette strip of the feather cards (:data:`plumage.ATLAS_START`), then subdivided
    ``body.subdivision_levels(params.body_voxel_m)`` times onto the implicit surface (see :mod:`.body`); normals
    are the field's gradient at the final vertices.
    """
    params = _check_params(params)
    levels = _body.subdivision_levels(params.body_voxel_m)
    coarse = _body.build_body_mesh(_body.UNWRAP_VOXEL_M)
    at = _uv.atlas(coarse.vertices_m, coarse.faces)
    st = at.st.astype(np.float64)  # the body's charts above the feathers' palette strip of the texture
    st[:, 1] = _plumage.ATLAS_START + (1.0 - _plumage.ATLAS_START) * st[:, 1]
    welded, faces, normals, part = _surface_part("Body", _sdf.body_sdf, coarse.vertices_m[at.vmapping], at.faces,
                                                 st, levels)
    mesh = _body.BodyMesh(vertices_m=welded, faces=faces, normals=normals)
    points = part.points_m.astype(np.float64)
    s, _ = _neck.neck_s(points)
    band = _neck.in_band(points)
    part = replace(part, primvars={
        "neckS": Primvar(np.clip(s, 0.0, 1.0).astype(np.float32), "vertex",
                         "neck coordinate: 0 at the neck base, 1 at its top below the head, clipped"),
        "neckBand": Primvar(band.astype(np.float32), "vertex", "1 in the neck band, else 0"),
    })
    return Body(mesh=mesh, part=part, wings=None,
                card_band_area_m2=_cards.band_area_m2(mesh.vertices_m, mesh.faces))


def build_cards(body: Body, params: BirdParams) -> _cards.FeatherCards:
    """The neck feather cards on ``body`` (see :mod:`rockdove.geometry.cards`)."""
    params = _check_params(params)
    return _cards.build_cards(body.mesh.vertices_m, body.mesh.faces, params, body.card_band_area_m2)


def build_bird(params: BirdParams, body: Body | None = None) -> Bird:
    """The whole rock dove: Body, CoatFeathers, Wings, Tail, NeckFeathers, Beak, Cere, Eyes, EyeRings, Legs.

    Parameters
    ----------
    params : BirdParams
    body : Body, optional
        A body already built for ``params`` (e.g. from a cache); built when omitted.
    """
    params = _check_params(params)
    body = build_body(params) if body is None else body
    cards = build_cards(body, params)
    plumage = _plumage.build_plumage(body.mesh.vertices_m, body.mesh.faces, params.seed)
    return Bird(parts=(body.part,) + plumage + (cards.part(),) + _parts.build_parts())

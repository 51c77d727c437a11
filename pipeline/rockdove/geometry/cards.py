"""Neck feather cards: slightly curved strips of a few quads, rooted just under the skin of the neck band.

Each card i has a root point p on the skin (blue noise, see ``neck``), the outward normal n there (the body
field's gradient), and a direction t along the skin "down the neck and toward the tail" (the downward neck
axis plus a little -Z, projected on the tangent plane, turned by a seeded yaw). Across the card
b = t x n (so that (b, t, n) is right-handed and the quads wind counter-clockwise seen from outside), turned
by a seeded roll about t. Along the card, v = j / K (j = 0 .. K, ``QUADS_PER_CARD`` = K):

    c(v) = p + L v t + h(v) n,    h(v) = -depth (1 - v)^4 + L (sin(lift) v + bend v^2)

so the root is ``depth`` under the skin, the card rises quickly through the skin and then lies back along
it, bending gently away like a shingle. Vertices beyond the root that would still be within
``CLEARANCE_M`` of the skin (where the surface curves up under the card) are pushed out along the field
gradient. The two edge vertices of a row are c -/+ (W / 2) b; st = (0 | 1, v)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rockdove.geometry import neck as _neck
from rockdove.geometry import sdf as _sdf
from rockdove.geometry import thickness as _thickness
from rockdove.geometry.types import MeshPart, Primvar, unit

#: Quads along each card (K): a slightly curved strip.
QUADS_PER_CARD = 3
#: Vertices of one card: two per row, K + 1 rows.
VERTICES_PER_CARD = 2 * (QUADS_PER_CARD + 1)
#: Smallest distance, metres, between the skin and any card vertex beyond the root row.
CLEARANCE_M = 0.0003
#: Full jitter amplitudes (at card_jitter = 1) of the yaw on the skin and of the roll about the card axis.
YAW_JITTER_DEG = 20.0
ROLL_JITTER_DEG = 15.0
#: How much "toward the tail" (-Z) is mixed into "down the neck" for the lie of the cards.
TAILWARD_MIX = 0.35
#: Card roots are placed up to s = 1 + this, just under the head: as the head's own feathers do, the top
#: row overlaps the top of the band, which cards lying down the neck from roots inside it cannot cover.
TOP_MARGIN_S = 0.06
#: The neck coordinate up to which card roots are placed.
BAND_S_MAX = 1.0 + TOP_MARGIN_S
#: Display colour of the cards (linear RGB): the dark slate of a neck feather.
FEATHER_DISPLAY_COLOR = (0.05, 0.07, 0.07)

#: Independent random streams, so that changing one parameter does not move unrelated things.
STREAM_PLACEMENT, STREAM_JITTER, STREAM_THICKNESS = 1, 2, 3
#: The primvar of the thickness field before the ranges place it: a viewer re-places the thickness for other ranges
#: exactly as a build with them would (rockdove.geometry.thickness.place_thickness_nm).
THICKNESS_FIELD = "thicknessField"
THICKNESS_FIELD_DOC = ("the card's film thickness before the ranges place it: (neck height h in [0, 1], smooth field in "
                       "half-widths of the range at h, jitter nm); thickness = clip(mid(h) + halfwidth(h) field + "
                       "jitter, lo(h), hi(h))")


def stream(seed: int, which: int) -> np.random.Generator:
    """The seeded generator of one random stream."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(which)]))


@dataclass(frozen=True)
class FeatherCards:
    """N cards of :data:`VERTICES_PER_CARD` vertices each, card-major: ``points_m`` float32 metres, ``normals``
    float32 unit, facing away from the skin, ``st`` float32 (u across the card, v from root 0 to tip 1), ``quads``
    (N K, 4) int32 counter-clockwise seen from outside; per card: ``root_skin_m`` (N, 3) the skin point it grows
    from, ``skin_normal`` (N, 3) the outward normal there, ``neck_s`` (N,) float32 its neck coordinate and
    ``thickness_nm`` (N,) float32 its film thickness and ``thickness_field`` (N, 3) float32 what placed it
    (:func:`rockdove.geometry.thickness.thickness_field`)."""

    points_m: np.ndarray
    normals: np.ndarray
    st: np.ndarray
    quads: np.ndarray
    root_skin_m: np.ndarray
    skin_normal: np.ndarray
    neck_s: np.ndarray
    thickness_nm: np.ndarray
    thickness_field: np.ndarray

    @property
    def count(self) -> int:
        return int(self.root_skin_m.shape[0])

    def triangles(self) -> np.ndarray:
        """(2 N K, 3) int64 triangles of the quads (same winding)."""
        q = self.quads.astype(np.int64)
        return np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])

    def part(self) -> MeshPart:
        """The cards as the one ``NeckFeathers`` mesh, with the ``thickness`` and ``neckS`` primvars."""
        per = VERTICES_PER_CARD
        primvars = {"thickness": Primvar(np.repeat(self.thickness_nm, per).astype(np.float32), "vertex",
                                         "film thickness, nm (constant over each card)"),
                    "neckS": Primvar(np.repeat(self.neck_s, per).astype(np.float32), "vertex",
                                     "neck coordinate of the card's root: 0 at the neck base, 1 at its top"),
                    THICKNESS_FIELD: Primvar(np.repeat(self.thickness_field, per, axis=0), "vertex",
                                             THICKNESS_FIELD_DOC)}
        return MeshPart(name="NeckFeathers", points_m=self.points_m,
                        face_vertex_counts=np.full(len(self.quads), 4, dtype=np.int32),
                        face_vertex_indices=self.quads.reshape(-1).astype(np.int32), normals=self.normals, st=self.st,
                        material="feather", display_color=FEATHER_DISPLAY_COLOR, primvars=primvars)


def _push_out(points: np.ndarray, direction: np.ndarray, clearance_m: float, steps: int = 8) -> np.ndarray:
    """Move (M, 3) points closer than ``clearance_m`` to the skin (or inside) out of the body: first along
    ``direction`` (M, 3), the card's skin normal (near the root the field gradient to within a few degrees, without
    the six field evaluations of a numerical gradient), then the few still too close (a tip reaching the curved
    shoulder) along the field gradient. The field is evaluated again only on the points that moved."""
    p = points.copy()
    todo = np.arange(len(p))
    d = _sdf.body_sdf(p)
    for step in range(steps):
        low = d < clearance_m
        if not low.any():
            break
        todo, d = todo[low], d[low]
        g = direction[todo] if step == 0 else _sdf.sdf_gradient(_sdf.body_sdf, p[todo])
        # aim past the clearance (the field is not an exact distance) so a point leaves in one or two steps
        p[todo] += ((1.5 if step == 0 else 1.0) * (1.2 * clearance_m - d))[:, None] * g
        d = _sdf.body_sdf(p[todo])
    return p


def snap_to_skin(points_m: np.ndarray):
    """(outward unit normals (N, 3), the points moved onto the body field's zero set) of points near the skin."""
    n = _sdf.sdf_gradient(_sdf.body_sdf, points_m)
    return n, points_m - _sdf.body_sdf(points_m)[:, None] * n


def card_frames(n: np.ndarray, rng: np.random.Generator, jitter: float):
    """Lie direction t and across direction b of each card (both (N, 3) unit) from the skin normals n (N, 3)."""
    axis = _sdf.NECK_TOP_M - _sdf.NECK_BASE_M
    flow = -axis / np.linalg.norm(axis) + TAILWARD_MIX * np.array([0.0, 0.0, -1.0])
    f = flow[None, :] - (n @ flow)[:, None] * n
    weak = np.linalg.norm(f, axis=1) < 0.2  # skin facing along the flow: fall back to straight down
    if weak.any():
        down = np.array([0.0, -1.0, 0.0])
        f[weak] = down - (n[weak] @ down)[:, None] * n[weak]
    f = unit(f)
    count = len(n)
    yaw = np.deg2rad(YAW_JITTER_DEG) * jitter * rng.uniform(-1.0, 1.0, count)
    roll = np.deg2rad(ROLL_JITTER_DEG) * jitter * rng.uniform(-1.0, 1.0, count)
    t = f * np.cos(yaw)[:, None] + np.cross(n, f) * np.sin(yaw)[:, None]
    b = np.cross(t, n)
    b = b * np.cos(roll)[:, None] - n * np.sin(roll)[:, None]
    return t, unit(b)


def build_cards(body, params) -> FeatherCards:
    """``params.card_count`` feather cards (sizes, jitter, lift, bend, root depth, thickness field and seed from
    the :class:`BirdParams` ``params``) on the neck band of ``body`` (a :class:`rockdove.geometry.Body`: its
    welded mesh and, when known, its band's area; else that is estimated, 200k samples, ~45 ms)."""
    n_cards = params.card_count
    roots = _neck.blue_noise_band(body.mesh.vertices_m, body.mesh.faces, n_cards,
                                  stream(params.seed, STREAM_PLACEMENT), s_max=BAND_S_MAX,
                                  area_m2=body.card_band_area_m2)
    n, roots = snap_to_skin(roots)  # the mesh is a chordal approximation of the field's zero set
    rng = stream(params.seed, STREAM_JITTER)
    t, b = card_frames(n, rng, params.card_jitter)
    length = rng.uniform(*params.card_length_m, n_cards)
    width = rng.uniform(*params.card_width_m, n_cards)
    depth = rng.uniform(*params.card_root_depth_m, n_cards)

    k = QUADS_PER_CARD
    v = np.arange(k + 1) / k  # (K+1,)
    lift = np.sin(np.deg2rad(params.card_lift_deg))
    h = (-depth[:, None] * (1.0 - v[None, :]) ** 4
         + length[:, None] * (lift * v[None, :] + params.card_bend * v[None, :] ** 2))  # (N, K+1)
    centre = (roots[:, None, :] + (length[:, None] * v[None, :])[..., None] * t[:, None, :]
              + h[..., None] * n[:, None, :])  # (N, K+1, 3)
    half = (0.5 * width)[:, None, None] * b[:, None, :]
    pts = np.stack([centre - half, centre + half], axis=2)  # (N, K+1, 2, 3): left, right
    above = pts[:, 1:].reshape(-1, 3)
    push_dir = np.broadcast_to(n[:, None, None, :], pts[:, 1:].shape).reshape(-1, 3)
    pts[:, 1:] = _push_out(above, push_dir, CLEARANCE_M).reshape(pts[:, 1:].shape)

    along = np.gradient(pts.mean(axis=2), axis=1)  # (N, K+1, 3), along the card's mid line
    across = pts[:, :, 1] - pts[:, :, 0]
    nrm = unit(np.cross(across, along))  # (N, K+1, 3), outward: b x t = n
    normals = np.repeat(nrm[:, :, None, :], 2, axis=2)

    st = np.empty((n_cards, k + 1, 2, 2), dtype=np.float32)
    st[..., 0] = np.array([0.0, 1.0], dtype=np.float32)[None, None, :]
    st[..., 1] = v.astype(np.float32)[None, :, None]

    j = np.arange(k)
    local = np.stack([2 * j, 2 * j + 1, 2 * j + 3, 2 * j + 2], axis=1)  # (K, 4)
    quads = (local[None, :, :] + (VERTICES_PER_CARD * np.arange(n_cards))[:, None, None]).reshape(-1, 4)

    s = np.clip(_neck.neck_s(roots)[0], 0.0, 1.0)
    field = _thickness.thickness_field(roots, params, stream(params.seed, STREAM_THICKNESS))
    thickness = _thickness.place_thickness_nm(field, params.thickness_base_nm, params.thickness_top_nm)
    return FeatherCards(points_m=pts.reshape(-1, 3).astype(np.float32),
                        normals=normals.reshape(-1, 3).astype(np.float32), st=st.reshape(-1, 2),
                        quads=quads.astype(np.int32), root_skin_m=roots, skin_normal=n, neck_s=s.astype(np.float32),
                        thickness_nm=thickness.astype(np.float32), thickness_field=field.astype(np.float32))

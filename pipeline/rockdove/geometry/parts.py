"""The bird's other parts: beak, cere, eyes, legs and feet. Surfaces of revolution, each closed and smooth.

A surface of revolution has a natural parametrisation, used as its st: u around (0 .. 1, the seam vertices
duplicated), v along the profile (0 .. 1).

Rock-dove numbers (Columba livia; Wikipedia, "Rock dove", Description, after Gibbs, Barnes and Cox, "Pigeons
and Doves", 2001): bill about 1.8 cm, grey-black, "with a conspicuous off-white cere" at its base; iris
orange, red or golden; feet purplish-red; tarsus 2.6-3.5 cm. The bill here is short and stout (a quarter of
its length deep at the base), slightly flattened side to side, pointing forward and a little down, rooted
:data:`BILL_EMBED_M` inside the head; its exposed length (:data:`BILL_LENGTH_M`, from where it leaves the
head's surface to the tip) is what tests compare with the cited 1.8 cm."""

from __future__ import annotations

import numpy as np

from rockdove.geometry import sdf as _sdf
from rockdove.geometry.colours import EYE_SRGB, TILE_START, atlas_st
from rockdove.geometry.types import MeshPart, triangle_part, unit

#: Segments around every surface of revolution.
AROUND = 20

#: Display colours (linear RGB).
BEAK_COLOR = (0.035, 0.03, 0.03)
CERE_COLOR = (0.75, 0.74, 0.70)
#: Orange-red iris (sRGB ~ (0.88, 0.36, 0.12)); the cited range is orange, red or golden.
EYE_COLOR = (0.75, 0.11, 0.013)
#: Purplish-red feet and legs (sRGB ~ (0.78, 0.25, 0.33)); dark horn claws.
LEG_COLOR = (0.57, 0.05, 0.09)
CLAW_COLOR = (0.025, 0.022, 0.024)

#: Exposed bill length from the head's surface to the tip, metres: about 1.8 cm (Wikipedia, "Rock dove").
BILL_LENGTH_M = 0.018
#: Depth of the bill at its base (twice its radius there), metres: stout, about a quarter of its length.
BILL_BASE_DEPTH_M = 0.0062
#: How far the bill's root is sunk into the head, metres (so no gap shows where it meets the face).
BILL_EMBED_M = 0.004
#: Direction of the bill: forward (+Z) and a little down (_BILL_AXIS: unit).
BILL_DIRECTION = (0.0, -0.30, 1.0)
_BILL_AXIS = np.asarray(BILL_DIRECTION, dtype=np.float64) / np.linalg.norm(BILL_DIRECTION)
#: Height of the bill's axis in the head's centre plane, metres: the axis leaves the face ~5 mm lower, a little
#: below the eyes, as the gape of a pigeon lies.
BILL_AXIS_Y_M = 0.2145
#: Length of the cere along the bill from the face, metres (it covers the nostrils on the base third).
CERE_LENGTH_M = 0.0075


def revolve(z_m: np.ndarray, radius_m: np.ndarray, around: int = AROUND):
    """Closed surface of revolution about +Z of a profile from pole to pole: ``z_m`` (M,) increasing, ``radius_m``
    (M,), 0 at both ends. Returns (vertices, unit outward normals, st (u around, v along), faces): every ring has a
    duplicated seam vertex and the poles are rings of coincident points; faces (2 (M - 1) around, 3) wind
    counter-clockwise seen from outside, without the degenerate triangles at the poles."""
    z = np.asarray(z_m, dtype=np.float64)
    r = np.asarray(radius_m, dtype=np.float64)
    m = len(z)
    phi = np.linspace(0.0, 2.0 * np.pi, around + 1)
    cos, sin = np.cos(phi), np.sin(phi)
    verts = np.stack([r[:, None] * cos[None, :], r[:, None] * sin[None, :],
                      np.broadcast_to(z[:, None], (m, around + 1))], axis=-1)
    nr, nz = np.gradient(z), -np.gradient(r)  # profile normal: the profile's tangent (dz, dr) turned outward
    ln = np.hypot(nr, nz)
    nr, nz = nr / ln, nz / ln
    nrm = np.stack([nr[:, None] * cos[None, :], nr[:, None] * sin[None, :],
                    np.broadcast_to(nz[:, None], (m, around + 1))], axis=-1)
    st = np.stack(np.broadcast_arrays((phi / (2.0 * np.pi))[None, :], np.linspace(0.0, 1.0, m)[:, None]),
                  axis=-1)
    idx = np.arange(m * (around + 1)).reshape(m, around + 1)
    a, b = idx[:-1, :-1], idx[:-1, 1:]
    c, d = idx[1:, 1:], idx[1:, :-1]
    # u runs counter-clockwise about +Z and v toward +Z, so (a, b, c) and (a, c, d) wind outward
    tri_lo = np.stack([a, b, c], axis=-1)  # uses ring j twice: degenerate on the first pole
    tri_hi = np.stack([a, c, d], axis=-1)  # uses ring j + 1 twice: degenerate on the last pole
    faces = np.concatenate([tri_lo[1:].reshape(-1, 3), tri_hi[:-1].reshape(-1, 3)])
    return verts.reshape(-1, 3), nrm.reshape(-1, 3), st.reshape(-1, 2).astype(np.float64), faces


def _frame(direction: np.ndarray) -> np.ndarray:
    """(3, 3) rotation whose third column is ``direction`` (unit) and whose second leans to +Y."""
    zc = direction / np.linalg.norm(direction)
    xc = np.cross(np.array([0.0, 1.0, 0.0]), zc)
    if np.linalg.norm(xc) < 1e-8:
        xc = np.cross(np.array([1.0, 0.0, 0.0]), zc)
    xc /= np.linalg.norm(xc)
    return np.stack([xc, np.cross(zc, xc), zc], axis=1)


def place(piece, origin_m, direction, scale_xy=(1.0, 1.0)):
    """Scale a revolved piece across its axis, turn its +Z to ``direction`` and move it to ``origin_m``."""
    verts, nrm, st, faces = piece
    s = np.array([scale_xy[0], scale_xy[1], 1.0])
    rot = _frame(np.asarray(direction, dtype=np.float64))
    v = (verts * s) @ rot.T + np.asarray(origin_m)
    return v, unit(nrm / s) @ rot.T, st, faces  # normals transform by the inverse scale


def _profile_z(length_m, m=16):
    """(m,) positions along a profile from pole (z = 0) to pole (z = length), denser near the poles."""
    return (0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, m))) * length_m


def ellipsoid_piece(radius_m: float, m: int = 12):
    """A sphere of ``radius_m`` along +Z from its south pole at z = 0 (scale across for an ellipsoid)."""
    a = np.linspace(0.0, np.pi, m)
    return revolve(radius_m * (1.0 - np.cos(a)), radius_m * np.sin(a))


def tube_piece(length_m: float, r0_m: float, r1_m: float, m: int = 14, uniform: bool = False):
    """A rounded tapered tube of ``length_m`` along +Z, radius r0 at the base to r1 near the end; ``m`` rings,
    denser at the ends (or evenly spaced: ``uniform``)."""
    z = np.linspace(0.0, length_m, m) if uniform else _profile_z(length_m, m)
    v = z / length_m
    body = r0_m + (r1_m - r0_m) * v
    cap = np.sqrt(np.clip(np.minimum(v, 1.0 - v) * length_m / max(r0_m, r1_m), 0.0, 1.0))
    r = body * np.minimum(1.0, 1.6 * cap)
    r[0] = r[-1] = 0.0
    return revolve(z, r)


def bill_root_m() -> np.ndarray:
    """(3,) point where the bill's axis leaves the head's surface (the body field's zero set), metres."""
    d = _BILL_AXIS
    start = np.array([0.0, BILL_AXIS_Y_M, float(_sdf.HEAD.centre_m[2])])
    # march out along the bill's direction from inside the head to the first point outside (0.05 mm steps)
    pts = start[None, :] + np.arange(0.0, 0.05, 0.00005)[:, None] * d[None, :]
    return pts[np.flatnonzero(_sdf.body_sdf(pts) > 0.0)[0]]


def build_beak() -> MeshPart:
    """The bill: short and stout (:data:`BILL_LENGTH_M` exposed), flattened side to side, slightly hooked down
    at the blunt tip; rooted :data:`BILL_EMBED_M` inside the head."""
    length = BILL_LENGTH_M + BILL_EMBED_M
    z = _profile_z(length, 18)
    v = z / length
    # full depth over the embedded root, then a taper that stays stout to the last quarter and rounds off
    r = 0.5 * BILL_BASE_DEPTH_M * np.sqrt(np.clip(1.0 - v**2.4, 0.0, 1.0)) * np.sqrt(np.clip(v * 12.0, 0.0, 1.0))
    r[-1] = 0.0
    root = bill_root_m() - BILL_EMBED_M * _BILL_AXIS
    return triangle_part("Beak", [place(revolve(z, r), root, _BILL_AXIS, (0.75, 1.0))], "beak", BEAK_COLOR)


def build_cere() -> MeshPart:
    """The cere: the off-white, powdery swelling over the nostrils on top of the base of the bill."""
    d = _BILL_AXIS
    up = np.array([0.0, 1.0, 0.0]) - d[1] * d
    up /= np.linalg.norm(up)
    # an ellipsoid from 1 mm inside the face to CERE_LENGTH_M along the bill, riding on its upper edge
    start = bill_root_m() - 0.001 * d + 0.42 * BILL_BASE_DEPTH_M * up
    piece = ellipsoid_piece(0.5 * (CERE_LENGTH_M + 0.001))
    return triangle_part("Cere", [place(piece, start, d, (0.62, 0.34))], "cere", CERE_COLOR)


EYE_CENTRE_M, EYE_RADIUS_M = (0.0142, 0.2185, 0.0905), 0.0042
#: The bare orbital ring (linear RGB): the rock dove's narrow, pale bluish-grey to whitish orbital skin (Gibbs et
#: al. 2001). The iris's tone in the atlas is colours.EYE_SRGB.
EYE_RING_COLOR = (0.50, 0.52, 0.56)
#: The ring's inner and outer radius about the eye's axis, metres: 1 .. 2 mm of bare skin round the eye.
EYE_RING_RADII_M = (0.0036, 0.0054)


def _eye_axis(side):
    outward = np.array([side, 0.15, 0.25])
    return np.array([side * EYE_CENTRE_M[0], *EYE_CENTRE_M[1:]]), outward / np.linalg.norm(outward)


def build_eyes() -> MeshPart:
    """Two eyes on the sides of the head (one part): the atlas's eye tile (orange-red iris, the pupil centred on
    the eye's outward axis, glossy), v from the back of the eyeball to the cornea."""
    r = EYE_RADIUS_M
    pieces = []
    for side in (1.0, -1.0):
        centre, outward = _eye_axis(side)
        v, n, st, f = place(ellipsoid_piece(r, 16), centre - r * outward, outward)
        pieces.append((v, n, atlas_st(TILE_START["eye", EYE_SRGB][0], st[:, 0], st[:, 1]), f))
    return triangle_part("Eyes", pieces, "plumage", EYE_COLOR)


def build_eye_rings() -> MeshPart:
    """Two thin grey orbital rings (one part): annuli from the eye's surface out onto the head's skin."""
    pieces = []
    k = AROUND + 4
    phi = np.linspace(0.0, 2.0 * np.pi, k + 1)[:-1]
    rho = np.linspace(*EYE_RING_RADII_M, 3)
    for side in (1.0, -1.0):
        centre, axis = _eye_axis(side)
        rot = _frame(axis)
        local = np.stack(np.broadcast_arrays(rho[:, None] * np.cos(phi), rho[:, None] * np.sin(phi), 0.0), -1)
        p = local.reshape(-1, 3) @ rot.T + centre
        eye_h = np.sqrt(np.clip(EYE_RADIUS_M ** 2 - np.repeat(rho, k) ** 2, 0.0, None))
        n = _sdf.sdf_gradient(_sdf.body_sdf, p)
        skin = p - (_sdf.body_sdf(p) - 0.00025)[:, None] * n  # onto the skin, 0.25 mm out
        h = np.maximum((skin - centre) @ axis, eye_h + 0.0001)  # and never under the eye's surface
        p = p + (h - (p - centre) @ axis)[:, None] * axis
        idx = np.arange(3 * k).reshape(3, k)
        a, b, c, d = idx[:-1], np.roll(idx[:-1], -1, 1), np.roll(idx[1:], -1, 1), idx[1:]
        faces = np.concatenate([np.stack([a, d, c], -1).reshape(-1, 3), np.stack([a, c, b], -1).reshape(-1, 3)])
        pieces.append((p, unit(0.5 * n + 0.5 * axis), np.zeros((len(p), 2)), faces))
    return triangle_part("EyeRings", pieces, "eyering", EYE_RING_COLOR)


#: Legs: the tarsus from the hip (inside the belly, so the tibia stays in the body's contour) to the ankle on
#: the ground, metres; three toes forward, one back (lengths m).
HIP_M, ANKLE_M = (0.016, 0.056, 0.006), (0.019, 0.0019, 0.022)
TOES = ((-28.0, 0.026), (0.0, 0.031), (28.0, 0.026), (180.0, 0.017))


#: Scutes: the transverse plates on the front of the tarsus and the top of the toes, their pitch (m) and the depth
#: of the grooves between them as a fraction of the radius; claws: length (m), base radius (m), droop (deg, at most
#: down to the ground).
SCUTE_PITCH_M, SCUTE_GROOVE = (0.0018, 0.0013), 0.12
CLAW_LENGTH_M, CLAW_RADIUS_M, CLAW_DROOP_DEG = 0.0055, 0.0009, 35.0


def scaly(piece, pitch_m: float, front=(0.0, 1.0)):
    """A tube of :func:`tube_piece` with scutes: grooves every ``pitch_m`` along it, deepest on its ``front``
    side (local x, y), gone on the back; the normals are the displaced mesh's (area-weighted)."""
    verts, smooth, st, faces = piece
    z, phi = verts[:, 2], np.arctan2(verts[:, 1], verts[:, 0])
    groove = np.clip(np.cos(2 * np.pi * z / pitch_m), 0, 1) ** 8 * np.clip(np.cos(phi - np.arctan2(*front[::-1])), 0, 1)
    v = verts * np.stack([1.0 - SCUTE_GROOVE * groove] * 2 + [np.ones_like(z)], 1)
    fn = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, faces[:, k], fn)
    return v, np.where(np.linalg.norm(n, axis=1, keepdims=True) > 0, unit(n), smooth), st, faces  # poles: as revolved


def _fine_tube(length_m, r0_m, r1_m, pitch_m):
    return scaly(tube_piece(length_m, r0_m, r1_m, int(round(4 * length_m / pitch_m)) + 1, uniform=True), pitch_m)


def build_legs() -> tuple:
    """``(Legs, Claws)``: tarsus from inside the belly to the foot, three toes forward and one back, with scutes,
    soles at y = 0; a dark claw at the end of every toe, curving down."""
    pieces, claws = [], []
    toe_r = 0.0019
    for side in (1.0, -1.0):
        hip = np.array([side * HIP_M[0], *HIP_M[1:]])
        foot = np.array([side * ANKLE_M[0], *ANKLE_M[1:]])
        tarsus = _fine_tube(np.linalg.norm(foot - hip) + 0.002, 0.0034, 0.0026, SCUTE_PITCH_M[0])
        pieces.append(place(tarsus, hip, foot - hip))
        for yaw_deg, length in TOES:
            yaw = np.deg2rad(yaw_deg * side)
            d = np.array([np.sin(yaw), -0.04, np.cos(yaw)])
            pieces.append(place(_fine_tube(length, toe_r, 0.0011, SCUTE_PITCH_M[1]), foot - 0.002 * d, d))
            tip = foot - 0.002 * d + (length - 0.0022) * d + np.array([0.0, 0.0003, 0.0])
            droop = min(np.deg2rad(CLAW_DROOP_DEG), np.arcsin(np.clip(tip[1] / CLAW_LENGTH_M, 0, 1)))  # to the ground
            cz = _profile_z(CLAW_LENGTH_M, 10)
            claw = revolve(cz, CLAW_RADIUS_M * (1.0 - cz / CLAW_LENGTH_M) ** 0.7 * np.sqrt(
                np.clip(cz / 0.0004, 0, 1)))
            claws.append(place(claw, tip, d * np.cos(droop) - np.array([0.0, np.sin(droop), 0.0]), (0.75, 1.0)))
    return (triangle_part("Legs", pieces, "leg", LEG_COLOR), triangle_part("Claws", claws, "claw", CLAW_COLOR))


def build_parts() -> tuple:
    """Beak, cere, eyes, eye rings, legs and claws, in that order (each a :class:`MeshPart`)."""
    return (build_beak(), build_cere(), build_eyes(), build_eye_rings()) + build_legs()

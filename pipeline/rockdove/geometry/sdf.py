"""Signed-distance primitives and the rock dove's body field (negative inside), all vectorised over (N, 3).

Primitives and the polynomial smooth minimum follow Inigo Quilez, "distance functions" and "smooth minimum"
(iquilezles.org, 2008-2013): the ellipsoid uses his bound ``k0 (k0 - 1) / k1``, the tapered capsule the
linearly interpolated radius along the segment. Smooth union:
``h = clip(0.5 + 0.5 (b - a) / k, 0, 1); d = mix(b, a, h) - k h (1 - h)``.

The bird faces +Z, Y up, metres, feet at y = 0 (docs/design.md, Conventions). Proportions: see the body's
section below; the shapes were tuned against side-view photographs and the measures of rockdove.verify.anatomy."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rockdove.geometry.types import unit


def rotation_x(angle_rad: float) -> np.ndarray:
    """(3, 3) rotation about +X by ``angle_rad`` (right-handed)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


@dataclass(frozen=True)
class Ellipsoid:
    """Ellipsoid: ``centre_m`` (3,), ``radii_m`` (3,) along its local axes, ``rotation`` (3, 3) local -> world."""

    centre_m: tuple
    radii_m: tuple
    rotation: np.ndarray = None

    def sdf(self, p: np.ndarray) -> np.ndarray:
        """(N,) approximate signed distance, metres (Quilez's bound), at (N, 3) points ``p``."""
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        return self.sdf_xyz(p[:, 0], p[:, 1], p[:, 2])

    def sdf_xyz(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """:meth:`sdf` on separate (N,) coordinate arrays (contiguous 1-D arithmetic: about twice as fast)."""
        cx, cy, cz = self.centre_m
        qx, qy, qz = x - cx, y - cy, z - cz
        r = self.rotation
        if r is not None:  # q @ r
            qx, qy, qz = (qx * r[0, 0] + qy * r[1, 0] + qz * r[2, 0], qx * r[0, 1] + qy * r[1, 1] + qz * r[2, 1],
                          qx * r[0, 2] + qy * r[1, 2] + qz * r[2, 2])
        rx, ry, rz = self.radii_m
        qx /= rx
        qy /= ry
        qz /= rz
        k0 = np.sqrt(qx * qx + qy * qy + qz * qz)
        qx /= rx
        qy /= ry
        qz /= rz
        k1 = np.sqrt(qx * qx + qy * qy + qz * qz)
        return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


@dataclass(frozen=True)
class TaperedCapsule:
    """Capsule from ``a_m`` (radius ``ra_m``) to ``b_m`` (radius ``rb_m``), radius linear along the segment."""

    a_m: tuple
    b_m: tuple
    ra_m: float
    rb_m: float

    def sdf_xyz(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """(N,) approximate signed distance, metres, at the points of the (N,) coordinate arrays."""
        a, b = np.asarray(self.a_m, dtype=np.float64), np.asarray(self.b_m, dtype=np.float64)
        ba = b - a
        px, py, pz = x - a[0], y - a[1], z - a[2]
        t = np.clip((px * ba[0] + py * ba[1] + pz * ba[2]) / (ba @ ba), 0.0, 1.0)
        px -= t * ba[0]
        py -= t * ba[1]
        pz -= t * ba[2]
        return np.sqrt(px * px + py * py + pz * pz) - (self.ra_m + t * (self.rb_m - self.ra_m))


def smooth_union(a: np.ndarray, b: np.ndarray, k_m: float) -> np.ndarray:
    """Polynomial smooth minimum of two distance fields with blend radius ``k_m`` metres (Quilez)."""
    h = np.clip(0.5 + 0.5 * (b - a) / k_m, 0.0, 1.0)
    return b * (1.0 - h) + a * h - k_m * h * (1.0 - h)


# ---- the rock dove's body: torso, breast, belly, rump, neck, head (one closed surface) ------------------
# Measurements of Columba livia (cited in rockdove.verify.anatomy, which checks the written asset against them):
# total length 29-37 cm, tail 9.5-12 cm, tarsus 2.6-3.5 cm (Gibbs, Barnes and Cox, "Pigeons and Doves", 2001;
# Wikipedia, "Rock dove"). Standing, the trunk is held 30-45 degrees nose-up with the breast full and forward,
# the small head held up over it and the back sloping on into the tail (from side-view photographs).
# The folded wings and the tail are feather cards (rockdove.geometry.plumage), not part of this field.
_DEG = np.pi / 180.0

#: Body axis above the horizontal, degrees.
BODY_PITCH_DEG = 44.0
#: Torso: the trunk, tilted nose-up by BODY_PITCH_DEG.
TORSO = Ellipsoid((0.0, 0.098, -0.012), (0.045, 0.044, 0.076), rotation_x(-BODY_PITCH_DEG * _DEG))
#: The full breast in front of and below the neck.
BREAST = Ellipsoid((0.0, 0.122, 0.046), (0.041, 0.046, 0.042), None)
#: Belly, between the legs.
BELLY = Ellipsoid((0.0, 0.061, 0.000), (0.034, 0.032, 0.040), None)
#: Rump and tail coverts: the trunk tapering into the tail along the slope of the back.
RUMP = Ellipsoid((0.0, 0.059, -0.067), (0.024, 0.016, 0.026), rotation_x(-28 * _DEG))
#: Neck: a tapered capsule from the shoulders to under the head, leaning forward.
NECK = TaperedCapsule((0.0, 0.150, 0.040), (0.0, 0.203, 0.072), 0.026, 0.0165)
#: Head: small and rounded, only slightly longer front to back than it is high.
HEAD = Ellipsoid((0.0, 0.214, 0.083), (0.0190, 0.0200, 0.0215), rotation_x(10 * _DEG))
#: Around the neck band the body keeps the shoulders and breast the iridescent cards were tuned on (the
#: coherent green/purple field at the 90 degree sweep): torso and breast of the earlier bird, blended into the
#: new trunk over NECK_BLEND_RADII_M from the neck axis, so the band, its cards and their thickness field stay
#: as they were.
NECK_TORSO = Ellipsoid((0.0, 0.112, -0.005), (0.048, 0.050, 0.088), rotation_x(-22 * _DEG))
NECK_BREAST = Ellipsoid((0.0, 0.122, 0.045), (0.043, 0.047, 0.045), None)
BELLY_NECK = Ellipsoid((0.0, 0.080, 0.008), (0.036, 0.037, 0.050), None)
NECK_BLEND_RADII_M = (0.050, 0.064)
NECK_BLEND_S = (-0.55, -0.3)

#: Neck axis for the band coordinate s: s = 0 at the base of the neck, s = 1 at its top below the head.
NECK_BASE_M = np.array([0.0, 0.150, 0.038])
NECK_TOP_M = np.array([0.0, 0.197, 0.068])
#: Surface points farther than this from the neck axis are not in the neck band (excludes back and breast).
NECK_BAND_RADIUS_M = 0.034

#: Axis-aligned box that holds the whole body surface, metres (min corner, max corner).
BODY_BOUNDS_M = (np.array([-0.062, 0.030, -0.205]), np.array([0.062, 0.240, 0.115]))


def neck_s(points_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(s, radius_m) of (N, 3) points, float64: the projection on the neck axis, 0 at its base and 1 at its top
    (not clipped), and the distance from the axis line, metres."""
    q = np.asarray(points_m, dtype=np.float64).reshape(-1, 3) - NECK_BASE_M
    axis = NECK_TOP_M - NECK_BASE_M
    s = (q @ axis) / (axis @ axis)
    return s, np.linalg.norm(q - s[:, None] * axis, axis=1)


def body_sdf(p: np.ndarray) -> np.ndarray:
    """(N,) float64 signed distance, metres (approximate: Lipschitz <~ 1), from (N, 3) points to the body surface
    (torso, breast, belly, rump, neck, head; negative inside)."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    x, y, z = (np.ascontiguousarray(p[:, a]) for a in range(3))
    d = smooth_union(TORSO.sdf_xyz(x, y, z), BREAST.sdf_xyz(x, y, z), 0.035)
    d = smooth_union(d, BELLY.sdf_xyz(x, y, z), 0.035)
    d = smooth_union(d, RUMP.sdf_xyz(x, y, z), 0.02)
    # the neck band's surroundings (see NECK_TORSO): weight 1 near the neck axis, 0 on the trunk
    s, r = neck_s(p)
    w = smoothstep(NECK_BLEND_S[0], NECK_BLEND_S[1], s) * (1.0 - smoothstep(*NECK_BLEND_RADII_M, r))
    i = np.flatnonzero(w > 0.0)
    if len(i):
        xi, yi, zi = x[i], y[i], z[i]
        old = smooth_union(NECK_TORSO.sdf_xyz(xi, yi, zi), NECK_BREAST.sdf_xyz(xi, yi, zi), 0.025)
        old = smooth_union(old, BELLY_NECK.sdf_xyz(xi, yi, zi), 0.02)
        d[i] = w[i] * old + (1.0 - w[i]) * d[i]
    d = smooth_union(d, NECK.sdf_xyz(x, y, z), 0.03)
    return smooth_union(d, HEAD.sdf_xyz(x, y, z), 0.012)


def smoothstep(e0, e1, x):
    """Hermite smoothstep of ``x`` between the edges ``e0`` and ``e1``: 0 below, 1 above, 3 t^2 - 2 t^3 between."""
    t = np.clip((np.asarray(x, dtype=np.float64) - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def sdf_gradient(sdf, p: np.ndarray, step_m: float = 1e-4) -> np.ndarray:
    """(N, 3) unit gradient of ``sdf`` at ``p`` by central differences (outward normal on the surface)."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    g = np.empty_like(p)
    for axis in range(3):  # three axes, not a loop over points
        e = np.zeros(3)
        e[axis] = step_m
        g[:, axis] = sdf(p + e) - sdf(p - e)
    return unit(g)

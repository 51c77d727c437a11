"""Cameras and lights of the verification renders: a turntable of the bird, the hero view and the paper's light sweep.

A :class:`View` (docs/design.md, "Render views") is one camera (OpenGL convention: it looks down its local -Z with
+Y up; ``camera_to_world`` acts on column vectors) plus one directional light. In the light sweep the camera stays
still and the light turns about its up axis, so the light-view angle ``alpha`` passes 90 degrees, where
``cos_theta = cos(alpha / 2)``, ``theta = 45`` degrees: the green/purple flip (docs/design.md, "Conventions")."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError

#: D65 white in the working space lin_rec709 (docs/design.md, "Conventions").
D65_WHITE_RGB = (1.0, 1.0, 1.0)
#: Turntable key light in camera coordinates (from the surface toward the light): up-left-front.
TURNTABLE_LIGHT_CAMERA = (-0.4, 0.5, 0.77)
#: Turntable (and hero) camera elevation above the horizontal through the scene's centre, degrees: at the framing
#: distance of the default bird (~0.6 m) 8 degrees puts the camera ~0.08 m above the centre, about its eye height.
TURNTABLE_ELEVATION_DEG = 8.0
#: The hero view: azimuth (0 = in front of the beak, positive toward the bird's left, +X), degrees; its size as a
#: multiple of the verification views' (512 -> 1024); its distance as a fraction of the turntable's (the bird fills
#: ~80 % of the picture's height).
HERO_AZIMUTH_DEG = 40.0
HERO_SCALE = 2
HERO_ZOOM = 0.72
#: Vertical fields of view, degrees.
TURNTABLE_YFOV_DEG = 35.0
SWEEP_YFOV_DEG = 30.0
#: Light-view angles (degrees) of the default sweep: either side of the 90 degree flip.
DEFAULT_SWEEP_ANGLES_DEG = (60.0, 120.0)
#: Direction (world, from the neck toward the camera) of the sweep camera: the bird's left side, a little
#: to the front and above (the bird faces +Z, Y is up).
SWEEP_CAMERA_DIRECTION = (0.8, 0.25, 0.55)


@dataclass(frozen=True, eq=False)
class View:
    """One camera and one directional light; arrays are stored as read-only float64 copies."""

    name: str  # "turntable_030", "sweep_060", ...
    camera_to_world: np.ndarray  # (4, 4), OpenGL convention; translation in metres
    yfov_rad: float  # vertical field of view
    width: int  # pixels
    height: int
    light_direction: np.ndarray  # (3,) unit, world, from the surface toward the light
    light_rgb: np.ndarray  # (3,) linear lin_rec709; D65 white = (1, 1, 1)

    def __post_init__(self):
        m = np.asarray(self.camera_to_world, dtype=np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise UsageError(f"camera_to_world must be a finite (4, 4) matrix, got shape {m.shape}")
        if not (0 < float(self.yfov_rad) < math.pi):
            raise UsageError(f"yfov_rad must be in (0, pi), got {self.yfov_rad}")
        for key in ("width", "height"):
            _check_n(getattr(self, key), key)
            object.__setattr__(self, key, int(getattr(self, key)))
        ld = np.asarray(self.light_direction, dtype=np.float64).reshape(-1)
        if ld.shape != (3,) or not np.all(np.isfinite(ld)) or np.linalg.norm(ld) == 0:
            raise UsageError(f"light_direction must be a finite non-zero 3-vector, got {self.light_direction!r}")
        rgb = np.asarray(self.light_rgb, dtype=np.float64).reshape(-1)
        if rgb.shape != (3,) or not np.all(np.isfinite(rgb)) or np.any(rgb < 0):
            raise UsageError(f"light_rgb must be 3 finite values >= 0, got {self.light_rgb!r}")
        norm = np.linalg.norm(ld)
        if abs(norm - 1.0) > 1e-12:  # keep already-unit vectors bit-exact, so View(**to_dict()) round-trips
            ld = ld / norm
        for key, val in (("camera_to_world", m), ("light_direction", ld), ("light_rgb", rgb)):
            val = val.copy()
            val.setflags(write=False)
            object.__setattr__(self, key, val)
        object.__setattr__(self, "yfov_rad", float(self.yfov_rad))

    @property
    def eye_m(self) -> np.ndarray:
        """Camera position, world metres, (3,)."""
        return self.camera_to_world[:3, 3].copy()

    @property
    def aspect(self) -> float:
        return self.width / self.height

    def to_dict(self) -> dict:
        """JSON-serialisable form (plain lists and numbers); ``View(**d)`` is its inverse."""
        return {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in vars(self).items()}

    def __eq__(self, other):
        if not isinstance(other, View):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """Camera-to-world matrix (OpenGL: looks down -Z) of a camera at ``eye`` looking at ``target``, (4, 4)."""
    eye, target = np.asarray(eye, dtype=np.float64), np.asarray(target, dtype=np.float64)
    z = eye - target
    if np.linalg.norm(z) == 0:
        raise UsageError(f"eye and target must differ, both are {eye.tolist()}")
    z /= np.linalg.norm(z)
    x = np.cross(np.asarray(up, dtype=np.float64), z)
    if np.linalg.norm(x) < 1e-9:  # looking along up: pick another up
        x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, eye
    return m


def direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """Unit world direction at ``azimuth_deg`` (0 = +Z, in front of the beak; positive toward +X) and
    ``elevation_deg`` above the horizontal."""
    a, e = math.radians(azimuth_deg), math.radians(elevation_deg)
    return np.array([math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)])


def _rotate(v, axis, angle_rad):
    """Rodrigues rotation of ``v`` about unit ``axis`` by ``angle_rad``."""
    v, k = np.asarray(v, dtype=np.float64), np.asarray(axis, dtype=np.float64)
    k = k / np.linalg.norm(k)
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return v * c + np.cross(k, v) * s + k * np.dot(k, v) * (1 - c)


def _fit_distance(radius_m: float, yfov_rad: float, aspect: float, margin: float = 1.1) -> float:
    """Distance at which a sphere of ``radius_m`` fits the narrower field of view, with ``margin``."""
    half = min(yfov_rad / 2, math.atan(math.tan(yfov_rad / 2) * aspect))
    return margin * radius_m / math.sin(half)


def _check_n(n, name="n"):
    if int(n) != n or int(n) < 1:
        raise UsageError(f"{name} must be a positive integer, got {n!r}")
    return int(n)


def turntable_views(scene_bounds, n: int, width: int, height: int, start_azimuth_deg: float = 30.0) -> list[View]:
    """``n`` views of ``width`` x ``height`` px orbiting the world ``[min, max]`` bounds ``scene_bounds`` (metres),
    evenly in azimuth from ``start_azimuth_deg`` (0 = camera on +Z, in front of the beak; positive toward +X), the
    bounding sphere framed with a 10 % margin; named ``turntable_<azimuth in degrees, 3 digits>``."""
    n = _check_n(n)
    b = np.asarray(scene_bounds, dtype=np.float64)
    if b.shape != (2, 3) or not np.all(np.isfinite(b)) or np.any(b[1] < b[0]):
        raise UsageError(f"scene_bounds must be a finite (2, 3) [min, max] array, got {scene_bounds!r}")
    centre = b.mean(axis=0)
    radius = max(0.5 * float(np.linalg.norm(b[1] - b[0])), 1e-6)
    yfov = math.radians(TURNTABLE_YFOV_DEG)
    dist = _fit_distance(radius, yfov, width / height)
    views = []
    for k in range(n):
        az_deg = (start_azimuth_deg + 360.0 * k / n) % 360.0
        c2w = look_at(centre + dist * direction(az_deg, TURNTABLE_ELEVATION_DEG), centre)
        light = c2w[:3, :3] @ np.asarray(TURNTABLE_LIGHT_CAMERA, dtype=np.float64)
        views.append(View(f"turntable_{int(round(az_deg)) % 360:03d}", c2w, yfov, width, height, light, D65_WHITE_RGB))
    return views


def hero_view(scene_bounds, width: int, height: int) -> View:
    """The hero 3/4 view, named ``hero``: the turntable frame at :data:`HERO_AZIMUTH_DEG` with its key light, the
    camera at :data:`HERO_ZOOM` of its distance (the turntable frames the bounding sphere, which leaves the bird at
    about half the picture's height)."""
    v = turntable_views(scene_bounds, 1, width, height, start_azimuth_deg=HERO_AZIMUTH_DEG)[0]
    c2w = v.camera_to_world.copy()
    centre = np.asarray(scene_bounds, dtype=np.float64).mean(axis=0)
    c2w[:3, 3] = centre + HERO_ZOOM * (c2w[:3, 3] - centre)
    return View("hero", c2w, v.yfov_rad, width, height, v.light_direction, v.light_rgb)


def light_sweep_views(neck_centre, n: int, width: int, height: int, angles_deg=None, distance_m: float = 0.25,
                      yfov_deg: float = SWEEP_YFOV_DEG, camera_direction=SWEEP_CAMERA_DIRECTION) -> list[View]:
    """The paper's experiment: a still camera ``distance_m`` from ``neck_centre`` (world metres) along
    ``camera_direction``, a D65-white directional light at each light-view angle ``alpha`` of ``angles_deg`` in
    [0, 180) (default ``n`` angles evenly over [30, 150], through the flip; 90 for ``n = 1``;
    :data:`DEFAULT_SWEEP_ANGLES_DEG` for ``n = 2``), ``V`` rotated about the camera's up axis by ``alpha``; named
    ``sweep_<alpha in degrees, 3 digits>``."""
    c = np.asarray(neck_centre, dtype=np.float64).reshape(-1)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise UsageError(f"neck_centre must be a finite 3-vector, got {neck_centre!r}")
    if not distance_m > 0:
        raise UsageError(f"distance_m must be > 0, got {distance_m}")
    if angles_deg is None:
        n = _check_n(n)
        angles_deg = DEFAULT_SWEEP_ANGLES_DEG if n == 2 else [90.0] if n == 1 else np.linspace(30.0, 150.0, n).tolist()
    angles = [float(a) for a in angles_deg]
    if any(not 0 <= a < 180 for a in angles):
        raise UsageError(f"angles_deg must lie in [0, 180), got {angles}")
    v = np.asarray(camera_direction, dtype=np.float64)
    v = v / np.linalg.norm(v)
    c2w = look_at(c + distance_m * v, c)
    yfov = math.radians(yfov_deg)
    # the light turns toward the camera's right (- about up): with the default camera on the bird's left side,
    # it moves toward the bird's front (the throat), and stays on one side of the picture
    return [View(f"sweep_{int(round(a)):03d}", c2w, yfov, width, height, _rotate(v, c2w[:3, 1], -math.radians(a)),
                 D65_WHITE_RGB) for a in angles]


def default_views(scene, width: int = 512, height: int = 512, n: int = 4) -> list[View]:
    """The verification views: ``ceil(n / 2)`` turntable frames, then ``floor(n / 2)`` light-sweep frames (``n =
    4``: azimuths 30 and 210, light-view angles 60 and 120 degrees), the sweep camera framing the feathers' bounds
    (at least 6 cm away)."""
    n = _check_n(n)
    views = turntable_views(scene.bounds_m, (n + 1) // 2, width, height)
    n_sweep = n // 2
    if n_sweep == 0:
        return views
    feathers = [p.positions_m for p in scene.parts if p.is_feather]
    if feathers:
        pts = np.concatenate(feathers).astype(np.float64)
        r = 0.5 * float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    else:
        b = scene.bounds_m
        r = 0.25 * float(np.linalg.norm(b[1] - b[0]))
    dist = max(_fit_distance(max(r, 1e-3), math.radians(SWEEP_YFOV_DEG), width / height, margin=1.05), 0.06)
    views += light_sweep_views(scene.neck_centre_m, n_sweep, width, height, distance_m=dist)
    return views

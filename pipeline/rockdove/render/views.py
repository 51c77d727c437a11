"""Cameras and lights of the verification renders: a turntable of the bird and the paper's light sweep.

A :class:`View` (docs/design.md, "Render views") is one camera (OpenGL convention: the camera looks down its
local -Z with +Y up; ``camera_to_world`` is a 4x4 matrix acting on column vectors) plus one directional light.

- :func:`turntable_views`: the camera orbits the bird about the world Y axis through the centre of the scene
  bounds; the light is **fixed relative to the camera** (a key light above and to the left of the camera,
  :data:`TURNTABLE_LIGHT_CAMERA`), so every frame is lit from the front as seen.
  The camera is at eye level (:data:`TURNTABLE_ELEVATION_DEG`): a few degrees above the centre, about the
  height of the bird's own eye at the framing distance, as a look-dev artist shoots a turntable; never below.
- :func:`hero_view`: the 3/4 front view a look-dev artist shows first, at :data:`HERO_SCALE` times the
  verification size (1024 x 1024 by default), camera at eye level in front of the bird's left shoulder.
- :func:`light_sweep_views`: the paper's experiment. The camera stays still, framing the neck; a D65-white
  directional light (``light_rgb = (1, 1, 1)`` in lin_rec709) rotates about the camera's up axis through the
  neck, so the angle ``alpha`` between the light direction ``L`` and the view direction ``V`` (both from the
  neck centre) sweeps through 90 degrees, where the film's incidence is ``cos_theta = dot(L, H) =
  cos(alpha / 2)``, ``theta = 45`` degrees: the green/purple flip (method.md, docs/design.md "Conventions").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: D65 white in the working space lin_rec709 (docs/design.md, "Conventions").
D65_WHITE_RGB = (1.0, 1.0, 1.0)
#: Turntable key light in camera coordinates (from the surface toward the light): up-left-front.
TURNTABLE_LIGHT_CAMERA = (-0.4, 0.5, 0.77)
#: Turntable camera elevation above the horizontal through the scene's centre, degrees: at the framing distance
#: of the default bird (~0.6 m) 8 degrees puts the camera ~0.08 m above the centre, at about the bird's eye height.
TURNTABLE_ELEVATION_DEG = 8.0
#: The hero view: azimuth (0 = in front of the beak, positive toward the bird's left, +X), elevation (degrees),
#: and its size as a multiple of the verification views' size (512 -> 1024).
HERO_AZIMUTH_DEG = 40.0
HERO_ELEVATION_DEG = 8.0
HERO_SCALE = 2
#: Hero camera distance as a fraction of the turntable's (the bird fills ~80 % of the picture's height).
HERO_ZOOM = 0.72
#: Default vertical fields of view, degrees.
TURNTABLE_YFOV_DEG = 35.0
SWEEP_YFOV_DEG = 30.0
#: Light-view angles (degrees) of the default sweep: either side of the 90 degree flip.
DEFAULT_SWEEP_ANGLES_DEG = (60.0, 120.0)
#: Direction (world, from the neck toward the camera) of the sweep camera: the bird's left side, a little
#: to the front and above (the bird faces +Z, Y is up).
SWEEP_CAMERA_DIRECTION = (0.8, 0.25, 0.55)


@dataclass(frozen=True, eq=False)
class View:
    """One camera and one directional light.

    Attributes
    ----------
    name : str
        ``"turntable_000"``, ``"sweep_060"``, ...
    camera_to_world : ndarray, (4, 4) float64
        OpenGL convention: the camera looks down its -Z, +Y up; translation in metres.
    yfov_rad : float
        Vertical field of view, radians.
    width, height : int
        Image size in pixels.
    light_direction : ndarray, (3,) float64
        Unit, world, from the surface toward the light.
    light_rgb : ndarray, (3,) float64
        Light colour, linear lin_rec709; D65 white = (1, 1, 1).
    """

    name: str
    camera_to_world: np.ndarray
    yfov_rad: float
    width: int
    height: int
    light_direction: np.ndarray
    light_rgb: np.ndarray

    def __post_init__(self):
        m = np.asarray(self.camera_to_world, dtype=np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise ValueError(f"camera_to_world must be a finite (4, 4) matrix, got shape {m.shape}")
        if not (0 < float(self.yfov_rad) < math.pi):
            raise ValueError(f"yfov_rad must be in (0, pi), got {self.yfov_rad}")
        for key in ("width", "height"):
            v = getattr(self, key)
            if int(v) != v or int(v) < 1:
                raise ValueError(f"{key} must be a positive integer, got {v!r}")
        ld = np.asarray(self.light_direction, dtype=np.float64).reshape(-1)
        if ld.shape != (3,) or not np.all(np.isfinite(ld)) or np.linalg.norm(ld) == 0:
            raise ValueError(f"light_direction must be a finite non-zero 3-vector, got {self.light_direction!r}")
        rgb = np.asarray(self.light_rgb, dtype=np.float64).reshape(-1)
        if rgb.shape != (3,) or not np.all(np.isfinite(rgb)) or np.any(rgb < 0):
            raise ValueError(f"light_rgb must be 3 finite values >= 0, got {self.light_rgb!r}")
        norm = np.linalg.norm(ld)
        if abs(norm - 1.0) > 1e-12:  # keep already-unit vectors bit-exact, so to_dict/from_dict round-trips
            ld = ld / norm
        for key, val in (("camera_to_world", m), ("light_direction", ld), ("light_rgb", rgb)):
            val = val.copy()
            val.setflags(write=False)
            object.__setattr__(self, key, val)
        object.__setattr__(self, "yfov_rad", float(self.yfov_rad))
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))

    @property
    def eye_m(self) -> np.ndarray:
        """Camera position, world metres, (3,)."""
        return self.camera_to_world[:3, 3].copy()

    @property
    def aspect(self) -> float:
        return self.width / self.height

    def to_dict(self) -> dict:
        """JSON-serialisable form (plain lists and numbers)."""
        return {
            "name": self.name,
            "camera_to_world": self.camera_to_world.tolist(),
            "yfov_rad": self.yfov_rad,
            "width": self.width,
            "height": self.height,
            "light_direction": self.light_direction.tolist(),
            "light_rgb": self.light_rgb.tolist(),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "View":
        """Inverse of :meth:`to_dict`."""
        return cls(
            name=str(d["name"]),
            camera_to_world=np.asarray(d["camera_to_world"], dtype=np.float64),
            yfov_rad=float(d["yfov_rad"]),
            width=int(d["width"]),
            height=int(d["height"]),
            light_direction=np.asarray(d["light_direction"], dtype=np.float64),
            light_rgb=np.asarray(d["light_rgb"], dtype=np.float64),
        )

    def __eq__(self, other):
        if not isinstance(other, View):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """Camera-to-world matrix (OpenGL: looks down -Z) of a camera at ``eye`` looking at ``target``, (4, 4)."""
    eye = np.asarray(eye, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    z = eye - target
    if np.linalg.norm(z) == 0:
        raise ValueError(f"eye and target must differ, both are {eye.tolist()}")
    z /= np.linalg.norm(z)
    x = np.cross(np.asarray(up, dtype=np.float64), z)
    if np.linalg.norm(x) < 1e-9:  # looking along up: pick another up
        x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, eye
    return m


def _rotate(v, axis, angle_rad):
    """Rodrigues rotation of ``v`` about unit ``axis`` by ``angle_rad``."""
    v = np.asarray(v, dtype=np.float64)
    k = np.asarray(axis, dtype=np.float64)
    k = k / np.linalg.norm(k)
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return v * c + np.cross(k, v) * s + k * np.dot(k, v) * (1 - c)


def _fit_distance(radius_m: float, yfov_rad: float, aspect: float, margin: float = 1.1) -> float:
    """Distance at which a sphere of ``radius_m`` fits the narrower field of view, with ``margin``."""
    half = min(yfov_rad / 2, math.atan(math.tan(yfov_rad / 2) * aspect))
    return margin * radius_m / math.sin(half)


def _check_n(n, name="n"):
    if int(n) != n or int(n) < 1:
        raise ValueError(f"{name} must be a positive integer, got {n!r}")
    return int(n)


def turntable_views(
    scene_bounds,
    n: int,
    width: int,
    height: int,
    elevation_deg: float = TURNTABLE_ELEVATION_DEG,
    start_azimuth_deg: float = 30.0,
    yfov_deg: float = TURNTABLE_YFOV_DEG,
    light_rgb=D65_WHITE_RGB,
) -> list[View]:
    """``n`` cameras orbiting the bird, evenly spaced in azimuth about world +Y.

    Parameters
    ----------
    scene_bounds : array_like, (2, 3)
        World ``[min, max]`` of the scene, metres (e.g. ``RenderScene.bounds_m``).
    n : int
        Number of views; view k is at azimuth ``start_azimuth_deg + 360 k / n`` (0 = camera on +Z, in
        front of the beak; positive toward +X).
    width, height : int
        Image size, pixels.
    elevation_deg : float
        Camera elevation above the horizontal through the bounds' centre, degrees, in (-90, 90).
    yfov_deg : float
        Vertical field of view, degrees; the bounding sphere is framed with a 10 % margin.
    light_rgb : (3,) linear lin_rec709
        The light is fixed relative to the camera at :data:`TURNTABLE_LIGHT_CAMERA`.

    Returns
    -------
    list of View, named ``turntable_<azimuth in degrees, 3 digits>``.
    """
    n = _check_n(n)
    b = np.asarray(scene_bounds, dtype=np.float64)
    if b.shape != (2, 3) or not np.all(np.isfinite(b)) or np.any(b[1] < b[0]):
        raise ValueError(f"scene_bounds must be a finite (2, 3) [min, max] array, got {scene_bounds!r}")
    if not -90 < elevation_deg < 90:
        raise ValueError(f"elevation_deg must be in (-90, 90), got {elevation_deg}")
    centre = b.mean(axis=0)
    radius = max(0.5 * float(np.linalg.norm(b[1] - b[0])), 1e-6)
    yfov = math.radians(yfov_deg)
    dist = _fit_distance(radius, yfov, width / height)
    el = math.radians(elevation_deg)
    views = []
    for k in range(n):
        az_deg = (start_azimuth_deg + 360.0 * k / n) % 360.0
        az = math.radians(az_deg)
        eye = centre + dist * np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])
        c2w = look_at(eye, centre)
        light = c2w[:3, :3] @ np.asarray(TURNTABLE_LIGHT_CAMERA, dtype=np.float64)
        views.append(
            View(f"turntable_{int(round(az_deg)) % 360:03d}", c2w, yfov, width, height, light, light_rgb)
        )
    return views


def hero_view(scene_bounds, width: int, height: int, azimuth_deg: float = HERO_AZIMUTH_DEG,
              elevation_deg: float = HERO_ELEVATION_DEG, yfov_deg: float = TURNTABLE_YFOV_DEG,
              light_rgb=D65_WHITE_RGB) -> View:
    """The hero 3/4 view, named ``hero``: one turntable frame at ``azimuth_deg``, the camera :data:`HERO_ZOOM` of
    the turntable's distance from the centre (the turntable frames the bounding sphere, which leaves the bird
    at about half the picture's height).

    Parameters are as for :func:`turntable_views` (``width`` x ``height`` in pixels, angles in degrees); the key
    light is the turntable's, fixed relative to the camera (up, left and in front of it).
    """
    v = turntable_views(scene_bounds, 1, width, height, elevation_deg=elevation_deg, start_azimuth_deg=azimuth_deg,
                        yfov_deg=yfov_deg, light_rgb=light_rgb)[0]
    c2w = v.camera_to_world.copy()
    b = np.asarray(scene_bounds, dtype=np.float64)
    centre = b.mean(axis=0)
    c2w[:3, 3] = centre + HERO_ZOOM * (c2w[:3, 3] - centre)
    return View("hero", c2w, v.yfov_rad, width, height, v.light_direction, v.light_rgb)


def light_sweep_views(
    neck_centre,
    n: int,
    width: int,
    height: int,
    angles_deg=None,
    distance_m: float = 0.25,
    yfov_deg: float = SWEEP_YFOV_DEG,
    camera_direction=SWEEP_CAMERA_DIRECTION,
    light_rgb=D65_WHITE_RGB,
) -> list[View]:
    """The paper's experiment: a still camera on the neck, a directional light rotating around it.

    The light direction is the view direction ``V`` (from the neck centre toward the camera) rotated about
    the camera's up axis by ``alpha``, so the angle between light and view is exactly ``alpha`` and the film
    sees ``cos_theta = cos(alpha / 2)``.

    Parameters
    ----------
    neck_centre : array_like, (3,)
        World point the camera looks at, metres (``RenderScene.neck_centre_m``).
    n : int
        Number of views (ignored when ``angles_deg`` is given).
    width, height : int
        Image size, pixels.
    angles_deg : sequence of float, optional
        Light-view angles ``alpha`` in [0, 180); default ``n`` values evenly spaced over [30, 150]
        (i.e. through the flip at 90), or :data:`DEFAULT_SWEEP_ANGLES_DEG` for ``n = 2``.
    distance_m : float
        Camera distance from the neck centre, metres.
    yfov_deg : float
        Vertical field of view, degrees.
    camera_direction : (3,)
        World direction from the neck to the camera.
    light_rgb : (3,)
        Linear lin_rec709 light colour, D65 white = (1, 1, 1).

    Returns
    -------
    list of View, named ``sweep_<alpha in degrees, 3 digits>``.
    """
    c = np.asarray(neck_centre, dtype=np.float64).reshape(-1)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise ValueError(f"neck_centre must be a finite 3-vector, got {neck_centre!r}")
    if not distance_m > 0:
        raise ValueError(f"distance_m must be > 0, got {distance_m}")
    if angles_deg is None:
        n = _check_n(n)
        if n == 2:
            angles_deg = DEFAULT_SWEEP_ANGLES_DEG
        else:
            angles_deg = [90.0] if n == 1 else np.linspace(30.0, 150.0, n).tolist()
    angles = [float(a) for a in angles_deg]
    if any(not 0 <= a < 180 for a in angles):
        raise ValueError(f"angles_deg must lie in [0, 180), got {angles}")
    v = np.asarray(camera_direction, dtype=np.float64)
    v = v / np.linalg.norm(v)
    c2w = look_at(c + distance_m * v, c)
    up_cam = c2w[:3, 1]
    yfov = math.radians(yfov_deg)
    views = []
    for a in angles:
        # rotate toward the camera's right (- about up): with the default camera on the bird's left side,
        # the light moves toward the bird's front (the throat), and stays on one side of the picture
        light = _rotate(v, up_cam, -math.radians(a))
        views.append(View(f"sweep_{int(round(a)):03d}", c2w, yfov, width, height, light, light_rgb))
    return views


def default_views(scene, width: int = 512, height: int = 512, n: int = 4) -> list[View]:
    """The verification views: ``ceil(n / 2)`` turntable frames, then ``floor(n / 2)`` light-sweep frames.

    ``n = 4`` (the benchmark's unit) gives 2 turntable frames (azimuth 30 and 210 degrees) and 2 sweep frames
    at light-view angles 60 and 120 degrees, either side of the green/purple flip. The sweep camera distance
    frames the feathers' bounds (at least 6 cm).
    """
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
    yfov = math.radians(SWEEP_YFOV_DEG)
    dist = max(_fit_distance(max(r, 1e-3), yfov, width / height, margin=1.05), 0.06)
    views += light_sweep_views(scene.neck_centre_m, n_sweep, width, height, distance_m=dist)
    return views

"""Parameters of the procedural rock dove (:class:`BirdParams`) and its two presets.

The thickness presets follow ../shared/reference/method.md: the measured cortex thickness of rock-dove neck
barbules is 480-580 nm at the base of the neck and 600-700 nm towards the top (Yoshioka, Nakamura and
Kinoshita, J. Phys. Soc. Jpn. 76(1), 2007); the seed paper uses 650 nm everywhere.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

from pipeline.geometry import thickness as _thickness
from pipeline.geometry.body import VOXEL_RANGE_M

#: Measured film thickness at the base of the neck, nm (Yoshioka et al. 2007).
MEASURED_BASE_NM = (480.0, 580.0)
#: Measured film thickness towards the top of the neck, nm (Yoshioka et al. 2007).
MEASURED_TOP_NM = (600.0, 700.0)
#: The seed paper's single film thickness, nm.
PAPER_THICKNESS_NM = 650.0


def _check_range(name, value, lo_allowed, hi_allowed, unit):
    """Validate a (min, max) pair of finite numbers within [lo_allowed, hi_allowed] with min <= max."""
    try:
        pair = tuple(float(v) for v in value)
    except TypeError:
        raise ValueError(f"{name}={value!r} must be a (min, max) pair in {unit}") from None
    if len(pair) != 2:
        raise ValueError(f"{name}={value!r} must be a (min, max) pair in {unit}, got {len(pair)} values")
    lo, hi = pair
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{name}={value!r} must be finite")
    if lo > hi:
        raise ValueError(f"{name}={value!r}: min {lo} is above max {hi}")
    if lo < lo_allowed or hi > hi_allowed:
        raise ValueError(f"{name}={value!r} must lie within [{lo_allowed}, {hi_allowed}] {unit}")
    return pair


def _check_number(name, value, lo_allowed, hi_allowed, unit, integer=False):
    if integer:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{name}={value!r} must be an integer")
    else:
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{name}={value!r} must be a number in {unit}") from None
        if not math.isfinite(value):
            raise ValueError(f"{name}={value!r} must be finite")
    if value < lo_allowed or value > hi_allowed:
        raise ValueError(f"{name}={value!r} must lie within [{lo_allowed}, {hi_allowed}] {unit}")
    return value


@dataclass(frozen=True)
class BirdParams:
    """Everything that shapes the procedural rock dove. Validated on construction (ValueError naming the field).

    Attributes
    ----------
    seed : int
        Seed of every random choice (card placement, jitter, thickness variation). >= 0.
    card_count : int
        Exact number of neck feather cards, 1 .. 1,000,000 (default 1500).
    card_length_m : (float, float)
        Range of card lengths, metres, within [0.001, 0.05] (default 10-15 mm, a rock dove's neck feathers).
    card_width_m : (float, float)
        Range of card widths, metres, within [0.0005, 0.03] (default 5-8 mm).
    card_jitter : float
        0 .. 1, scales the seeded jitter of each card's direction on the skin (up to +-20 deg at 1) and of its
        roll about its own axis (up to +-15 deg at 1).
    card_lift_deg : float
        Angle between a card and the skin at its root, degrees, 0 .. 45 (default 6).
    card_bend : float
        Extra rise of the tip away from the skin, as a fraction of the card length, 0 .. 0.5 (default 0.08):
        the card bends gently away from the skin, quadratically along its length.
    card_root_depth_m : (float, float)
        Range of depths of a card's root under the skin, metres, within [0, 0.002] (default 0.5-1.2 mm).
    thickness_base_nm : (float, float)
        Film thickness range at the base of the neck (s = 0), nm, within [1, 5000] (measured: 480-580).
    thickness_top_nm : (float, float)
        Film thickness range at the top of the neck (s = 1), nm, within [1, 5000] (measured: 600-700).
        The paper preset sets both ranges to (650, 650).
    thickness_correlation_length_m : float
        Correlation length of the smooth random thickness field over the neck skin, metres, 0.0005 .. 0.2
        (default 0.008: a few feathers across, so neighbouring feathers share their colour).
    thickness_spread : float
        Standard deviation of that field as a fraction of the half-width of the thickness range at the card's
        height, 0 .. 2 (default 0.5; values beyond the range are clipped to it).
    thickness_jitter_nm : float
        Standard deviation of each card's own independent thickness jitter, nm, 0 .. 100 (default 3).
    body_texture_resolution : int
        Width = height of the body base-colour texture, texels, 16 .. 8192 (default 1024).
    feather_texture_resolution : int
        Width = height of the feather textures, texels, 16 .. 4096 (default 256).
    body_voxel_m : float
        Detail of the body surface: about its edge length, metres, 0.0008 .. 0.01 (default 0.002, as in
        schemas/config.schema.json). The body and the wings are meshed and unwrapped on an 8 mm grid, then
        subdivided ``k = max(0, round(log2(0.008 / body_voxel_m)))`` times onto their implicit surfaces, 4x the
        triangles each: 0.002 gives k = 2 (58,112 body + 38,272 wing triangles), 0.004 gives k = 1
        (14,528 + 9,568), from about 0.0057 up k = 0 (3,632 + 2,392). Values between those snap to the nearest
        level.
    """

    seed: int = 0
    card_count: int = 1500
    card_length_m: tuple = (0.010, 0.015)
    card_width_m: tuple = (0.005, 0.008)
    card_jitter: float = 0.5
    card_lift_deg: float = 6.0
    card_bend: float = 0.08
    card_root_depth_m: tuple = (0.0005, 0.0012)
    thickness_base_nm: tuple = MEASURED_BASE_NM
    thickness_top_nm: tuple = MEASURED_TOP_NM
    thickness_correlation_length_m: float = _thickness.DEFAULT_CORRELATION_LENGTH_M
    thickness_spread: float = _thickness.DEFAULT_SPREAD
    thickness_jitter_nm: float = _thickness.DEFAULT_JITTER_NM
    body_texture_resolution: int = 1024
    feather_texture_resolution: int = 256
    body_voxel_m: float = 0.002

    def __post_init__(self):
        s = object.__setattr__
        s(self, "seed", _check_number("seed", self.seed, 0, 2**63 - 1, "", integer=True))
        s(self, "card_count", _check_number("card_count", self.card_count, 1, 1_000_000, "cards", integer=True))
        s(self, "card_length_m", _check_range("card_length_m", self.card_length_m, 0.001, 0.05, "m"))
        s(self, "card_width_m", _check_range("card_width_m", self.card_width_m, 0.0005, 0.03, "m"))
        s(self, "card_jitter", _check_number("card_jitter", self.card_jitter, 0.0, 1.0, ""))
        s(self, "card_lift_deg", _check_number("card_lift_deg", self.card_lift_deg, 0.0, 45.0, "deg"))
        s(self, "card_bend", _check_number("card_bend", self.card_bend, 0.0, 0.5, ""))
        s(self, "card_root_depth_m", _check_range("card_root_depth_m", self.card_root_depth_m, 0.0, 0.002, "m"))
        s(self, "thickness_base_nm", _check_range("thickness_base_nm", self.thickness_base_nm, 1.0, 5000.0, "nm"))
        s(self, "thickness_top_nm", _check_range("thickness_top_nm", self.thickness_top_nm, 1.0, 5000.0, "nm"))
        s(self, "thickness_correlation_length_m", _check_number(
            "thickness_correlation_length_m", self.thickness_correlation_length_m, 0.0005, 0.2, "m"))
        s(self, "thickness_spread", _check_number("thickness_spread", self.thickness_spread, 0.0, 2.0, ""))
        s(self, "thickness_jitter_nm", _check_number("thickness_jitter_nm", self.thickness_jitter_nm, 0.0, 100.0,
                                                     "nm"))
        s(self, "body_texture_resolution",
          _check_number("body_texture_resolution", self.body_texture_resolution, 16, 8192, "texels", integer=True))
        s(self, "feather_texture_resolution",
          _check_number("feather_texture_resolution", self.feather_texture_resolution, 16, 4096, "texels",
                        integer=True))
        s(self, "body_voxel_m", _check_number("body_voxel_m", self.body_voxel_m, *VOXEL_RANGE_M, "m"))

    @classmethod
    def measured(cls, **overrides) -> "BirdParams":
        """The measured preset: 480-580 nm at the neck base to 600-700 nm at the top (Yoshioka et al. 2007)."""
        return cls(**{"thickness_base_nm": MEASURED_BASE_NM, "thickness_top_nm": MEASURED_TOP_NM, **overrides})

    @classmethod
    def paper(cls, **overrides) -> "BirdParams":
        """The seed paper's preset: 650 nm everywhere (both ranges (650, 650))."""
        t = (PAPER_THICKNESS_NM, PAPER_THICKNESS_NM)
        return cls(**{"thickness_base_nm": t, "thickness_top_nm": t, **overrides})

    @classmethod
    def from_dict(cls, values: dict) -> "BirdParams":
        """Build from a mapping of field names (unknown names raise ValueError naming them)."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"unknown BirdParams fields {unknown}; known: {sorted(known)}")
        return cls(**values)

    def to_dict(self) -> dict:
        """Plain mapping of every field (tuples as lists), e.g. for hashing a build step's inputs."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}

    def with_(self, **changes) -> "BirdParams":
        """A copy with some fields changed (validated)."""
        return replace(self, **changes)

    def body_key(self) -> dict:
        """The fields the body (and its UVs and texture) depend on: the build graph can cache by these."""
        return {"body_voxel_m": self.body_voxel_m, "body_texture_resolution": self.body_texture_resolution}

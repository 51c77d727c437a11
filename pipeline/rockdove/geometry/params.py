"""Parameters of the procedural rock dove (:class:`BirdParams`) and its two presets.

The thickness presets follow ../shared/reference/method.md: the measured cortex thickness of rock-dove neck
barbules is 480-580 nm at the base of the neck and 600-700 nm towards the top (Yoshioka, Nakamura and
Kinoshita, J. Phys. Soc. Jpn. 76(1), 2007); the seed paper uses 650 nm everywhere.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

from rockdove.config import get, limits

#: Measured film thickness at the base of the neck, nm (Yoshioka et al. 2007).
MEASURED_BASE_NM = (480.0, 580.0)
#: Measured film thickness towards the top of the neck, nm (Yoshioka et al. 2007).
MEASURED_TOP_NM = (600.0, 700.0)
#: The seed paper's single film thickness, nm.
PAPER_THICKNESS_NM = 650.0
#: Defaults of the thickness field's parameters (rockdove.geometry.thickness; schemas/config.schema.json
#: documents the same values). Here rather than in thickness.py so that reading the parameters (the build
#: graph does on every run, even a no-op) imports no numpy.
DEFAULT_CORRELATION_LENGTH_M = 0.008
DEFAULT_SPREAD = 0.5
DEFAULT_JITTER_NM = 3.0


#: BirdParams field -> its key in the build configuration. Each field's allowed range is that key's minimum and
#: maximum in schemas/config.schema.json (:func:`rockdove.config.limits`): the schema is the user-facing contract
#: and the one place the ranges are written, so a config the schema accepts gives valid BirdParams and back.
CONFIG_KEYS = {
    "seed": "geometry.seed", "card_count": "geometry.card_count", "card_length_m": "geometry.card_length_m",
    "card_width_m": "geometry.card_width_m", "card_jitter": "geometry.card_jitter",
    "card_lift_deg": "geometry.card_lift_deg", "card_bend": "geometry.card_bend",
    "card_root_depth_m": "geometry.card_root_depth_m", "body_voxel_m": "geometry.body_voxel_m",
    "thickness_base_nm": "thickness.base_nm", "thickness_top_nm": "thickness.top_nm",
    "thickness_correlation_length_m": "thickness.correlation_length_m", "thickness_spread": "thickness.spread",
    "thickness_jitter_nm": "thickness.jitter_nm",
    "body_texture_resolution": "textures.body_resolution",
    "feather_texture_resolution": "textures.feather_resolution",
}


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


#: (field, kind, unit) in the order BirdParams checks them; kind: "int", "number" or "pair" (lo <= hi).
_CHECKS = (
    ("seed", "int", ""), ("card_count", "int", "cards"), ("card_length_m", "pair", "m"),
    ("card_width_m", "pair", "m"), ("card_jitter", "number", ""), ("card_lift_deg", "number", "deg"),
    ("card_bend", "number", ""), ("card_root_depth_m", "pair", "m"), ("thickness_base_nm", "pair", "nm"),
    ("thickness_top_nm", "pair", "nm"), ("thickness_correlation_length_m", "number", "m"),
    ("thickness_spread", "number", ""), ("thickness_jitter_nm", "number", "nm"),
    ("body_texture_resolution", "int", "texels"), ("feather_texture_resolution", "int", "texels"),
    ("body_voxel_m", "number", "m"),
)


@dataclass(frozen=True)
class BirdParams:
    """Everything that shapes the procedural rock dove. Validated on construction (ValueError naming the field)
    against the ranges of the configuration's keys in schemas/config.schema.json (:data:`CONFIG_KEYS`).

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
    thickness_correlation_length_m: float = DEFAULT_CORRELATION_LENGTH_M
    thickness_spread: float = DEFAULT_SPREAD
    thickness_jitter_nm: float = DEFAULT_JITTER_NM
    body_texture_resolution: int = 1024
    feather_texture_resolution: int = 256
    body_voxel_m: float = 0.002

    def __post_init__(self):
        for name, kind, unit in _CHECKS:
            value = getattr(self, name)
            if kind == "pair":
                value = _check_range(name, value, *limits(CONFIG_KEYS[name]), unit)
            else:
                value = _check_number(name, value, *limits(CONFIG_KEYS[name]), unit, integer=kind == "int")
            object.__setattr__(self, name, value)

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

    @classmethod
    def from_config(cls, config: dict) -> "BirdParams":
        """From a build configuration (:func:`rockdove.config.load_config`): the keys of :data:`CONFIG_KEYS`."""
        values = {name: get(config, key) for name, key in CONFIG_KEYS.items()}
        return cls(**{name: tuple(v) if isinstance(v, list) else v for name, v in values.items()})

    def to_dict(self) -> dict:
        """Plain mapping of every field (tuples as lists), e.g. for hashing a build step's inputs."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}

    def with_(self, **changes) -> "BirdParams":
        """A copy with some fields changed (validated)."""
        return replace(self, **changes)

    def body_key(self) -> dict:
        """The fields the body (and its UVs and texture) depend on: the build graph can cache by these."""
        return {"body_voxel_m": self.body_voxel_m, "body_texture_resolution": self.body_texture_resolution}

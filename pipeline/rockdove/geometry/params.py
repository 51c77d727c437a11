"""Parameters of the procedural rock dove (:class:`BirdParams`); its defaults are the configuration schema's.

The presets (assets/pigeon/*.toml) follow the literature: the measured cortex thickness of rock-dove neck
barbules is 480-580 nm at the base of the neck and 600-700 nm towards the top (Yoshioka, Nakamura and
Kinoshita, J. Phys. Soc. Jpn. 76(1), 2007); the seed paper uses 650 nm everywhere. This module imports no numpy:
the build graph reads the parameters on every run, even a no-op."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace

from rockdove.config import get, limits

from ..errors import UsageError

#: The seed paper's single film thickness, nm.
PAPER_THICKNESS_NM = 650.0

#: BirdParams field -> its key in the build configuration. Each field's allowed range is that key's minimum and
#: maximum in schemas/config.schema.json (:func:`rockdove.config.limits`): the schema is the user-facing contract
#: and the one place the ranges (and the meanings of the keys) are written.
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


def _check(name, value, default, lo_allowed, hi_allowed):
    """``value`` of the field ``name`` checked as its ``default`` is typed (int, float, or a (min, max) pair of
    floats with min <= max) and within [lo_allowed, hi_allowed]; ValueError naming the field."""
    unit = name.rsplit("_", 1)[-1] if name.endswith(("_m", "_nm", "_deg")) else ""
    if isinstance(default, tuple):
        try:
            pair = tuple(float(v) for v in value)
        except TypeError:
            raise UsageError(f"{name}={value!r} must be a (min, max) pair in {unit}") from None
        if len(pair) != 2:
            raise UsageError(f"{name}={value!r} must be a (min, max) pair in {unit}, got {len(pair)} values")
        if not all(math.isfinite(v) for v in pair):
            raise UsageError(f"{name}={value!r} must be finite")
        if pair[0] > pair[1]:
            raise UsageError(f"{name}={value!r}: min {pair[0]} is above max {pair[1]}")
        checked = pair
    elif isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise UsageError(f"{name}={value!r} must be an integer")
        checked = value
    else:
        try:
            checked = float(value)
        except (TypeError, ValueError):
            raise UsageError(f"{name}={value!r} must be a number in {unit}") from None
        if not math.isfinite(checked):
            raise UsageError(f"{name}={value!r} must be finite")
    ends = checked if isinstance(checked, tuple) else (checked, checked)
    if ends[0] < lo_allowed or ends[1] > hi_allowed:
        raise UsageError(f"{name}={value!r} must lie within [{lo_allowed}, {hi_allowed}] {unit}")
    return checked


@dataclass(frozen=True)
class BirdParams:
    """Everything that shapes the procedural rock dove, validated on construction (ValueError naming the field)
    against the ranges of the configuration keys of :data:`CONFIG_KEYS`; their meanings and units (metres, nm,
    degrees, texels) are the schema's (schemas/config.schema.json)."""

    seed: int = 0
    card_count: int = 1500
    card_length_m: tuple = (0.010, 0.015)
    card_width_m: tuple = (0.005, 0.008)
    card_jitter: float = 0.5
    card_lift_deg: float = 6.0
    card_bend: float = 0.08
    card_root_depth_m: tuple = (0.0005, 0.0012)
    thickness_base_nm: tuple = (PAPER_THICKNESS_NM, PAPER_THICKNESS_NM)
    thickness_top_nm: tuple = (PAPER_THICKNESS_NM, PAPER_THICKNESS_NM)
    thickness_correlation_length_m: float = 0.008
    thickness_spread: float = 0.5
    thickness_jitter_nm: float = 3.0
    body_texture_resolution: int = 1024
    feather_texture_resolution: int = 256
    body_voxel_m: float = 0.002

    def __post_init__(self):
        for f in fields(self):
            value = _check(f.name, getattr(self, f.name), f.default, *limits(CONFIG_KEYS[f.name]))
            object.__setattr__(self, f.name, value)

    @classmethod
    def from_config(cls, config: Mapping) -> BirdParams:
        """From a build configuration (:func:`rockdove.config.load_config`): the keys of :data:`CONFIG_KEYS`."""
        values = {name: get(config, key) for name, key in CONFIG_KEYS.items()}
        return cls(**{name: tuple(v) if isinstance(v, list) else v for name, v in values.items()})

    def to_dict(self) -> dict:
        """Plain mapping of every field (tuples as lists), e.g. for hashing a build step's inputs."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}

    def with_(self, **changes) -> BirdParams:
        """A copy with some fields changed (validated)."""
        return replace(self, **changes)

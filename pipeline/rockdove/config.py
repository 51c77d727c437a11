"""The build configuration: TOML layers checked against ``schemas/config.schema.json`` (draft 2020-12), the one
source of every parameter's documentation, unit, range and default. Layers, later wins: the schema's defaults, a
preset ``assets/pigeon/<preset>.toml``, ``--config FILE.toml``, ``--set KEY=VALUE``. Every problem is a one-line
:class:`UsageError` naming the key, the value and what the schema allows (exit 2 before anything is written)."""

from __future__ import annotations

import copy
import datetime
import functools
import hashlib
import json
import math
import operator
import os
import re
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from . import resources
from .errors import UsageError

DEFAULT_PRESET = "measured"

_KEY_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
_BARE_WORD_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.+-]*$")


@functools.lru_cache(maxsize=1)
def _schema_text() -> str:
    return resources.path("schemas/config.schema.json").read_text(encoding="utf-8")


def load_schema() -> dict:
    """The configuration's JSON Schema (a fresh copy; the file is read once)."""
    return json.loads(_schema_text())


def presets() -> list[str]:
    """Names of the presets in ``assets/pigeon/``, sorted."""
    return sorted(p.stem for p in resources.path("assets/pigeon").glob("*.toml"))


def preset_path(name: str) -> Path:
    """Path of preset ``name``; :class:`UsageError` naming the allowed presets when there is none."""
    allowed = presets()
    if name not in allowed:
        raise UsageError(f"preset {name!r} is unknown; allowed: {', '.join(allowed)}")
    return resources.path(f"assets/pigeon/{name}.toml")


def _defaults_of(node: dict) -> Any:
    if node.get("type") == "object" and "properties" in node:
        return {k: _defaults_of(v) for k, v in node["properties"].items()}
    return copy.deepcopy(node.get("default"))


def defaults() -> dict:
    """The configuration made of the schema's defaults alone."""
    return _defaults_of(load_schema())


def _merge(base: dict, layer: dict) -> dict:
    out = dict(base)
    for k, v in layer.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else copy.deepcopy(v)
    return out


def read_toml(path: str | os.PathLike, what: str = "config file") -> dict:
    """Read a TOML file; one-line :class:`UsageError` when it is missing, unreadable or malformed."""
    p = Path(path)
    if not p.exists():
        raise UsageError(f"{what} {str(p)!r} does not exist")
    if p.is_dir():
        raise UsageError(f"{what} {str(p)!r} is a directory, not a TOML file")
    try:
        with open(p, "rb") as f:
            return tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise UsageError(f"{what} {str(p)!r} is not valid TOML: {exc}") from None
    except RecursionError:  # tomllib parses arrays and inline tables recursively
        raise UsageError(f"{what} {str(p)!r} nests arrays or tables too deeply") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{what} {str(p)!r} cannot be read: {exc}") from None


def parse_set(item: str) -> tuple[str, Any]:
    """Parse one ``--set KEY=VALUE`` (``lut.angles=128``, ``thickness.base_nm=[500, 560]``, ``film.model=keratin``)."""
    if "=" not in item:
        raise UsageError(f"--set {item!r} is not KEY=VALUE; e.g. --set lut.angles=128")
    key, text = (s.strip() for s in item.split("=", 1))
    if not _KEY_RE.match(key):
        raise UsageError(f"--set {item!r}: key {key!r} is not a dotted name like 'lut.angles'")
    if text == "":
        raise UsageError(f"--set {item!r}: the value is empty; give a TOML literal, e.g. {key}=1")
    try:
        value = tomllib.loads(f"v = {text}")["v"]
    except RecursionError:
        raise UsageError(f"--set {key}=...: the value nests arrays or tables too deeply") from None
    except tomllib.TOMLDecodeError:
        if _BARE_WORD_RE.match(text) and text not in ("true", "false"):
            value = text
        else:
            raise UsageError(f"--set {item!r}: value {text!r} is not a TOML literal (number, string, "
                             f"true/false, [list])") from None
    return key, value


def _nest(key: str, value: Any) -> dict:
    return functools.reduce(lambda inner, part: {part: inner}, reversed(key.split(".")), value)


def schema_at(schema: dict, path: Iterable) -> dict:
    node = schema
    for part in path:
        node = node.get("items", {}) if isinstance(part, int) else node.get("properties", {}).get(part, {})
    return node


@functools.cache
def limits(key: str) -> tuple:
    """The schema's inclusive ``(minimum, maximum)`` of dotted config ``key`` (of its items for a ``[lo, hi]``
    pair): code that checks a value the config also carries reads its range here."""
    node = schema_at(load_schema(), key.split("."))
    if node.get("type") == "array":
        node = node.get("items", {})
    if "minimum" not in node or "maximum" not in node:
        raise KeyError(f"config key {key!r} has no minimum and maximum in schemas/config.schema.json")
    return node["minimum"], node["maximum"]


def _num(x) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def allowed(node: dict) -> str:
    """What a schema node allows, in words, with its unit: e.g. ``integer 2 to 4096 texels``."""
    unit = node.get("unit") or ""
    if "enum" in node:
        return "one of " + ", ".join(json.dumps(v) for v in node["enum"])
    types = node.get("type")
    types = [types] if isinstance(types, str) else list(types or [])
    nullable = "null" in types
    types = [t for t in types if t != "null"]
    if types == ["array"]:
        items = node.get("items", {})
        n = node.get("minItems"), node.get("maxItems")
        size = f"{n[0]}" if n[0] == n[1] else f"{n[0]}..{n[1]}"
        inner = allowed({**items, "unit": items.get("unit") or unit}) if items else "values"
        return f"a list of {size} ({inner})" + (f", {node['range']}" if node.get("range") else "")
    words = " or ".join(types) if types else "a value"
    lo = node.get("minimum", node.get("exclusiveMinimum"))
    hi = node.get("maximum", node.get("exclusiveMaximum"))
    if lo is not None or hi is not None:
        lo_s = ("> " if "exclusiveMinimum" in node else ">= ") + _num(lo) if lo is not None else ""
        hi_s = ("< " if "exclusiveMaximum" in node else "<= ") + _num(hi) if hi is not None else ""
        words += " " + " and ".join(s for s in (lo_s, hi_s) if s)
    if "minLength" in node:
        words += " (non-empty)"
    if unit:
        words += f" {unit}"
    if nullable:
        words += " (or unset: the model's value)"
    return words


def _dotted(path: Iterable) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def _show(value) -> str:
    """A value as TOML wrote it (``nan``, ``inf``, a date named as one), JSON otherwise."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, (datetime.date, datetime.time)):
        kind = "date-time" if isinstance(value, datetime.datetime) else type(value).__name__
        return f"{value.isoformat()} (a TOML {kind})"
    if isinstance(value, list):
        return "[" + ", ".join(map(_show, value)) + "]"
    return json.dumps(value, default=str)


def _check_finite(config: dict, schema: dict, path=()) -> None:
    """NaN and infinity are no value of any key (JSON Schema's ranges let NaN through): one line naming the key."""
    items = config.items() if isinstance(config, dict) else enumerate(config) if isinstance(config, list) else ()
    for k, v in items:
        if isinstance(v, float) and not math.isfinite(v):
            node = schema_at(schema, [*path, k])
            raise UsageError(f"config key {_dotted([*path, k])!r}: value {_show(v)} is not a finite number; "
                             f"allowed: {allowed(node) if node else 'a finite number'}")
        _check_finite(v, schema, (*path, k))


def _error_message(err, schema: dict) -> str:
    path = list(err.absolute_path)
    if err.validator == "additionalProperties":
        node = schema_at(schema, path)
        known = set(node.get("properties", {}))
        extra = sorted(set(err.instance) - known) if isinstance(err.instance, dict) else []
        key = _dotted(path + extra[:1])
        where = f"[{_dotted(path)}]" if path else "the top level"
        return (f"config key {key!r} is unknown; allowed keys in {where}: {', '.join(sorted(known))}")
    key = _dotted(path)
    node = schema_at(schema, path)
    if err.validator == "type" and node.get("type") == "object":
        return (f"config key {key!r}: value {_show(err.instance)} is not a table; allowed: a table with "
                f"keys {', '.join(sorted(node.get('properties', {})))}")
    what = {"type": "has the wrong type", "enum": "is not allowed", "minimum": "is out of range",
            "maximum": "is out of range", "exclusiveMinimum": "is out of range", "exclusiveMaximum": "is out of range",
            "minItems": "has too few items", "maxItems": "has too many items", "minLength": "is empty"}
    verb = what.get(err.validator, "is not allowed")
    return f"config key {key!r}: value {_show(err.instance)} {verb}; allowed: {allowed(node)}"


def validate(config: dict) -> dict:
    """``config`` checked against the schema and what it cannot say (ranges with lo <= hi), integer-typed
    values as ``int``; :class:`UsageError` naming the first problem's key, value and what is allowed."""
    import jsonschema

    schema = load_schema()
    _check_finite(config, schema)
    errors = sorted(jsonschema.Draft202012Validator(schema).iter_errors(config),
                    key=lambda e: (list(map(str, e.absolute_path)), e.validator))
    if errors:  # the deepest first is the most specific (an item's range before the list's type)
        raise UsageError(_error_message(max(errors, key=lambda e: len(e.absolute_path)), schema))
    for sect, node in schema["properties"].items():
        for key, sub in node.get("properties", {}).items():
            value = config.get(sect, {}).get(key)
            if sub.get("range") and isinstance(value, list) and value[0] > value[1]:
                raise UsageError(f"config key '{sect}.{key}': value {_show(value)} is an empty range "
                                 f"(lo > hi); allowed: {allowed(sub)}")
            if sub.get("type") == "integer" and isinstance(value, float):
                config[sect][key] = int(value)
    return config


def load_config(*, preset: str | None = DEFAULT_PRESET, config_file: str | os.PathLike | None = None,
                overrides: Mapping[str, Any] | Iterable[str] = ()) -> dict:
    """The effective, validated configuration: the ``preset`` (None: the schema's defaults only), the
    ``config_file`` over it, then ``overrides`` in order (``{dotted key: value}`` or ``KEY=VALUE`` strings)."""
    layers = []
    if preset is not None:
        layers.append(read_toml(preset_path(preset), what=f"preset {preset!r}"))
    if config_file is not None:
        layers.append(read_toml(config_file))
    if isinstance(overrides, Mapping):
        for key, value in overrides.items():
            if not isinstance(key, str) or not _KEY_RE.match(key):
                raise UsageError(f"override key {key!r} is not a dotted name like 'lut.angles'")
            layers.append(_nest(key, value))
    else:
        if isinstance(overrides, str):
            raise UsageError(f"overrides must be a mapping or a list of KEY=VALUE strings, got the string "
                             f"{overrides!r}")
        layers += [_nest(*parse_set(item)) for item in overrides]
    return validate(functools.reduce(_merge, layers, defaults()))


def canonical_json(value: Any) -> str:
    """Deterministic JSON text (sorted keys, no spaces) used for hashing."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=True)


def config_hash(config: dict) -> str:
    """sha256 (hex) of the canonical JSON of ``config``."""
    return hashlib.sha256(canonical_json(config).encode()).hexdigest()


class Config(Mapping[str, Any]):
    """A checked configuration, or the part of it a build stage declared, as a read-only value:
    ``config.lut.angles`` (a section reads as a Config, a list as a tuple). The names are the schema's; a key the
    schema has but this value lacks (a stage that did not declare it: its cache key would not cover it) raises
    AttributeError naming it. A Mapping too, for code that walks it (:func:`get`, :func:`canonical_json`)."""

    __slots__ = ("_data", "_path")

    def __init__(self, data: Mapping[str, Any], path: str = ""):
        self._data, self._path = data, path

    def __getattr__(self, name: str) -> Any:
        key = f"{self._path}.{name}".lstrip(".")
        if name.startswith("_") or name not in self._data:
            why = "was not declared (a stage's cache key covers only its declared keys)" \
                if schema_at(load_schema(), key.split(".")) else "is not in the schema"
            raise AttributeError(f"config key {key!r} {why}")
        value = self._data[name]
        if isinstance(value, Mapping):
            return Config(value, key)
        return tuple(value) if isinstance(value, list) else value

    def __getitem__(self, name: str) -> Any:
        return self._data[name]

    def __iter__(self):
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __repr__(self) -> str:
        return f"Config({dict(self._data)!r})"


def get(config: Mapping, key: str) -> Any:
    """The value at dotted ``key`` (``"lut"`` gives the section, ``"lut.angles"`` one value)."""
    return functools.reduce(operator.getitem, key.split("."), config)


def subset(config: Mapping, keys: Iterable[str]) -> dict:
    """The values at the dotted ``keys``, nested as in ``config`` (the part of it a build stage declared)."""
    return functools.reduce(_merge, (_nest(key, get(config, key)) for key in keys), {})


@dataclass(frozen=True)
class Parameter:
    """One configuration key as ``rockdove config`` shows it: value, unit, default, allowed, meaning (the schema's)."""

    key: str
    value: Any
    unit: str
    default: Any
    allowed: str
    description: str


def describe(config: Mapping) -> list[Parameter]:
    """One :class:`Parameter` per key of ``config``, in the schema's order."""
    leaves = [(f"{key}.{sub}" if sub else key, leaf) for key, node in load_schema()["properties"].items()
              for sub, leaf in (node["properties"].items() if node.get("properties") else [(None, node)])]
    return [Parameter(dotted, get(config, dotted), leaf.get("unit", ""), leaf.get("default"), allowed(leaf),
                      leaf.get("description", "")) for dotted, leaf in leaves]

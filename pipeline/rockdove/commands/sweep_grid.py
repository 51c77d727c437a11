"""The grid of ``rockdove sweep``: ``--grid 'KEY=[V1, V2, ...]'`` axes (TOML literals as ``--set`` takes them)
and their product, each point with a stable folder name."""

from __future__ import annotations

import collections
import hashlib
import itertools
import json
import re
from dataclasses import dataclass

from ..config import load_schema, parse_set, schema_at
from ..errors import UsageError


@dataclass(frozen=True)
class Point:
    """One grid point: folder ``name``, ``index`` per axis, ``overrides`` (``KEY=LITERAL``), parsed ``values``."""

    name: str
    index: tuple[int, ...]
    overrides: tuple[str, ...]
    values: dict


def split_array(text: str) -> list[str]:
    """The top-level elements of a TOML array literal ``[a, "b, c", [1, 2]]``, as written (quotes and nested
    brackets respected, a trailing comma allowed). Raises ValueError naming what is wrong."""
    text = text.strip()
    if not (text.startswith("[") and text.endswith("]")):
        raise UsageError(f"{text!r} is not a [list] of values")
    items, cur, depth, quote, escaped = [], [], 0, None, False
    for c in text[1:-1]:
        if quote:
            if escaped:
                escaped = False
            elif c == "\\" and quote == '"':
                escaped = True
            elif c == quote:
                quote = None
        elif c in "\"'":
            quote = c
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
            if depth < 0:
                raise UsageError(f"{text!r} has an unmatched {c!r}")
        elif c == "," and depth == 0:
            items.append("".join(cur).strip())
            cur = []
            continue
        cur.append(c)
    if quote or depth:
        raise UsageError(f"{text!r} has an unclosed {quote or 'bracket'}")
    items.append("".join(cur).strip())
    if items and items[-1] == "":
        items.pop()  # trailing comma
    if not items or any(it == "" for it in items):
        raise UsageError(f"{text!r} has an empty value" if items else f"{text!r} is empty; give at least one value")
    return items


def parse_grid(grid: list[str]) -> list[tuple[str, list[tuple[str, object]]]]:
    """``--grid`` items -> ``[(key, [(literal, value), ...]), ...]``. Raises UsageError (exit 2) for bad
    syntax, an unknown key, a key given twice or a value given twice."""
    if not grid:
        raise UsageError("no --grid given; e.g. --grid 'film.cauchy_a=[1.5, 1.55]'")
    axes = []
    for item in grid:
        if "=" not in item:
            raise UsageError(f"--grid {item!r} is not KEY=[V1, V2, ...]; e.g. --grid 'film.cauchy_a=[1.5, 1.55]'")
        key, text = (s.strip() for s in item.split("=", 1))
        try:
            literals = split_array(text)
        except ValueError as exc:
            raise UsageError(f"--grid {item!r}: {exc}; e.g. --grid '{key}=[V1, V2]'") from None
        values = [parse_set(f"{key}={lit}")[1] for lit in literals]  # the key's syntax and each literal's
        node = schema_at(load_schema(), key.split("."))
        if not node:
            raise UsageError(f"--grid {item!r}: unknown key {key!r}; `rockdove config` lists the keys")
        if "properties" in node:
            raise UsageError(f"--grid {item!r}: {key!r} is a section; sweep one of its keys, e.g. {key}.<name>")
        if key in (k for k, _ in axes):
            raise UsageError(f"--grid {key!r} is given twice; put all its values in one list")
        seen = {}
        for lit, v in zip(literals, values):
            canon = json.dumps(_canonical(v), sort_keys=True, default=str)
            if canon in seen:
                raise UsageError(f"--grid {item!r}: value {lit} is given twice (as {seen[canon]})")
            seen[canon] = lit
        axes.append((key, list(zip(literals, values))))
    return axes


def _canonical(v):
    """One value per number however it is spelt: ``3`` and ``3.0`` are 3, ``-0.0`` is 0 (lists, tables inside)."""
    if isinstance(v, float) and v.is_integer():
        return int(v)
    if isinstance(v, list):
        return [_canonical(x) for x in v]
    return {k: _canonical(x) for k, x in v.items()} if isinstance(v, dict) else v


_UNSAFE = re.compile(r"[^A-Za-z0-9._+=-]+")
_HASHED = re.compile(r"-[0-9a-f]{8}$")


def grid_points(axes) -> list[Point]:
    """The product of the axes in order (the last key varies fastest), each with a stable, readable folder name of
    its ``KEY=VALUE`` pairs, ended by a short hash of its overrides where two would read the same (also ignoring
    case), one is long, or one reads like a hashed name: names cannot collide (two equal hashes are refused)."""
    points = []
    for combo in itertools.product(*[list(enumerate(vals)) for _, vals in axes]):
        overrides = tuple(f"{key}={lit}" for (key, _), (_, (lit, _v)) in zip(axes, combo))
        values = {key: v for (key, _), (_, (_lit, v)) in zip(axes, combo)}
        name = "__".join(f"{key}=" + _UNSAFE.sub("_", lit.replace('"', "").replace("'", "")).strip("_")
                         for (key, _), (_, (lit, _v)) in zip(axes, combo))
        points.append(Point(name, tuple(i for i, _ in combo), overrides, values))
    counts = collections.Counter(p.name.lower() for p in points)
    out = []
    for p in points:
        if counts[p.name.lower()] > 1 or len(p.name) > 150 or _HASHED.search(p.name):
            h = hashlib.sha256("\n".join(p.overrides).encode()).hexdigest()[:8]
            p = Point(f"{p.name[:150]}-{h}", p.index, p.overrides, p.values)
        out.append(p)
    clash = [n for n, c in collections.Counter(p.name.lower() for p in out).items() if c > 1]
    if clash:
        raise UsageError(f"--grid: two points would be built in one folder points/{clash[0]}; change a value")
    return out

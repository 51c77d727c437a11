"""Typed records as JSON data and back: :class:`Record` (``to_json``/``from_json``), :func:`plain` and :func:`read`,
shared by the verification's results (:mod:`.results`), comparisons (:mod:`.compare`) and boundary shapes
(:mod:`.boundary`), which import this module and not one another's."""

from __future__ import annotations

import dataclasses
import functools
import sys
import types
import typing
from typing import Any


def plain(value: Any) -> Any:
    """``value`` as JSON data: typed results by their ``to_json``, other dataclasses as dicts, tuples as lists."""
    if hasattr(value, "to_json"):
        return value.to_json()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    return value


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    """``cls``'s field types; a name its module imports only when type checking comes from its ``type_names()``
    (asked only then: they import numpy, which a verdict read back needs not)."""
    try:
        return typing.get_type_hints(cls)
    except NameError:
        return typing.get_type_hints(cls, localns=getattr(sys.modules[cls.__module__], "type_names", dict)())


def read(tp: Any, value: Any) -> Any:
    """JSON ``value`` as the type ``tp``: a dataclass field by field (by its own ``from_json`` where it has one; a
    field absent takes its default), tuples, lists, dicts and optionals of them; anything else as it is."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if value is None:
        return None
    if origin in (typing.Union, types.UnionType):
        return read(next(a for a in args if a is not type(None)), value)
    if origin in (tuple, list):
        return origin(read(args[0], v) for v in value)
    if origin is dict:
        return {k: read(args[1], v) for k, v in value.items()}
    if getattr(tp, "from_json", None) is not None:
        return tp.from_json(value)
    return _fields(tp, value) if dataclasses.is_dataclass(tp) else value


def _fields(cls: Any, data: dict) -> Any:
    hints = _hints(cls)
    return cls(**{f.name: read(hints[f.name], data[f.name]) for f in dataclasses.fields(cls) if f.name in data})


class Record:
    """``to_json``: every field but those in ``_PRIVATE``, as JSON data; ``from_json`` reads it back."""

    _PRIVATE: tuple[str, ...] = ()

    def to_json(self) -> dict:
        return {f.name: plain(getattr(self, f.name)) for f in dataclasses.fields(self)  # type: ignore[arg-type]
                if f.name not in self._PRIVATE}

    @classmethod
    def from_json(cls, data: dict) -> typing.Self:
        return _fields(cls, data)

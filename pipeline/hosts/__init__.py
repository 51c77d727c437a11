"""Hosts: adapters at the edge that read the WRITTEN asset and render it with code the project did not write
where possible (BRIEF "The hosts interface"). Minimal registry for the web host; the full registry and
``rockdove verify --hosts`` are written in parallel (issue 9) and replace this file on merge.

A host module defines ``NAME``, ``VARIANT`` (``"glsl"``, ``"baked"`` or ``"physical"``), ``LOBE``
(``"half_angle"`` or ``"view_angle"``), ``unavailable() -> str | None`` and
``render(asset_path, views, out_dir) -> {view.name: (H, W, 3) float32 linear Rec.709}``.
"""

from __future__ import annotations

import importlib
from types import ModuleType

#: host name -> module, imported lazily.
REGISTRY = {
    "glsl": "pipeline.hosts.glsl",
    "materialx": "pipeline.hosts.materialx",
    "blender": "pipeline.hosts.blender",
    "web": "pipeline.hosts.web",
}


class HostError(RuntimeError):
    """A host failed (its browser did not start, a step timed out, a shader did not compile...)."""

    def __init__(self, host: str, message: str):
        super().__init__(f"host {host!r}: {message}")
        self.host = host
        self.message = message


def load(name: str) -> ModuleType:
    """The module of host ``name`` (ValueError naming the allowed hosts when unknown)."""
    if name not in REGISTRY:
        raise ValueError(f"host {name!r} is unknown; allowed: {', '.join(REGISTRY)}")
    return importlib.import_module(REGISTRY[name])

"""Hosts: adapters at the edge that read the WRITTEN asset and render it with their own code.

Minimal registry (BRIEF "hosts interface"); the full one (``select``, reasons, ``glsl``...) comes with the
MaterialX hosts. A host module defines ``NAME``, ``VARIANT``, ``LOBE``, ``unavailable() -> str | None`` and
``render(asset_path, views, out_dir) -> {view.name: (H, W, 3) float32 linear Rec.709}``, and raises
:class:`HostError` when it fails.
"""

from __future__ import annotations

#: host name -> module (imported only when the host is asked for).
REGISTRY = {
    "glsl": "pipeline.hosts.glsl",
    "materialx": "pipeline.hosts.materialx",
    "blender": "pipeline.hosts.blender",
    "web": "pipeline.hosts.web",
}


class HostError(Exception):
    """A host failed to render (no display, import error, shader compile error...).

    Parameters
    ----------
    host : str
        The host's registry name.
    message : str
        What went wrong, one line.
    """

    def __init__(self, host: str, message: str):
        super().__init__(f"host {host!r}: {message}")
        self.host = self.name = host
        self.message = message

"""The ``materialx_physical`` host: the asset's ``physical`` shading variant (OpenPBR's own thin film) through
MaterialX's GLSL generator, drawn as :mod:`rockdove.hosts.materialx` draws the baked network (same EGL host,
same ``view_angle`` lobe: uniform white environment of unit radiance, base colour black).

OpenPBR's GLSL thin film is an approximation (Gaussian fits of the colour-matching functions, a few Airy
terms, a known white-point bug): this host is checked for green and purple and for hue-class agreement with
the exact reference, and its dE is reported, not held to the baked network's dE goal.
"""

from __future__ import annotations

from . import materialx

NAME = "materialx_physical"
VARIANT = "physical"
LOBE = "view_angle"


def unavailable() -> str | None:
    """As :func:`rockdove.hosts.materialx.unavailable`."""
    return materialx.unavailable()


def cannot_draw(asset_path: str) -> str | None:
    """Why this host cannot draw this asset (no ``physical`` shading variant), else None."""
    return materialx.cannot_draw(asset_path, VARIANT)


def render(asset_path: str, views, out_dir: str) -> dict:
    """Render ``views`` of the asset's ``physical`` MaterialX network (raises HostError when the asset has none)."""
    return materialx.render_variant(asset_path, views, out_dir, variant=VARIANT, name=NAME)

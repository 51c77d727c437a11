"""What a verification report records about what it verified: the asset's hash and configuration, the library
versions, and the asset validator's verdict (:func:`rockdove.usd.validate.validate_asset`)."""

from __future__ import annotations

import json
import os
import platform
import time
from functools import lru_cache

from ..usd.layout import MARKER
from .results import Validation

LIBRARIES = ("numpy", "scipy", "colour", "trimesh", "embreex", "pxr", "pyrender", "OpenGL", "PIL",
             "matplotlib", "OpenEXR", "MaterialX")


def library_versions() -> dict:
    """Versions of Python, rockdove and the verification's libraries (None when not installed), a new dict; read once
    per process (~12 directory scans of ``sys.path``)."""
    return dict(_library_versions())


@lru_cache(maxsize=1)
def _library_versions() -> dict:
    from importlib import metadata

    from .. import __version__

    dist = {"colour": "colour-science", "PIL": "pillow", "pxr": "usd-core", "OpenGL": "PyOpenGL"}
    out = {"python": platform.python_version(), "rockdove": __version__}
    for name in LIBRARIES:
        try:
            out[name] = metadata.version(dist.get(name, name))
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def asset_configuration(layer_path: str) -> dict:
    """What the asset records about the configuration it was built from: the build marker beside the root layer and
    any ``customLayerData`` or default-prim ``assetInfo`` key containing "config" (empty for a bare assembly)."""
    from pxr import Sdf

    found = {}
    marker = os.path.join(os.path.dirname(os.path.abspath(layer_path)), MARKER)
    if os.path.isfile(marker):
        try:
            with open(marker, encoding="utf-8") as f:
                found["marker"] = json.load(f)
        except (OSError, ValueError) as exc:
            found["marker_error"] = f"{marker}: {exc}"
    layer = Sdf.Layer.FindOrOpen(layer_path)
    if layer is None:
        return found
    prim = layer.GetPrimAtPath(f"/{layer.defaultPrim}") if layer.defaultPrim else None
    for where, d in (("customLayerData", layer.customLayerData), ("assetInfo", prim.assetInfo if prim else None)):
        found.update({f"{where}:{k}": v for k, v in dict(d or {}).items() if "config" in k.lower()})
    return json.loads(json.dumps(found, default=str))


def run_validation(layer_path: str) -> tuple[Validation, float]:
    """Run the asset validator: ``(Validation, seconds)``."""
    from ..usd.validate import validate_asset

    t = time.perf_counter()
    try:
        result = validate_asset(layer_path)
    except Exception as exc:  # noqa: BLE001 - a validator that raises is a failure, never a pass
        return Validation(False, None, f"validation raised: {type(exc).__name__}: {exc}"), time.perf_counter() - t
    details = json.loads(json.dumps(result.to_dict(), default=str))
    return Validation(result.clean, details, None), time.perf_counter() - t

"""The asset folder's layout (docs/design.md, "USD asset"): its file names, and :func:`resolve_root_layer`, the one
resolver every reader uses, so they accept the same paths and fail with the same one-line error."""

from __future__ import annotations

import os

from ..errors import UsageError

#: The file a published build leaves in the asset folder (:mod:`rockdove.graph.publish` writes it): tool,
#: version, configuration hash, preset, stage keys. A folder without it was not made by rockdove.
MARKER = ".rockdove-asset.json"
#: Root-layer names looked for in an asset folder, in this order (the build writes the first and the usdz).
ROOT_LAYER_NAMES = ("pigeon.usda", "pigeon.usdc", "pigeon.usd", "pigeon.usdz")
#: Extensions of a USD layer given by its path.
USD_EXTENSIONS = (".usda", ".usdc", ".usd", ".usdz")


_BACKSLASH = "\\"


def unusable_path(path: str) -> str | None:
    """Why USD cannot use ``path`` for an asset (a control character; a backslash, which USD, and Blender, read as
    a folder separator, so the layers beside the root would be looked for elsewhere), else None."""
    bad = sorted({c for c in path if ord(c) < 32 or ord(c) == 127 or c == _BACKSLASH})
    if not bad:
        return None
    what = "a backslash, which USD reads as a folder separator" if bad == [_BACKSLASH] else "a control character"
    return f"holds {what} ({', '.join(map(repr, bad))}); rename the folder or choose another path"


def resolve_root_layer(asset) -> str:
    """The absolute path of an asset's root layer, given its folder or a layer; else a one-line ValueError."""
    path = os.path.abspath(os.fspath(asset))
    if why := unusable_path(path):
        raise UsageError(f"asset={os.fspath(asset)!r} {why}")
    if os.path.isdir(path):
        for name in ROOT_LAYER_NAMES:
            cand = os.path.join(path, name)
            if os.path.isfile(cand):
                return cand
        raise UsageError(f"asset={os.fspath(asset)!r} is a folder without {' or '.join(ROOT_LAYER_NAMES)}")
    if not os.path.isfile(path):
        raise UsageError(f"asset={os.fspath(asset)!r} does not exist; give the asset folder or its root layer")
    if not path.endswith(USD_EXTENSIONS):
        raise UsageError(f"asset={os.fspath(asset)!r} is not a USD layer ({', '.join(USD_EXTENSIONS)})")
    return path

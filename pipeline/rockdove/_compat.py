"""Work-arounds for third-party packages, applied where those packages are imported (never at import of
``rockdove``)."""

from __future__ import annotations

import os


def import_pyrender():
    """pyrender, on EGL unless ``PYOPENGL_PLATFORM`` is set (before OpenGL is imported: its pinned PyOpenGL 3.1.0
    fails with osmesa), with ``np.infty`` (removed in numpy 2) that 0.1.45 uses."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    import numpy as np

    if not hasattr(np, "infty"):
        np.infty = np.inf
    import pyrender

    return pyrender


def import_colour():
    """colour-science without its plotting sub-package: 0.4.7 imports it unconditionally, and with it matplotlib
    (~0.35 s of its ~1 s import, ``python -X importtime``). A placeholder stands in while ``colour`` is first
    imported and is removed after, so ``import colour.plotting`` still gets the real one."""
    import sys
    import types

    if "colour" in sys.modules or "colour.plotting" in sys.modules:
        import colour

        return colour
    placeholder = types.ModuleType("colour.plotting", "placeholder while colour is imported (rockdove._compat)")
    sys.modules["colour.plotting"] = placeholder
    try:
        import colour
    finally:
        if sys.modules.get("colour.plotting") is placeholder:
            del sys.modules["colour.plotting"]
        parent = sys.modules.get("colour")
        if parent is not None and parent.__dict__.get("plotting") is placeholder:
            del parent.__dict__["plotting"]
    return colour

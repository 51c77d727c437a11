"""Work-arounds for third-party packages, applied where those packages are imported (never at import of
``rockdove``)."""

from __future__ import annotations

import os


def import_pyrender():
    """Import pyrender for offscreen rendering and return the module.

    - Selects EGL (Mesa llvmpipe works headless; pyrender 0.1.45 pins PyOpenGL 3.1.0, which fails with
      osmesa) unless ``PYOPENGL_PLATFORM`` is already set. This must happen before OpenGL is imported.
    - pyrender 0.1.45 uses ``np.infty``, removed in numpy 2.
    """
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    import numpy as np

    if not hasattr(np, "infty"):
        np.infty = np.inf
    import pyrender

    return pyrender


def import_colour():
    """Import colour-science without its plotting sub-package and return the module.

    colour-science 0.4.7's ``colour/__init__.py`` runs ``from colour import plotting`` unconditionally, which
    imports matplotlib and pyplot (~0.35 s of its ~1 s import, measured with ``python -X importtime``) although
    nothing on the build's path plots with it. While ``colour`` is first imported, ``colour.plotting`` is a
    placeholder module; afterwards the placeholder is removed again, so ``import colour.plotting`` (or
    ``from colour import plotting``) still imports the real one when something asks for it.
    """
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

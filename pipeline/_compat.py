"""Work-arounds for third-party packages, applied where those packages are imported (never at import of
``pipeline``)."""

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

"""Shared test set-up. Offscreen GL (EGL) is chosen before anything imports OpenGL."""

import os
import sys

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

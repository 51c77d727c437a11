"""Shared test set-up. Offscreen GL (EGL) is chosen before anything imports OpenGL.

The tests import ``pipeline`` as installed in the venv (``make test`` installs it editable); nothing here puts
the checkout on ``sys.path``, and command-line tests run the installed ``rockdove`` from a folder outside the
checkout (:data:`OUTSIDE`), so a file missing from the package fails them.
"""

import os
import tempfile

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
# Where make installs bpy (a venv of its own: it pins numpy < 2); `make test` exports the same setting.
_BPY = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), ".venv-bpy", "bin", "python")
if os.path.exists(_BPY):
    os.environ.setdefault("ROCKDOVE_BPY_PYTHON", _BPY)

#: A working directory outside the checkout for subprocesses (``python -m`` puts its cwd on sys.path).
OUTSIDE = tempfile.gettempdir()

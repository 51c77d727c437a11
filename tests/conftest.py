"""Shared test set-up. Offscreen GL (EGL) is chosen before anything imports OpenGL.

The tests import ``pipeline`` as installed in the venv (``make test`` installs it editable); nothing here puts
the checkout on ``sys.path``, and command-line tests run the installed ``rockdove`` from a folder outside the
checkout (:data:`OUTSIDE`), so a file missing from the package fails them.
"""

import os
import tempfile

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

#: A working directory outside the checkout for subprocesses (``python -m`` puts its cwd on sys.path).
OUTSIDE = tempfile.gettempdir()

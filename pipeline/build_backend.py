"""The build backend (pyproject.toml ``backend-path``): setuptools' own, without one notice.

The data folders ship as sub-packages mapped from the repository's top (``materials/`` as ``rockdove.materials``),
so an editable install cannot be a plain ``.pth`` and setuptools installs a meta path finder, after which it
always emits an ``InformationOnly`` warning (pip shows it boxed on every ``pip install -e .``): folders named like
the package in the working directory may take precedence. It is a notice, not a fault of this project (no
``rockdove/`` folder sits at the top of the checkout), and setuptools has no setting for it, so it is filtered
here by its text; every other warning, and every other notice, is shown.
"""

import warnings

from setuptools.build_meta import *  # noqa: F403 (a PEP 517 backend: setuptools' hooks, re-exported)
from setuptools.warnings import InformationOnly

# matched anywhere in the text: newer setuptools wraps it in a banner
warnings.filterwarnings("ignore", message=r"(?s).*Please be careful with folders in your working directory",
                        category=InformationOnly)

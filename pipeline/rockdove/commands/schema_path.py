"""``rockdove schema-path``: print the folder of the ``RockDoveThinFilmAPI`` USD plugin (its ``plugInfo.json``).

USD tools (usdview, usdchecker, Houdini, Omniverse) find codeless schemas through ``PXR_PLUGINPATH_NAME``::

    export PXR_PLUGINPATH_NAME=$(rockdove schema-path)${PXR_PLUGINPATH_NAME:+:$PXR_PLUGINPATH_NAME}

The folder is inside the installed package (:mod:`rockdove.resources`), so this works for a wheel install
as well as a checkout.
"""

from __future__ import annotations

import argparse

HELP = "print the folder holding the USD schema plugin, for PXR_PLUGINPATH_NAME"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = "usage in a shell: export PXR_PLUGINPATH_NAME=$(rockdove schema-path)"


def run(args: argparse.Namespace) -> int:
    from rockdove import resources

    print(resources.path("schemas/plugInfo.json").parent)
    return 0

"""``rockdove schema-path``: the folder of the ``RockDoveThinFilmAPI`` USD plugin (``plugInfo.json``), for USD
tools that find codeless schemas through ``PXR_PLUGINPATH_NAME``."""

from __future__ import annotations

import argparse

from rockdove import resources


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = "usage in a shell: export PXR_PLUGINPATH_NAME=$(rockdove schema-path)"


def run(args: argparse.Namespace) -> int:
    print(resources.path("schemas/plugInfo.json").parent)
    return 0

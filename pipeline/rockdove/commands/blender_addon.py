"""``rockdove blender-addon --out DIR``: write the Blender add-on ``DIR/rockdove_blender.zip`` (Blender 4.2 or
later: Edit > Preferences > Add-ons > Install from Disk, or the two ``bpy.ops`` calls it prints), with which a USD
import of the asset gives the neck feathers Cycles' physical thin film (``materials/blender/rockdove_blender``)."""

from __future__ import annotations

import argparse
import os


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", required=True, metavar="DIR", help="folder to write rockdove_blender.zip into")


def run(args: argparse.Namespace) -> int:
    from rockdove.graph.publish import check_output_file, starts_like
    from rockdove.hosts.blender import ADDON_MODULE, ADDON_ZIP, addon_zip

    check_output_file(os.path.join(args.out, ADDON_ZIP), starts_like(b"PK", b"rockdove_blender/"))
    path = addon_zip(args.out)
    print(path)
    print(f'install: bpy.ops.preferences.addon_install(filepath="{path}"); '
          f'bpy.ops.preferences.addon_enable(module="{ADDON_MODULE}")')
    return 0

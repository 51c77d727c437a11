"""``rockdove config``: the configuration a build with the same options would use, with the schema's units and
ranges (or as JSON); ``--paths`` the folders rockdove uses outside an asset."""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
from typing import NamedTuple

from .. import resources, sources
from ..config import config_hash, describe, load_config
from .build import add_config_arguments


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_arguments(parser)
    parser.add_argument("--json", action="store_true",
                        help="print JSON: the configuration, its hash and each key's unit/default/allowed range")
    parser.add_argument("--verbose", "-v", action="store_true", help="also print each key's description and range")
    parser.add_argument("--paths", action="store_true",
                        help="print the folders rockdove reads and writes outside an asset (the user cache and what "
                             "each part of it holds, marking the stale ones; the package's data)")
    parser.add_argument("--prune", action="store_true",
                        help="remove the user-cache folders --paths marks stale (what derived them has changed)")


def _fmt(value) -> str:
    return "unset (model's value)" if value is None else json.dumps(value)


#: User-cache folder name prefix -> what it holds.
HOLDS = {"colour-science-": "colour-science's CIE tables and RGB matrices, the quadrature's weights "
                            "(rockdove.spectral.colour_data)",
         "usd-validation-nvidia-": "NVIDIA's mesh-rule findings (rockdove.usd.nvidia)",
         "code": "the parsed imports of the package's files (rockdove.sources)",
         "verify": "renders of assets verified without a build cache beside them (rockdove.verify.verification)"}
#: folders whose entries are each keyed by what they read (stage-cache items), never stale as a whole
KEYED_INSIDE = ("verify",)


class PathRow(NamedTuple):
    """A folder rockdove uses outside an asset; a user-cache ``folder`` also says why it is ``stale`` (or a false
    value: current, keyed inside, not rockdove's) and whether --prune ``removed`` it."""

    what: str
    path: str
    keyed_by: str
    folder: bool = False
    stale: str | bool | None = None
    removed: bool = False

    def to_json(self) -> dict:
        out = {"what": self.what, "path": self.path, "keyed_by": self.keyed_by}
        return {**out, "stale": self.stale, **({"removed": True} if self.removed else {})} if self.folder else out


def paths() -> list[PathRow]:
    """Every folder rockdove uses outside an asset, stale as :func:`rockdove.sources.stale` finds it."""
    user = resources.user_cache_dir()
    rows = [PathRow("user cache ($XDG_CACHE_HOME/rockdove; safe to delete)", str(user),
                    f"what derives each folder: code, installed distributions, Python ({sources.KEY_FILE})")]
    for folder in sorted(user.iterdir()) if user.is_dir() else []:
        what = next((w for prefix, w in HOLDS.items() if folder.name.startswith(prefix)), None)
        rows.append(PathRow(what or "(not rockdove's)", str(folder), sources.KEY_FILE, True,
                            what and folder.name not in KEYED_INSIDE and sources.stale(folder)))
    return [*rows, PathRow("package data (read only)", str(resources.package_root()), ""),
            PathRow("stage cache of a build", ".rockdove-cache beside --out, or --cache", "stage key")]


def run(args: argparse.Namespace) -> int:
    if args.paths or args.prune:
        folders = paths()
        for i, row in enumerate(folders):
            if args.prune and row.stale:
                shutil.rmtree(row.path, ignore_errors=True)
                folders[i] = row._replace(removed=True)
        if args.json:
            print(json.dumps([row.to_json() for row in folders], indent=1))
            return 0
        for row in folders:
            if row.folder:
                stale = f"  STALE: {row.stale}" + ("; removed" if row.removed else "") if row.stale else ""
                print(f"  {row.what}: {row.path}{stale}")
            else:
                print(f"{row.what}: {row.path}" + (f"  (keyed by {row.keyed_by})" if row.keyed_by else ""))
        return 0
    config = load_config(preset=args.preset, config_file=args.config, overrides=args.overrides)
    rows = describe(config)
    if args.json:
        print(json.dumps({"preset": args.preset, "config_hash": config_hash(config), "config": config,
                          "parameters": [dataclasses.asdict(r) for r in rows]}, indent=1))
        return 0
    print(f"# rockdove configuration: preset {args.preset}"
          + (f" + {args.config}" if args.config else "")
          + (f" + {len(args.overrides)} --set" if args.overrides else "")
          + f"; hash {config_hash(config)[:16]}")
    width = max(len(r.key) for r in rows)
    section = None
    for r in rows:
        head = r.key.split(".")[0]
        if head != section and "." in r.key:
            print(f"\n[{head}]")
        section = head
        unit = f" {r.unit}" if r.unit else ""
        changed = "" if r.value == r.default else f"   (default {_fmt(r.default)})"
        print(f"{r.key:<{width}} = {_fmt(r.value)}{unit}{changed}")
        if args.verbose:
            print(f"{'':<{width}}   {r.description} Allowed: {r.allowed}.")
    return 0

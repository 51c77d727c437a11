"""``rockdove config``: print the effective build configuration with units (or as JSON).

Takes the same ``--preset``, ``--config`` and ``--set`` options as ``rockdove build``, so a user sees exactly
what a build would use; the units, ranges and descriptions come from ``schemas/config.schema.json``.
"""

from __future__ import annotations

import argparse
import json

from ..config import config_hash, describe, load_config
from .build import add_config_arguments



def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_arguments(parser)
    parser.add_argument("--json", action="store_true",
                        help="print JSON: the configuration, its hash and each key's unit/default/allowed range")
    parser.add_argument("--verbose", "-v", action="store_true", help="also print each key's description and range")
    parser.add_argument("--paths", action="store_true",
                        help="print the folders rockdove reads and writes outside an asset (the user cache and what "
                             "each part of it holds, the package's data) instead of the configuration")


def _fmt(value) -> str:
    return "unset (model's value)" if value is None else json.dumps(value)


def paths() -> list[tuple[str, str, str]]:
    """(what, folder, keyed by) of every folder rockdove uses outside an asset and its stage cache."""
    from .. import resources
    from ..graph.code import SCANNER_VERSION

    user = resources.user_cache_dir()
    rows = [("user cache ($XDG_CACHE_HOME/rockdove; safe to delete)", str(user), "")]
    described = {"colour-science-": "colour-science's CIE tables and RGB matrices (rockdove.spectral)",
                 "quadrature": "the product quadrature's integration weights (rockdove.lut.quadrature)",
                 "usd-validation-nvidia-": "NVIDIA's mesh-rule findings (rockdove.usd.nvidia)",
                 "code": "the build graph's parsed imports (rockdove.graph.code)"}
    found = sorted(p.name for p in user.iterdir()) if user.is_dir() else []
    for name in found:
        what = next((w for prefix, w in described.items() if name.startswith(prefix)), "(not rockdove's)")
        rows.append((f"  {what}", str(user / name), "library version and code" if name != "code" else
                     f"file content (scanner v{SCANNER_VERSION})"))
    rows.append(("package data (read only)", str(resources.package_root()), ""))
    rows.append(("stage cache of a build", ".rockdove-cache beside --out, or --cache", "stage key"))
    return rows


def run(args: argparse.Namespace) -> int:
    if args.paths:
        rows = paths()
        if args.json:
            print(json.dumps([{"what": w.strip(), "path": p, "keyed_by": k} for w, p, k in rows], indent=1))
        else:
            for what, path, keyed in rows:
                print(f"{what}: {path}" + (f"  (keyed by {keyed})" if keyed else ""))
        return 0
    config = load_config(preset=args.preset, config_file=args.config, overrides=args.overrides)
    rows = describe(config)
    if args.json:
        print(json.dumps({"preset": args.preset, "config_hash": config_hash(config), "config": config,
                          "parameters": rows}, indent=1))
        return 0
    print(f"# rockdove configuration: preset {args.preset}"
          + (f" + {args.config}" if args.config else "")
          + (f" + {len(args.overrides)} --set" if args.overrides else "")
          + f"; hash {config_hash(config)[:16]}")
    width = max(len(r["key"]) for r in rows)
    section = None
    for r in rows:
        head = r["key"].split(".")[0]
        if head != section and "." in r["key"]:
            print(f"\n[{head}]")
        section = head
        unit = f" {r['unit']}" if r["unit"] else ""
        changed = "" if r["value"] == r["default"] else f"   (default {_fmt(r['default'])})"
        print(f"{r['key']:<{width}} = {_fmt(r['value'])}{unit}{changed}")
        if args.verbose:
            print(f"{'':<{width}}   {r['description']} Allowed: {r['allowed']}.")
    return 0

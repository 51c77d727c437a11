"""``rockdove validate PATH``: validate a USD asset (:mod:`rockdove.usd.validate`), a folder's ``pigeon.usda`` and
``pigeon.usdz``, or one layer or ``.usdz``; exit status 1 when not clean."""

from __future__ import annotations

import argparse
import json
import os


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("path", help="asset folder (pigeon.usda and pigeon.usdz), a root layer, or a .usdz")
    parser.add_argument("--json", action="store_true", help="print the report(s) as JSON on stdout")
    add_external_argument(parser)


def add_external_argument(parser: argparse.ArgumentParser) -> None:
    """``--allow-external-assets`` (shared with ``rockdove verify``)."""
    parser.add_argument("--allow-external-assets", action="store_true",
                        help="read files the asset names by absolute paths or outside its folder (by default "
                             "they are reported as errors and never read)")


def targets(path: str) -> list[str]:
    """The layers to validate for ``path``: a folder gives its root layer and, if present, its usdz."""
    from rockdove.usd.layout import resolve_root_layer
    from rockdove.usd.usdz import USDZ_NAME

    root, usdz = resolve_root_layer(path), os.path.join(path, USDZ_NAME)
    both = os.path.isdir(path) and os.path.isfile(usdz) and os.path.abspath(usdz) != os.path.abspath(root)
    return [root, usdz] if both else [root]


def run(args: argparse.Namespace) -> int:
    from rockdove.errors import UsageError, VerificationFailed
    from rockdove.usd.validate import validate_asset

    try:
        paths = targets(args.path)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    reports = [validate_asset(p, allow_external=args.allow_external_assets) for p in paths]
    if args.json:
        print(json.dumps({"clean": all(r.clean for r in reports), "reports": [r.to_dict() for r in reports]},
                         indent=2, sort_keys=True))
    else:
        print("\n".join(r.format() for r in reports))
    failed = [r for r in reports if not r.clean]
    if failed:
        raise VerificationFailed("; ".join(f"{len(r.errors)} error(s) in {r.path}" for r in failed))
    return 0

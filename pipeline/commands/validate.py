"""``rockdove validate PATH [--json]``: validate a USD asset (see :mod:`pipeline.usd.validate`).

Exit status: 0 clean, 1 not clean (:class:`pipeline.errors.VerificationFailed`), 2 bad usage (missing path,
not a USD layer).
"""

from __future__ import annotations

import argparse
import json
import sys

HELP = "validate a USD asset (UsdValidation + MaterialX node definitions + textures)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("path", help="asset folder (containing pigeon.usda), a root layer, or a .usdz")
    parser.add_argument("--json", action="store_true", help="print the report as JSON on stdout")


def run(args: argparse.Namespace) -> int:
    from pipeline.errors import UsageError, VerificationFailed
    from pipeline.usd.validate import resolve_root_layer, validate_asset

    try:
        resolve_root_layer(args.path)
    except (FileNotFoundError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    report = validate_asset(args.path)
    if args.json:
        json.dump(report.to_dict(), sys.stdout, indent=2, sort_keys=True)
        sys.stdout.write("\n")
    else:
        print(report.format())
    if not report.clean:
        raise VerificationFailed(f"{len(report.errors)} error(s) in {report.path}")
    return 0

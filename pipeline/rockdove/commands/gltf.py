"""``rockdove gltf ASSET``: export a written asset to glTF 2.0 (:func:`rockdove.web.gltf.export_glb`), optionally
checked by the Khronos glTF-Validator (exit status 1 when it reports errors)."""

from __future__ import annotations

import argparse
import json
import os

from ..errors import UsageError, VerificationFailed
from .validate import add_external_argument


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("asset", metavar="ASSET", help="the asset folder or its root layer (pigeon.usda)")
    parser.add_argument("--out", metavar="F.glb", default=None, help="output file (default: pigeon.glb beside the "
                        "root layer)")
    parser.add_argument("--validate", action="store_true",
                        help="run the Khronos glTF-Validator (npm gltf-validator, needs node) on the result")
    parser.add_argument("--json", action="store_true", help="print the export (and validation) summary as JSON")
    add_external_argument(parser)


def run(args: argparse.Namespace) -> int:
    from .. import __version__
    from ..graph.publish import check_output_file
    from ..usd.dependencies import require_inside
    from ..web.gltf import GLB_NAME, export_glb, validate_glb

    layer = require_inside(args.asset, args.allow_external_assets)
    out = args.out or os.path.join(os.path.dirname(layer), GLB_NAME)
    if not out.endswith(".glb"):
        raise UsageError(f"--out must name a .glb file, got {out!r}")
    check_output_file(out, _ours)
    export = export_glb(layer, out, version=__version__)
    try:
        v = validate_glb(out) if args.validate else None
    except RuntimeError as exc:
        raise UsageError(str(exc)) from None
    if args.json:  # the validator's first 20 messages as it wrote them
        print(json.dumps({**export._asdict(), **({} if v is None else {"validation": {
            "numErrors": v.errors, "numWarnings": v.warnings, "numInfos": v.infos, "numHints": v.hints,
            "messages": v.messages[:20]}})}, indent=2))
    else:
        lo, hi = export.thickness_range_nm
        print(f"wrote {export.path} ({export.bytes} bytes): iridescenceIor {export.iridescence_ior:.4f} at "
              f"{export.ior_wavelength_nm:g} nm, thickness {lo:g}-{hi:g} nm, substrate ior {export.substrate_ior:g}")
        if v is not None:
            print(f"glTF-Validator: {v.errors} errors, {v.warnings} warnings, {v.infos} infos, {v.hints} hints")
            for m in v.messages[:20]:  # the validator's own entries
                print(f"  {m['code']}: {m['message']} ({m.get('pointer', '')})")
    if v is not None and v.errors:
        raise VerificationFailed(f"glTF-Validator found {v.errors} errors in {out}")
    return 0


def _ours(path) -> bool:
    """Whether ``path`` is a .glb rockdove wrote: its JSON chunk's ``asset.generator`` starts with ``rockdove``."""
    import struct

    with open(path, "rb") as fh:
        head = fh.read(20)
        if len(head) < 20 or head[:4] != b"glTF":
            return False
        doc = fh.read(min(struct.unpack_from("<I", head, 12)[0], 1 << 26))
    try:
        return str(json.loads(doc).get("asset", {}).get("generator", "")).startswith("rockdove")
    except (ValueError, AttributeError):
        return False

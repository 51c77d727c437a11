"""``rockdove lut``: bake a thin-film colour LUT into OpenEXR with an sRGB PNG preview, both written atomically."""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

from ..errors import UsageError
from ..lut import BAKE_METHODS, bake, lut_error, write_exr, write_preview_png
from ..lut.bake import DEFAULT_ANGLE_WARP_GAMMA, DEFAULT_ANGLES, DEFAULT_THICKNESS_RANGE_NM, DEFAULT_THICKNESSES
from ..resources import atomic_path

DEFAULT_ERROR_POINTS = 1000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", required=True, metavar="PATH.exr", help="output EXR file (preview: PATH.png)")
    parser.add_argument("--angles", type=int, default=DEFAULT_ANGLES, metavar="N", help="angle texels (2 .. 4096)")
    parser.add_argument("--thicknesses", type=int, default=DEFAULT_THICKNESSES, metavar="M",
                        help="thickness texels (1 .. 4096; 1 gives the paper's one-texel-high LUT)")
    parser.add_argument("--thickness-range", type=float, nargs=2, default=DEFAULT_THICKNESS_RANGE_NM,
                        metavar=("LO", "HI"), help="film thickness range in nm (LO == HI: one texel high)")
    parser.add_argument("--film", default="paper", help="film model: paper (n = 1.5) or keratin (dispersive)")
    parser.add_argument("--method", default="auto", help=f"bake method: {', '.join(BAKE_METHODS)}")
    parser.add_argument("--angle-gamma", type=float, default=DEFAULT_ANGLE_WARP_GAMMA, metavar="G",
                        help="angle axis warp: cos_theta = x**G (> 1 puts texels near grazing)")
    parser.add_argument("--colour-space", default="lin_rec709", help="working colour space: lin_rec709 or acescg")
    parser.add_argument("--error-points", type=int, default=DEFAULT_ERROR_POINTS, metavar="K",
                        help="random points at which the LUT is checked against the exact reference (0: skip)")


def run(args: argparse.Namespace) -> int:
    from ..graph.publish import check_output_file, starts_like

    if not args.out.lower().endswith(".exr"):
        raise UsageError(f"--out must name a .exr file, got {args.out!r}")
    if os.path.isdir(args.out):
        raise UsageError(f"--out is a directory, expected a .exr file path: {args.out!r}")
    out = os.path.abspath(args.out)

    ours = starts_like(b"\x76\x2f\x31\x01", b"rockdove:format")  # an EXR rockdove wrote: never the user's files
    check_output_file(out, ours)
    check_output_file(os.path.splitext(out)[0] + ".png", lambda p: os.path.isfile(out) and ours(out))
    if args.error_points < 0:
        raise UsageError(f"--error-points must be >= 0, got {args.error_points}")
    t0 = time.perf_counter()
    try:
        lut = bake(angles=args.angles, thicknesses=args.thicknesses, thickness_range=tuple(args.thickness_range),
                   film=args.film, method=args.method, angle_warp_gamma=args.angle_gamma,
                   colour_space=args.colour_space)
    except ValueError as exc:  # name the command-line option, not only the library argument
        name = str(exc).split(" ", 1)[0]
        if name in ("angles", "thicknesses", "thickness_range", "film", "method", "angle_warp_gamma", "colour_space"):
            option = "angle-gamma" if name == "angle_warp_gamma" else name.replace("_", "-")
            raise UsageError(f"--{option}: {exc}") from None
        raise
    bake_s = time.perf_counter() - t0
    if args.error_points:
        from ..lut.bake import error_metadata

        err = lut_error(lut, args.film, n_points=args.error_points, seed=0)
        lut = dataclasses.replace(lut, metadata={**lut.metadata, **error_metadata(err)})
    os.makedirs(os.path.dirname(out), exist_ok=True)
    png = os.path.splitext(out)[0] + ".png"
    for path, write in ((out, write_exr), (png, write_preview_png)):  # each written beside, then swapped in
        with atomic_path(path) as tmp:
            write(lut, tmp)
    md = lut.metadata
    print(out)
    print(f"  {lut.n_thickness} x {lut.n_angle} texels ({lut.n_thickness * lut.n_angle}), film {md['film']}, "
          f"method {md['method']}, baked in {bake_s:.3f} s (incl. one-time colour tables of this process)")
    if args.error_points:
        print(f"  estimated error vs the exact reference: max dE2000 {md['estimatedMaxDeltaE2000']}, "
              f"p99 {md['estimatedP99DeltaE2000']} ({md['estimatedErrorSample']})")
    else:
        print("  estimated error: not measured (--error-points 0)")
    print(f"  preview {png}")
    return 0

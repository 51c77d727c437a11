"""``rockdove verify ASSET``: :func:`rockdove.api.verify` (the build's verification with its cache: what a build or
an earlier verification checked is not rendered again) and its results as text or ``--json``. Exit status 0 when
everything passes, 1 when a check fails, 2 on bad usage."""

from __future__ import annotations

import argparse
import json
import os

from .validate import add_external_argument


def _ranged(key: str, unit: str):
    """An argparse type: an integer within the schema's range of config ``key`` (its one source)."""
    def parse(text: str) -> int:
        from ..config import limits

        lo, hi = limits(key)
        if not text.strip().lstrip("-").isdigit() or not lo <= int(text) <= hi:
            raise argparse.ArgumentTypeError(f"must be an integer from {lo} to {hi} {unit}, got {text!r}")
        return int(text)
    return parse


def _beauty_size(text: str) -> tuple:
    w, sep, h = text.lower().partition("x")
    if not sep or not w.isdigit() or not h.isdigit() or not (64 <= int(w) <= 4096 and 64 <= int(h) <= 4096):
        raise argparse.ArgumentTypeError(f"{text!r} is not WxH with each 64 to 4096 pixels, e.g. 768x512")
    return int(w), int(h)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("asset", metavar="ASSET", help="the asset folder or its root layer (pigeon.usda)")
    parser.add_argument("--out", metavar="DIR", default=None,
                        help="report folder (default: verify/ beside the root layer)")
    parser.add_argument("--json", action="store_true", help="print the report summary as JSON on stdout")
    for side in ("width", "height"):
        parser.add_argument(f"--{side}", type=_ranged(f"verify.{side}", "pixels"), metavar=side[0].upper(),
                            help=f"render {side}, pixels (default [verify] {side})")
    parser.add_argument("--views", type=_ranged("verify.views", "views"), metavar="N",
                        help="turntable + light-sweep views (default [verify] views), plus the sweep at the flip")
    parser.add_argument("--cache", metavar="DIR",
                        help="the cache of renders already checked (default: the build's .rockdove-cache beside the "
                             "asset folder, else the user cache)")
    parser.add_argument("--view", dest="names", action="append", default=None, metavar="NAME",
                        help="check only this view (repeatable), e.g. --view sweep_090; default all")
    parser.add_argument("--hosts", default=None, metavar="LIST",
                        help="comma-separated hosts that also render the views, each checked against the exact "
                             "reference of its lighting model: glsl, materialx, materialx_physical, blender, web "
                             "(default: glsl, materialx, materialx_physical, blender, web where available; 'all' "
                             "adds Storm's; glsl always runs)")
    parser.add_argument("--bench-dir", default=None, metavar="DIR",
                        help="show the benchmark plots (*.png) of DIR in the report, e.g. build/bench "
                             "(default: none)")
    parser.add_argument("--beauty", default=None, choices=("auto", "cycles", "gl", "off"),
                        help="the report's opening picture: Cycles through the Blender add-on, GL, or auto "
                             "(default: Cycles when the blender host runs, else GL; [beauty] in the schema)")
    parser.add_argument("--beauty-size", type=_beauty_size, default=(None, None), metavar="WxH",
                        help="beauty render size, pixels (default 768x512)")
    parser.add_argument("--beauty-samples", type=_ranged("beauty.samples", "samples per pixel"), metavar="N",
                        help="Cycles samples per pixel of the beauty render (default 32, adaptive, denoised)")
    parser.add_argument("--junit", metavar="FILE", default=None,
                        help="also write the verification as JUnit XML (a test case per validator, view and host "
                             "view) for CI test-result pages")
    parser.add_argument("--motion", default=None, metavar="NAME",
                        help="also check a motion of the asset (walk or idle): its measures at every time code "
                             "(cards rigid, on the skin, the head, the feet, the head's hold and thrust) and the film "
                             "at --time codes, each frame skinned by UsdSkel")
    parser.add_argument("--time", dest="times", type=float, action="append", default=None, metavar="T",
                        help="a time code of --motion to check the film at (repeatable; default 15, 21 and 26: "
                             "one step of the walk)")
    parser.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    add_external_argument(parser)


def run(args: argparse.Namespace) -> int:
    from .. import api
    from ..errors import UsageError, VerificationFailed
    from ..verify.verdict import summary

    if args.times and not args.motion:
        raise UsageError(f"--time {args.times[0]:g} needs --motion: the time codes are a motion's")
    hosts = None if args.hosts is None else [h for h in args.hosts.split(",") if h.strip()]
    result = api.verify(args.asset, hosts, cache=args.cache, out=args.out, width=args.width, height=args.height,
                        views=args.names, n_views=args.views, bench_dir=args.bench_dir,
                        allow_external=args.allow_external_assets, motion=args.motion, times=args.times,
                        beauty={"renderer": args.beauty, "width": args.beauty_size[0],
                                "height": args.beauty_size[1], "samples": args.beauty_samples})
    report = result.report
    if args.junit:
        from ..verify.junit import write_junit

        write_junit(report, args.junit)
    if args.json:
        from ..verify.report import strict_json

        print(json.dumps(strict_json(summary(report)), indent=2, allow_nan=False))
    else:
        _print(report)
    if not result.passed:
        raise VerificationFailed("; ".join(result.failures))
    return 0


def _print(report) -> None:
    from ..verify.anatomy import format_rows

    def num(v, spec: str = ".3f") -> str:  # a NaN that report.json wrote as null reads back as None
        return format(float("nan") if v is None else v, spec)

    for m in report.views:
        print(f"{m.view:>16}: {m.n_pixels:7d} px  dE2000 median {num(m.de_median)}  p95 {num(m.de_p95)}  "
              f"max {num(m.de_max)}  {'ok' if m.passed else 'FAIL'}")
    h = report.hue_sweep
    print(f"light sweep hues: green {h.green}, purple {h.purple}, grey {h.grey}, other {h.other}")
    for name, b in report.boundary.per_view.items():
        print(f"boundary {name}: {b.n_points} points, RMS {num(b.rms_px, '.2f')} px "
              f"({num(b.rms_fraction, '.4f')} of its length)")
    for host in report.hosts:
        m = host.metrics
        if host.status == "skipped":
            print(f"host {host.name}: SKIPPED ({host.reason})")
        elif m is None:
            print(f"host {host.name}: ERROR {host.reason}")
        else:
            print(f"host {host.name} ({host.variant}, {host.lobe}): {m.n_pixels} px  dE2000 median "
                  f"{num(m.median_dE)}  p95 {num(m.p95_dE)}  green {m.green_px}  purple {m.purple_px}  "
                  f"hue agreement {num(m.hue_agreement, '.1%')}  {'ok' if host.passed else 'FAIL'}")
    if mo := report.motion:
        print(f"motion {mo.motion} ({mo.frames} time codes):", ", ".join(
            f"{k} {num(v, '.4g')}" for k, v in mo.measures.items()))
    print("anatomy (rockdove.verify.anatomy):", *format_rows(report.anatomy), sep="\n")
    if report.beauty:
        print(f"beauty render ({report.beauty['renderer']}): {report.beauty['seconds']:.1f} s")
    for note in report.notes:
        print(f"note: {note}")
    print(f"report: {os.path.join(report.out_dir, 'report.html')}")

"""``rockdove render ASSET --out DIR``: offscreen GLSL renders (:mod:`rockdove.render.gl`) of the default views,
one sRGB PNG each and ``contact_sheet.png``, averaging K x K samples per pixel in linear radiance."""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from ..errors import UsageError
from ..render.images import MAX_SHEET_PX, MAX_SIDE_PX
from .validate import add_external_argument


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("asset", metavar="ASSET", help="the asset folder or its root layer (pigeon.usda)")
    parser.add_argument("--out", required=True, metavar="DIR", help="folder for the PNGs (created)")
    parser.add_argument("--width", type=int, default=512, help="image width in pixels (default 512)")
    parser.add_argument("--height", type=int, default=512, help="image height in pixels (default 512)")
    parser.add_argument("--views", type=int, default=4, metavar="N",
                        help="number of views: ceil(N/2) turntable + floor(N/2) light sweep (default 4)")
    parser.add_argument("--supersample", type=int, default=2, metavar="K",
                        help="render K x K samples per pixel and average the linear radiance for the PNGs "
                             "(anti-aliasing; default 2, 1 = the raw pixel-centre render)")
    parser.add_argument("--shading", default=None, metavar="VARIANT",
                        help="the shading variant to select (baked or physical; default: as authored)")
    parser.add_argument("--motion", default=None, metavar="NAME",
                        help="pose the bird in this motion (walk or idle; default: the rest pose), skinned by UsdSkel")
    parser.add_argument("--time", type=float, default=None, metavar="T",
                        help="the --motion's time code to render (default its first; 60 a second)")
    parser.add_argument("--angle", default="physical", choices=("physical", "materialx_baked"),
                        help="film angle: physical = dot(L, H) (the paper), materialx_baked = |dot(N, V)|")
    add_external_argument(parser)


def run(args: argparse.Namespace) -> int:
    from ..graph.publish import claim_output
    from ..usd.dependencies import require_inside

    if not 1 <= args.supersample <= 4:
        raise UsageError(f"--supersample must be in [1, 4], got {args.supersample}")
    for key in ("width", "height"):
        v = getattr(args, key)
        if not 1 <= v * args.supersample <= MAX_SIDE_PX:
            raise UsageError(f"--{key} x --supersample must be in [1, {MAX_SIDE_PX}] pixels (the memory budget), "
                             f"got {v} x {args.supersample}")
    if args.views < 1 or args.views * args.width * args.height > MAX_SHEET_PX:
        raise UsageError(f"--views must be >= 1 and --views x --width x --height <= {MAX_SHEET_PX} pixels (the "
                         f"memory budget), got {args.views} x {args.width} x {args.height}")
    claim_output(args.out, "renders", create=False)  # a folder rockdove did not write is refused, before rendering
    require_inside(args.asset, args.allow_external_assets)
    from ..png import save_png
    from ..render.gl import GLRenderer
    from ..render.images import box_downsample, contact_sheet
    from ..render.scene import load_scene
    from ..render.views import View, default_views
    from ..srgb import linear_to_srgb8

    t0 = time.perf_counter()
    variants = {k: v for k, v in (("shading", args.shading), ("motion", args.motion)) if v}
    scene = load_scene(args.asset, variants=variants or None, time=args.time)
    t_load = time.perf_counter() - t0
    views = default_views(scene, args.width, args.height, n=args.views)
    k = args.supersample
    big = [View(v.name, v.camera_to_world, v.yfov_rad, v.width * k, v.height * k, v.light_direction, v.light_rgb)
           for v in views]
    t1 = time.perf_counter()
    args.out = str(claim_output(args.out, "renders"))
    tiles, t_write = [], 0.0
    with GLRenderer(scene, angle_mode=args.angle, width=big[0].width, height=big[0].height) as renderer:
        for v in big:  # one view's float buffers at a time: memory does not grow with --views
            r = renderer.render(v)
            t2 = time.perf_counter()
            rgb, alpha = box_downsample(r.radiance_rgb, k), box_downsample(r.alpha, k)
            img = np.dstack([linear_to_srgb8(rgb), (np.clip(alpha, 0, 1) * 255 + 0.5).astype(np.uint8)])
            tiles.append((r.view.name, img))
            path = save_png(img, os.path.join(args.out, f"{r.view.name}.png"))
            print(f"{path}  ({r.seconds * 1e3:.1f} ms)")
            del r, rgb, alpha
            t_write += time.perf_counter() - t2
    t_render = time.perf_counter() - t1 - t_write
    t2 = time.perf_counter()
    sheet = contact_sheet(os.path.join(args.out, "contact_sheet.png"),
                          [tiles[i:i + 4] for i in range(0, len(tiles), 4)])
    t_write += time.perf_counter() - t2
    print(sheet)
    print(f"load {t_load:.2f} s, render {len(big)} views at {args.width}x{args.height} ({k}x{k} samples per "
          f"pixel) {t_render:.2f} s (incl. context and upload), write {t_write:.2f} s")
    return 0

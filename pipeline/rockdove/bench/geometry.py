"""``rockdove bench geometry``: how the procedural bird scales with the number of neck feather cards.

Rows, each a median of ``--repeats`` runs timed with ``time.perf_counter`` in this process:

- the body (surface nets on the 8 mm unwrap grid, xatlas UVs, then subdivided onto the implicit surface to the
  detail ``body_voxel_m``), built once: the build graph caches it, so it is reported on its own, with its
  phases (coarse mesh, xatlas, subdivision + projection + relaxation) timed separately;
- the cards alone (``build_cards``: blue-noise placement, card strips, thickness) at 1k, 10k and 100k cards;
  goals: 1,000 cards well under a second (< 0.5 s), 100,000 cards under 10 s;
- the whole bird given the body (``build_bird(params, body=...)``: cards + the other parts);
- the textures (feather base + mask at the default resolution, body base colour at the default resolution).

Imports are warmed up before the first row. Peak memory is measured in a separate, untimed run of each row
with ``tracemalloc`` (numpy reports its array allocations to it), so the timing runs carry no tracing overhead.
The band coverage (the fraction of the neck band's skin hidden by cards, rays along the skin normal,
alpha-tested with the feather silhouette) is reported for each card count."""

from __future__ import annotations

import argparse
import json
import statistics
import time
import tracemalloc

from ..errors import UsageError

HELP = "geometry benchmarks: body, cards and whole bird at 1k/10k/100k cards (median time, peak memory)"

#: The goals (seconds).
GOAL_1K_S = 0.5
GOAL_100K_S = 10.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true",
                        help="a smoke test: coarse body, 200 and 1,000 cards, one repeat, no coverage")
    parser.add_argument("--repeats", type=int, default=3, help="repeats per timed row (median; default 3)")
    parser.add_argument("--counts", type=int, nargs="+", default=None,
                        help="card counts (default 1000 10000 100000)")
    parser.add_argument("--no-coverage", action="store_true", help="skip the ray-cast coverage column")
    parser.add_argument("--json", metavar="FILE", help="also write the results as JSON to FILE")


def _median_time(fn, repeats: int) -> tuple[float, object]:
    times, result = [], None
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), result


def _peak_mib(fn) -> float:
    tracemalloc.start()
    try:
        fn()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak / 2**20


def _body_phase_rows(row, voxel_m: float, repeats: int) -> None:
    """Rows for the phases of ``build_body``: coarse surface nets, xatlas, subdivision onto the surface."""
    from rockdove.geometry import body as _body
    from rockdove.geometry import sdf as _sdf
    from rockdove.geometry import uv as _uv

    levels = _body.subdivision_levels(voxel_m)
    coarse = row(f"  surface nets {_body.UNWRAP_VOXEL_M * 1000:g} mm", None,
                 lambda: _body.build_body_mesh(_body.UNWRAP_VOXEL_M), repeats,
                 lambda m: {"triangles": len(m.faces)})
    at = row("  xatlas unwrap", None, lambda: _uv.atlas(coarse.vertices_m, coarse.faces), repeats)
    row(f"  subdivide x{levels} + relax", None,
        lambda: _body.subdivide_onto_surface(_sdf.body_sdf, coarse.vertices_m[at.vmapping], at.faces, at.st, levels),
        repeats, lambda r: {"triangles": len(r[2])})


def run(args: argparse.Namespace) -> int:
    from rockdove import textures
    from rockdove.geometry import BirdParams, build_bird, build_body, build_cards

    from .coverage import band_coverage

    if args.repeats < 1:
        raise UsageError(f"--repeats={args.repeats} must be >= 1")
    quick = args.quick
    counts = args.counts or ([200, 1000] if quick else [1000, 10000, 100000])
    if any(c < 1 for c in counts):
        raise UsageError(f"--counts={counts} must all be >= 1")
    repeats = 1 if quick else args.repeats
    base = BirdParams(body_voxel_m=0.008) if quick else BirdParams()
    coverage = not (quick or args.no_coverage)
    rows = []
    # warm up: the rows time the work, not the first import of trimesh, xatlas or colour-science (a cold build's
    # imports are in ``rockdove bench build``)
    import trimesh  # noqa: F401
    import xatlas  # noqa: F401

    textures.feather_textures(16)

    def row(name, count, fn, reps, extra=None):
        t, result = _median_time(fn, reps)
        peak = _peak_mib(fn)
        rows.append({"row": name, "cards": count, "median_s": t, "peak_mib": peak, "repeats": reps,
                     **(extra(result) if extra else {})})
        return result

    body = row(f"body (detail {base.body_voxel_m * 1000:g} mm)", None, lambda: build_body(base), repeats,
               lambda b: {"triangles": len(b.mesh.faces), "uv_vertices": len(b.part.points_m)})
    _body_phase_rows(row, base.body_voxel_m, repeats)
    alpha = textures.feather_textures(base.feather_texture_resolution)["base"][..., 3]
    for n in counts:
        p = base.with_(card_count=n)

        def cov(cards):
            if not coverage:
                return {}
            return {"coverage": band_coverage(body.mesh.vertices_m, body.mesh.faces, cards, rays=2000, alpha=alpha)}

        row("cards", n, lambda p=p: build_cards(body, p), repeats, cov)
        row("bird given body", n, lambda p=p: build_bird(p, body=body), repeats)
    row(f"feather textures {base.feather_texture_resolution}^2", None,
        lambda: textures.feather_textures(base), repeats)
    row(f"body texture {base.body_texture_resolution}^2", None,
        lambda: textures.body_base_colour(base, body), repeats)

    print(f"{'row':<28} {'cards':>8} {'median s':>10} {'peak MiB':>10} {'coverage':>9}")
    for r in rows:
        cards = "" if r["cards"] is None else f"{r['cards']:,}"
        c = f"{r['coverage']:.4f}" if "coverage" in r else ""
        print(f"{r['row']:<28} {cards:>8} {r['median_s']:>10.3f} {r['peak_mib']:>10.1f} {c:>9}")
    goals = {1000: GOAL_1K_S, 100000: GOAL_100K_S}
    for r in rows:
        if r["row"] == "cards" and r["cards"] in goals:
            ok = r["median_s"] < goals[r["cards"]]
            r["goal_s"] = goals[r["cards"]]
            r["goal_met"] = ok
            print(f"goal: {r['cards']:,} cards in < {goals[r['cards']]:g} s: "
                  f"{'met' if ok else 'MISSED'} ({r['median_s']:.3f} s)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"topic": "geometry", "quick": quick, "rows": rows}, f, indent=2)
    return 0

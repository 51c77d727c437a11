"""A small stand-in pipeline with the same shape and rules as the real one (pipeline/rockdove/graph/stages.py).

geometry -> thickness range -> LUT (only for baked shading, one texel high when the film is uniform) -> textures
-> USD layers -> usdz -> per-view verification, each in well under a millisecond, so the graph framework and
the ``build`` command are tested fast. Tests pass it to :class:`rockdove.graph.engine.Graph` directly, and the
CLI tests run the real command with it through ``tests/launcher.py`` (which patches it in: production code
reads no test hook).
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from rockdove.graph import engine as G
from rockdove.verify.results import Verdict


def standin_body(ctx):
    rng = np.random.default_rng(0)
    return {"points_m": rng.normal(size=(64, 3)).astype(np.float32)}


def _cards(ctx):
    g, t = ctx.config["geometry"], ctx.config["thickness"]
    rng = np.random.default_rng(g["seed"])
    s = rng.uniform(0, 1, g["card_count"])
    lo = np.interp(s, [0, 1], [t["base_nm"][0], t["top_nm"][0]])
    hi = np.interp(s, [0, 1], [t["base_nm"][1], t["top_nm"][1]])
    thickness = lo + (hi - lo) * rng.uniform(0, 1, g["card_count"])
    return {"thickness_nm": thickness.astype(np.float32), "s": s.astype(np.float32),
            "body_points": ctx.inputs["body"]["points_m"][:1]}


def _thickness_range(ctx):
    d = ctx.inputs["cards"]["thickness_nm"]
    return [float(np.floor(d.min())), float(np.ceil(d.max()))]


def _lut(ctx):
    lo, hi = ctx.inputs["thickness_range"]
    rows = 1 if lo == hi else ctx.config["lut"]["thicknesses"]
    n = ctx.config["film"]["cauchy_a"] or 1.5
    d = np.linspace(lo, hi, rows)[:, None, None]
    rgb = np.cos(2 * np.pi * n * d / np.array([600.0, 550.0, 450.0]) + np.linspace(0, 1, ctx.config["lut"]["angles"])[None, :, None])
    np.save(ctx.workdir / "thinfilm_lut.npy", rgb.astype(np.float32))


def _textures(ctx):
    (ctx.workdir / "feather_base.txt").write_text(f"feather {ctx.config['textures']['feather_resolution']}\n")
    (ctx.workdir / "body_base.txt").write_text(f"body {ctx.config['textures']['body_resolution']}\n")


def _usd_layers(ctx):
    lut = "./textures/thinfilm_lut.npy" if "lut" in ctx.inputs else "none"
    thickness = ctx.inputs["cards"]["thickness_nm"]
    (ctx.workdir / "pigeon.usda").write_text(
        f"#usda stand-in\nfilm = {json.dumps(ctx.config['film'], sort_keys=True)}\nshading = "
        f"{ctx.config['shading']['variant']}\nlut = {lut}\ncards = {thickness.size}\n")


def _usdz(ctx):
    with zipfile.ZipFile(ctx.workdir / "pigeon.usdz", "w") as z:
        for name in ("usd_layers", "textures", "lut"):
            if name in ctx.inputs:
                for p in sorted(Path(ctx.inputs[name]).rglob("*")):
                    z.writestr(p.name, p.read_bytes())


def _verify(ctx):
    v = ctx.config["verify"]
    text = (ctx.asset_dir / "pigeon.usda").read_text()
    views = {f"view_{i:03d}": {"chars": len(text), "pixels": v["width"] * v["height"]} for i in range(v["views"])}
    # stand-in rule for the failed-verification test: a width of 17 px "fails"
    passed = ctx.config["verify"]["width"] != 17
    (ctx.workdir / "report.json").write_text(json.dumps({"views": views, "passed": passed}))
    return Verdict(passed, "stand-in width 17").to_json()




VERDICT = G.Codec("verdict", lambda v, f: (f / "verdict.json").write_text(json.dumps(v)),
                  lambda f: json.loads((f / "verdict.json").read_text()))


def standin_stages(config, *, verify=True):
    """The stand-in graph, built from the configuration like the real one."""
    variant = config["shading"]["variant"]
    stages = [
        G.Stage("body", standin_body, codec=G.NPZ),
        G.Stage("cards", _cards, config=("geometry.seed", "geometry.card_count", "thickness"), deps=("body",),
                codec=G.NPZ),
        G.Stage("thickness_range", _thickness_range, deps=("cards",)),
    ]
    if variant != "physical":
        stages.append(G.Stage("lut", _lut, config=("film", "lut"), deps=("thickness_range",), codec=G.FILES,
                              publish="textures"))
    stages.append(G.Stage("textures", _textures, config=("textures",), codec=G.FILES, publish="textures"))
    layer_deps = ("cards", "textures") + (("lut",) if variant != "physical" else ())
    stages.append(G.Stage("usd_layers", _usd_layers, config=("film", "shading"), deps=layer_deps, codec=G.FILES,
                          publish=""))
    if config["usd"]["usdz"]:
        stages.append(G.Stage("usdz", _usdz, deps=("usd_layers",) + layer_deps[1:], codec=G.FILES, publish=""))
    if verify:
        stages.append(G.Stage("verify", _verify, config=("verify",), deps=layer_deps + ("usd_layers",),
                              codec=VERDICT, needs_asset=True))
    return stages

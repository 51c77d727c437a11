"""Write the offline viewer ``verify/viewer.html``: pigeon.glb in three.js. A ``file://`` page may neither ``fetch``
nor load module scripts (origin ``null``), so data and ES modules arrive as classic ``<script src>`` tags beside the
page, which ``viewer_loader.js`` turns into same-origin ``blob:`` modules (docs/viewer.md)."""

from __future__ import annotations

import base64
import json
import os
import shutil
from pathlib import Path

import numpy as np

from .. import resources
from ..config import get, limits, load_config, load_schema, presets
from ..errors import ResourceMissing, UsageError
from ..films import film_from_config
from ..lut import fourier as F
from ..lut import quadrature as Q
from ..lut.bake import DEFAULT_FOURIER_TOL, DEFAULT_MAX_TERMS
from ..lut.weights import chebyshev_weights, colour_weights, reference_wavelengths
from ..render.scene import load_scene
from ..render.views import default_views, light_sweep_views
from ..spectral import WAVELENGTH_RANGE_NM
from ..usd.stage import BUILD_CONFIG_KEY, LOOKS_LAYER
from .gltf import THICKNESS_RAMP_TEXELS

#: ES modules of the npm package three, by the name viewer_loader.js knows them.
THREE_MODULES = {
    "three.core.js": "three/build/three.core.js",
    "three.module.js": "three/build/three.module.js",
    "BufferGeometryUtils.js": "three/examples/jsm/utils/BufferGeometryUtils.js",
    "SkeletonUtils.js": "three/examples/jsm/utils/SkeletonUtils.js",
    "GLTFLoader.js": "three/examples/jsm/loaders/GLTFLoader.js",
    "OrbitControls.js": "three/examples/jsm/controls/OrbitControls.js",
}
#: The light-view angle (degrees) of the viewer's start light: the green side of the paper's flip.
START_LIGHT_VIEW_DEG = 60.0
#: The page's Fourier table: rockdove.lut.fourier's G every G_STEP_NM nm (4-point Lagrange there: relative error
#: (2 pi h / 360 nm)^4 3 / 128 < 1e-6) up to G_END_NM (where |G| < 6e-5 of the white), and its Chebyshev rules up to
#: LADDER_END nodes (a column needing more is integrated on the reference's 0.1 nm grid, as costly).
G_STEP_NM, G_END_NM, LADDER_END = 4.0, 131072.0, 1536


def web_folder() -> Path:
    return resources.path("materials/web")


def three_folder() -> Path:
    """``materials/web/node_modules`` with the npm package three in it; ResourceMissing where it is not installed."""
    nm = web_folder() / "node_modules"
    if not (nm / "three" / "package.json").is_file():
        raise ResourceMissing(f"the npm package three (for verify/viewer.html) is not installed in {nm.parent}; run "
                              f"`npm ci --prefix {nm.parent}` (make asset / make test do), or build with "
                              "--set gltf.glb=false (no glb, no viewer)")
    return nm


def start_view(scene):
    """The viewer's first camera and light: the light-sweep camera on the neck, lit at :data:`START_LIGHT_VIEW_DEG`."""
    sweep = [v for v in default_views(scene, 512, 512, n=2) if v.name.startswith("sweep_")][0]
    neck = np.asarray(scene.neck_centre_m, np.float64)
    eye = sweep.camera_to_world[:3, 3]
    dist = float(np.linalg.norm(eye - neck))
    return light_sweep_views(neck, 1, 512, 512, angles_deg=[START_LIGHT_VIEW_DEG], distance_m=dist,
                             yfov_deg=float(np.degrees(sweep.yfov_rad)), camera_direction=(eye - neck) / dist)[0]


def _b64(array, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(array, dtype=dtype).tobytes()).decode("ascii")


def film_tables() -> dict:
    """The tables film_bake.js integrates with, rockdove.lut's own (D65, CIE 1931 2 deg, lin_rec709)."""
    g = F.g_table()
    ladder = [n for n in Q.NODE_LADDER if n <= LADDER_END]
    rules = [chebyshev_weights(n) for n in ladder]
    return {"wavelength_range_nm": list(WAVELENGTH_RANGE_NM),
            "reference_weights": _b64(colour_weights(reference_wavelengths()), "<f8"),
            "g_step_nm": G_STEP_NM, "g": _b64(g.g[: int(G_END_NM / g.step_nm) + 1 : int(G_STEP_NM / g.step_nm)], "<f4"),
            "ladder": ladder, "ladder_wavelength_nm": _b64(np.concatenate([r[0] for r in rules]), "<f8"),
            "ladder_weights": _b64(np.concatenate([r[1] for r in rules]), "<f4"),
            # a tenth of rockdove.lut.bake's Fourier tolerance: it sums each block of columns to its largest term
            # count, the page each column to its own
            "constants": {"FOURIER_TOL": DEFAULT_FOURIER_TOL / 10, "MAX_TERMS": DEFAULT_MAX_TERMS, "K_FULL": Q.K_FULL,
                          "K_SERIES": Q.K_SERIES, "N_MIN": Q.N_MIN, "SERIES_COST": Q.SERIES_COST,
                          "MAX_NODES": Q.MAX_NODES, "SERIES_TOL": Q.DEFAULT_SERIES_TOL,
                          "ANGLE_PANEL_COS": Q.ANGLE_PANEL_COS, "K_ANGLE": Q.K_ANGLE, "N_ANGLE_MIN": Q.N_ANGLE_MIN}}


#: The keys of the film panel and of ``window.rockdove.film()``: configuration key -> its section.
FILM_KEYS = {**dict.fromkeys(("cauchy_a", "cauchy_b_nm2", "k", "n_incident", "n_substrate"), "film"),
             "base_nm": "thickness", "top_nm": "thickness"}


def _toml(value) -> str:
    """``value`` as the TOML literal of a ``--set KEY=VALUE``."""
    if isinstance(value, list):
        return "[" + ", ".join(map(_toml, value)) + "]"
    return ("true" if value else "false") if isinstance(value, bool) else json.dumps(value)


def _film_of(config: dict) -> dict:
    film = film_from_config(config["film"])
    return {k: float(getattr(film, k)) if s == "film" else config[s][k] for k, s in FILM_KEYS.items()}


def film_panel_data(scene, lut) -> dict:
    """What the film panel (film_panel.js) starts from: the asset's film (as its looks layer records), presets."""
    from pxr import Sdf

    recorded, looks = None, Sdf.Layer.FindOrOpen(os.path.join(os.path.dirname(scene.root_layer), LOOKS_LAYER))
    try:
        flat = json.loads(looks.customLayerData.get(BUILD_CONFIG_KEY, "null") if looks else "null")
        if isinstance(flat, dict):
            flat = {f"{s}.{k}": v for s, section in flat.items() for k, v in dict(section).items()}
            recorded = (load_config(overrides=flat), flat)
    except (ValueError, TypeError, UsageError):  # not JSON, not sections, or not a valid configuration: unknown
        recorded = None
    default = load_config()
    feather = [p for p in scene.parts if p.is_feather]
    field = feather[0].thickness_field if len(feather) == 1 else None
    sets = []
    if recorded is not None and field is not None:
        asset = _film_of(recorded[0])
        sets = [[k, _toml(v)] for k, v in sorted(recorded[1].items()) if not k.startswith("film.")
                and k not in ("thickness.base_nm", "thickness.top_nm") and v is not None and v != get(default, k)]
    else:  # the film the USD records (float attributes: their shortest decimals); the ranges unknown
        model = scene.film.model
        asset = {k: float(str(np.float32(np.real(getattr(model, k))))) if s == "film" else None
                 for k, s in FILM_KEYS.items()}
    schema = load_schema()["properties"]
    # a uniform film's LUT is one row: a range then takes the configured (else default) count of rows
    thicknesses = (recorded or (default,))[0]["lut"]["thicknesses"] if lut.n_thickness == 1 else lut.n_thickness
    return {"tables": film_tables(), "asset": asset,
            "presets": {name: _film_of(load_config(preset=name)) for name in presets()},
            "limits": {k: list(limits(f"{s}.{k}")) for k, s in FILM_KEYS.items()},
            "units": {k: schema[s]["properties"][k]["unit"] for k, s in FILM_KEYS.items()},
            "lut": {"angles": lut.n_angle, "thicknesses": thicknesses, "angle_warp_gamma": lut.angle_warp_gamma,
                    "colour_space": lut.colour_space},
            "field": None if asset["base_nm"] is None else _b64(field, "<f4"), "sets": sets}


def viewer_data(scene, lut, glb_bytes: bytes, asset_name: str) -> dict:
    """What ``viewer_data.js`` holds (JSON-serialisable)."""
    view = start_view(scene)
    web = web_folder()
    rgb = np.ascontiguousarray(lut.rgb, dtype=np.float32)  # (n_thickness, n_angle, 3), row 0 thinnest
    return {
        "asset_name": asset_name,
        "glb": base64.b64encode(glb_bytes).decode("ascii"),
        "lut": {"rgb_f32": _b64(rgb, "float32"), "n_angle": int(rgb.shape[1]),
                "n_thickness": int(rgb.shape[0]), "angle_warp_gamma": float(lut.angle_warp_gamma),
                "thickness_range_nm": [float(v) for v in lut.thickness_range_nm],
                "colour_space": lut.colour_space,
                "verification_only": "purpose" in lut.metadata},
        "ramp_texels": THICKNESS_RAMP_TEXELS,
        "shaders": {k: (web / f"thinfilm_webgl.{k}").read_text() for k in ("vert", "frag")},
        "camera": {"eye_m": view.camera_to_world[:3, 3].tolist(), "target_m": [float(v) for v in scene.neck_centre_m],
                   "yfov_deg": float(np.degrees(view.yfov_rad))},
        "light": {"direction": view.light_direction.tolist()},
        "film": film_panel_data(scene, lut),
    }


def write_viewer(asset, glb_path, out_dir, asset_name: str | None = None) -> str:
    """Write ``viewer.html`` and its files into ``out_dir``; the page's path (``asset_name`` default: its folder)."""
    out = Path(out_dir)
    (out / "three").mkdir(parents=True, exist_ok=True)
    nm = three_folder()
    web = web_folder()
    scene = load_scene(asset)
    name = asset_name or scene.root_layer  # a path shows as its asset folder's name: no build machine's path
    if os.path.isabs(name) or os.sep in name:
        name = os.path.basename(os.path.dirname(name) if name.endswith((".usda", ".usd", ".usdc", ".usdz")) else name)
    data = viewer_data(scene, scene.load_lut(), Path(glb_path).read_bytes(), name)
    (out / "viewer_data.js").write_text("window.ROCKDOVE_DATA = " + json.dumps(data) + ";\n")
    modules = {**{n: nm / p for n, p in THREE_MODULES.items()}, "motion_player.js": web / "motion_player.js",
               "viewer_app.js": web / "viewer_app.js"}
    for name, src in modules.items():
        source = json.dumps(src.read_text(encoding="utf-8"))
        (out / "three" / name).write_text(f"(window.ROCKDOVE_MODULES = window.ROCKDOVE_MODULES || {{}})"
                                          f"[{json.dumps(name)}] = {source};\n")
    tags = "\n".join(f'<script src="three/{name}"></script>' for name in modules)
    for name in ("viewer_loader.js", "film_bake.js", "film_panel.js"):
        shutil.copyfile(web / name, out / name)
    page = (web / "viewer.html").read_text(encoding="utf-8")
    (out / "viewer.html").write_text(page.replace("<!--MODULE_SCRIPTS-->", tags))
    return str(out / "viewer.html")

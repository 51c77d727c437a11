"""Write the offline interactive viewer ``verify/viewer.html``: pigeon.glb in three.js, beside its data.

A ``file://`` page in Chromium may neither ``fetch`` files nor load module scripts from disk (origin ``null``), so
everything arrives through classic ``<script src>`` tags beside the page: ``viewer_data.js`` (the GLB and the
asset's float LUT in base64, the WebGL2 shaders ``materials/web/thinfilm_webgl.*``, the start camera and light);
``three/*.js``, the ES modules of the npm package ``three`` (``materials/web/node_modules``, pinned in
``package.json``), ``motion_player.js`` (the motion switch, play and pause) and ``viewer_app.js``, each copied
verbatim into a JavaScript string; ``viewer_loader.js``, which makes each module a same-origin ``blob:`` URL with its
imports pointed at its dependencies', then imports the app.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
from pathlib import Path

import numpy as np

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


def web_folder() -> Path:
    from .. import resources

    return resources.path("materials/web")


def three_folder() -> Path:
    """``materials/web/node_modules`` with the npm package three in it; ResourceMissing (a ``FileNotFoundError``: the
    CLI prints it in one line, exit 2) where three is not installed."""
    from ..errors import ResourceMissing

    nm = web_folder() / "node_modules"
    if not (nm / "three" / "package.json").is_file():
        raise ResourceMissing(f"the npm package three (for verify/viewer.html) is not installed in {nm.parent}; run "
                              f"`npm ci --prefix {nm.parent}` (make asset / make test do), or build with "
                              "--set gltf.glb=false (no glb, no viewer)")
    return nm


def start_view(scene):
    """The viewer's first camera and light: the verification's light-sweep camera on the neck, lit at
    :data:`START_LIGHT_VIEW_DEG` between light and view (``rockdove.render.views``)."""
    from ..render.views import default_views, light_sweep_views

    sweep = [v for v in default_views(scene, 512, 512, n=2) if v.name.startswith("sweep_")][0]
    neck = np.asarray(scene.neck_centre_m, np.float64)
    eye = sweep.camera_to_world[:3, 3]
    dist = float(np.linalg.norm(eye - neck))
    return light_sweep_views(neck, 1, 512, 512, angles_deg=[START_LIGHT_VIEW_DEG], distance_m=dist,
                             yfov_deg=float(np.degrees(sweep.yfov_rad)), camera_direction=(eye - neck) / dist)[0]


def viewer_data(scene, lut, glb_bytes: bytes, asset_name: str) -> dict:
    """What ``viewer_data.js`` holds (JSON-serialisable)."""
    from .gltf import THICKNESS_RAMP_TEXELS

    view = start_view(scene)
    web = web_folder()
    rgb = np.ascontiguousarray(lut.rgb, dtype=np.float32)  # (n_thickness, n_angle, 3), row 0 thinnest
    return {
        "asset_name": asset_name,
        "glb": base64.b64encode(glb_bytes).decode("ascii"),
        "lut": {"rgb_f32": base64.b64encode(rgb.tobytes()).decode("ascii"), "n_angle": int(rgb.shape[1]),
                "n_thickness": int(rgb.shape[0]), "angle_warp_gamma": float(lut.angle_warp_gamma),
                "thickness_range_nm": [float(v) for v in lut.thickness_range_nm],
                "colour_space": lut.colour_space,
                "verification_only": "purpose" in lut.metadata},
        "ramp_texels": THICKNESS_RAMP_TEXELS,
        "shaders": {"vert": (web / "thinfilm_webgl.vert").read_text(), "frag": (web / "thinfilm_webgl.frag").read_text()},
        "camera": {"eye_m": view.camera_to_world[:3, 3].tolist(), "target_m": [float(v) for v in scene.neck_centre_m],
                   "yfov_deg": float(np.degrees(view.yfov_rad))},
        "light": {"direction": view.light_direction.tolist()},
    }


def write_viewer(asset, glb_path, out_dir, asset_name: str | None = None) -> str:
    """Write ``viewer.html`` and the files beside it into ``out_dir`` (the asset's ``verify/``); return the page's
    path. ``asset`` (folder or root layer) gives the scene and LUT (a physical-only asset's is baked in memory,
    :meth:`rockdove.render.scene.RenderScene.load_lut`), ``glb_path`` its ``pigeon.glb``; ``asset_name`` is shown
    on the page (default: the asset folder's name)."""
    from ..render.scene import load_scene

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
    shutil.copyfile(web / "viewer_loader.js", out / "viewer_loader.js")
    page = (web / "viewer.html").read_text(encoding="utf-8")
    (out / "viewer.html").write_text(page.replace("<!--MODULE_SCRIPTS-->", tags))
    return str(out / "viewer.html")

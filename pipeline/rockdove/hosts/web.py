"""The web host: three.js's ``KHR_materials_iridescence`` (Belcour & Barla 2017) on the asset's ``pigeon.glb``, in
headless Chromium (WebGL2 on SwiftShader), the offline viewer page drawing a float render target (``view_angle``)."""

from __future__ import annotations

import base64
import json
import os
from pathlib import Path

import numpy as np

from ..png import save_png
from ..srgb import linear_to_srgb8
from ..usd.layout import resolve_root_layer
from .base import Host, HostError

NAME = "web"
#: Seconds for the page to load the GLB and draw its first frame (SwiftShader, 2 cores: about 10 s).
PAGE_TIMEOUT_S = 120.0
#: Seconds for one View to render and read back.
VIEW_TIMEOUT_S = 120.0


class WebHost(Host):
    """three.js in headless Chromium (module docstring)."""

    def unavailable(self) -> str | None:
        from ..web.browser import BrowserError, find_chromium
        from ..web.viewer import three_folder

        try:
            find_chromium()
            three_folder()
        except (BrowserError, OSError) as exc:  # no chromium; three not installed (ResourceMissing)
            return str(exc)
        return None

    def render(self, asset_path: str, views, out_dir: str, *, browser_factory=None) -> dict:
        """:meth:`Host.render` with three.js in headless Chromium; ``browser_factory``: a started Browser (tests)."""
        from ..web.browser import Browser, BrowserError
        from ..web.gltf import GLB_NAME, export_glb
        from ..web.viewer import write_viewer

        out = Path(out_dir)
        page_dir = out / "web"
        page_dir.mkdir(parents=True, exist_ok=True)
        layer = resolve_root_layer(asset_path)
        glb = Path(layer).parent / GLB_NAME  # the asset's own, else exported beside the page
        if not glb.is_file():
            export_glb(layer, page_dir / GLB_NAME)
            glb = page_dir / GLB_NAME
        try:
            page_path = write_viewer(asset_path, glb, page_dir)
        except (ValueError, RuntimeError, OSError) as exc:
            raise HostError(NAME, f"could not write the viewer page: {exc}") from None
        images = {}
        try:
            with (browser_factory or Browser)() as browser:
                page = browser.open(Path(page_path).absolute().as_uri(), 320, 240, timeout_s=PAGE_TIMEOUT_S)
                page.evaluate("window.rockdoveReady", timeout_s=PAGE_TIMEOUT_S, step="load pigeon.glb in three.js")
                for view in views:
                    spec = {**view.to_dict(), "camera_to_world": view.camera_to_world.reshape(-1).tolist()}
                    res = page.evaluate(f"window.rockdoveRender({json.dumps(spec)}, 'physical')",
                                        timeout_s=VIEW_TIMEOUT_S, step=f"render {view.name}")
                    rgb = np.frombuffer(base64.b64decode(res["rgb_f32"]), np.float32)
                    images[view.name] = rgb.reshape(view.height, view.width, 3).copy()
                    save_png(linear_to_srgb8(images[view.name]), os.fspath(out / f"web_{view.name}.png"))
                if page.errors:
                    raise HostError(NAME, "the page reported errors: " + "; ".join(page.errors[:3]))
        except BrowserError as exc:
            raise HostError(NAME, str(exc)) from None
        return images


HOST = WebHost(NAME, "physical", "view_angle")

"""The web viewer and the web host in a real browser (Debian's headless chromium, WebGL2 on SwiftShader)."""

from __future__ import annotations

import io

import numpy as np
import pytest


@pytest.fixture(scope="session")
def web_asset(tmp_path_factory):
    """A synthetic asset (ring of cards, 480-700 nm) with a real keratin LUT, its GLB and its viewer page."""
    from pipeline.films import get_film
    from pipeline.lut.bake import bake
    from pipeline.render.synthetic import THICKNESS_RANGE_NM, write_synthetic_asset
    from pipeline.web.gltf import export_glb
    from pipeline.web.viewer import write_viewer

    root = tmp_path_factory.mktemp("web")
    lut = bake(angles=64, thicknesses=16, thickness_range=THICKNESS_RANGE_NM, film=get_film("keratin"))
    write_synthetic_asset(root / "asset", lut=lut, n_cards=12)
    export_glb(root / "asset", root / "asset" / "pigeon.glb")
    page = write_viewer(root / "asset", root / "asset" / "pigeon.glb", root / "verify")
    return root / "asset", page


def _hue_counts(png: bytes):
    from PIL import Image

    from pipeline.render.compare import hue_classes

    srgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.float64) / 255.0
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    _, _, cls = hue_classes(linear)
    return int(np.sum(cls == 1)), int(np.sum(cls == 2)), linear


def test_viewer_loads_shows_green_and_purple_and_the_light_turns_them(web_asset):
    from pipeline.web.browser import Browser

    _, page_path = web_asset
    with Browser() as browser:
        page = browser.open(f"file://{page_path}", 480, 400, timeout_s=120)
        ready = page.evaluate("window.rockdoveReady", timeout_s=120, step="viewer ready")
        assert ready["feathers"] == 1 and ready["webgl2"]
        green0, purple0, before = _hue_counts(page.screenshot())
        page.evaluate("window.rockdoveSetLight(Number(document.getElementById('light').value) + 60)")
        green1, purple1, after = _hue_counts(page.screenshot())
        page.evaluate("document.querySelector('input[value=physical]').click()")
        green2, purple2, _ = _hue_counts(page.screenshot())
        errors = page.errors
    assert errors == []
    assert green0 > 50 and purple0 > 50, (green0, purple0)
    assert np.mean(np.abs(after - before)) > 0.005  # the light turned: the picture changed
    assert (green1, purple1) != (green0, purple0)
    assert green2 > 20 and purple2 > 20, (green2, purple2)  # three.js's own iridescence shows both too


def test_web_host_renders_linear_green_and_purple_on_black(web_asset, tmp_path):
    from pipeline.hosts import web
    from pipeline.render.compare import hue_classes
    from pipeline.render.scene import load_scene
    from pipeline.render.views import default_views

    asset, _ = web_asset
    view = [v for v in default_views(load_scene(asset), 96, 96, n=2) if v.name.startswith("sweep_")][0]
    images = web.render(str(asset), [view], str(tmp_path))
    rgb = images[view.name]
    assert rgb.shape == (96, 96, 3) and rgb.dtype == np.float32
    assert np.all(rgb[0, 0] == 0)  # background 0
    _, _, cls = hue_classes(rgb)
    assert np.sum(cls == 1) > 10 and np.sum(cls == 2) > 10
    assert (tmp_path / f"web_{view.name}.png").is_file()


def test_a_browser_that_cannot_start_is_a_named_host_failure(web_asset, tmp_path):
    from pipeline.hosts import HostError, web
    from pipeline.render.scene import load_scene
    from pipeline.render.views import default_views
    from pipeline.web.browser import Browser

    asset, _ = web_asset
    views = default_views(load_scene(asset), 32, 32, n=1)
    with pytest.raises(HostError, match=r"host 'web': false exited with status 1 \(start\)"):
        web.render(str(asset), views, str(tmp_path), browser_factory=lambda: Browser(executable="false",
                                                                                   start_timeout_s=20))

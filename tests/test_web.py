"""The web viewer and the web host in a real browser (Debian's headless chromium, WebGL2 on SwiftShader)."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest


@pytest.fixture(scope="session")
def web_asset(small_asset, tmp_path_factory):
    """The small real build (keratin film, 480-700 nm), its published pigeon.glb and a viewer page for it."""
    from rockdove.web.viewer import write_viewer

    page = write_viewer(small_asset, small_asset / "pigeon.glb", tmp_path_factory.mktemp("web") / "verify")
    return small_asset, page


def _hue_counts(png: bytes):
    from PIL import Image

    from rockdove.verify.compare import hue_classes

    srgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.float64) / 255.0
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    _, _, cls = hue_classes(linear)
    return int(np.sum(cls == 1)), int(np.sum(cls == 2)), linear


def test_viewer_loads_shows_green_and_purple_and_the_light_turns_them(web_asset):
    from rockdove.web.browser import Browser

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


@pytest.mark.gl
def test_web_host_agrees_with_the_exact_view_angle_reference(web_asset, tmp_path):
    """three.js's KHR_materials_iridescence of pigeon.glb (the web host, lobe view_angle) against the exact film
    colour at cos = |N.V| times the mask (the same pixels' N.V, thickness and mask from our GL renderer in its
    |N.V| mode): linear float, background 0, green and purple, hue classes and dE2000 close."""
    from rockdove.hosts import web
    from rockdove.render.gl import GLRenderer
    from rockdove.render.scene import load_scene
    from rockdove.render.views import default_views
    from rockdove.verify import compare as cmp
    from rockdove.verify.reference_image import structural_rgb

    asset, _ = web_asset
    scene = load_scene(asset)
    view = [v for v in default_views(scene, 96, 96, n=2) if v.name.startswith("sweep_")][0]
    rgb = web.HOST.render(str(asset), [view], str(tmp_path))[view.name]
    assert rgb.shape == (96, 96, 3) and rgb.dtype == np.float32
    assert np.all(rgb[0, 0] == 0)  # background 0
    assert (tmp_path / f"web_{view.name}.png").is_file()
    with GLRenderer(scene, angle_mode="materialx_baked", width=96, height=96) as r:
        g = r.render(view)
    tips = cmp.erode((g.part_id == scene.part_id("NeckFeathers")) & (g.mask >= 0.5), 1)
    ref = np.zeros_like(rgb)
    ref[tips] = structural_rgb(g.cos_theta[tips].astype(np.float64), g.thickness_nm[tips].astype(np.float64),
                               scene.film) * g.mask[tips][:, None]
    _, _, web_cls = cmp.hue_classes(rgb[tips])
    _, _, ref_cls = cmp.hue_classes(ref[tips])
    assert np.sum(web_cls == 1) > 10 and np.sum(web_cls == 2) > 10
    both = (ref_cls == 1) | (ref_cls == 2)
    assert np.mean(web_cls[both] == ref_cls[both]) > 0.9
    de = cmp.pixel_de(rgb[tips], ref[tips])[0]
    assert np.median(de) < 6.0, np.median(de)


def test_a_browser_that_cannot_start_is_a_named_host_failure(web_asset, tmp_path):
    from rockdove.hosts import HostError, web
    from rockdove.render.scene import load_scene
    from rockdove.render.views import default_views
    from rockdove.web.browser import Browser

    asset, _ = web_asset
    views = default_views(load_scene(asset), 32, 32, n=1)
    with pytest.raises(HostError, match=r"host 'web': false exited with status 1 \(start\)"):
        web.HOST.render(str(asset), views, str(tmp_path), browser_factory=lambda: Browser(executable="false",
                                                                                   start_timeout_s=20))


def test_viewer_console_is_clean_frames_the_bird_and_its_unlit_side_is_dark_grey(web_asset):
    """No console message at all (three.js's deprecation warnings are warnings, not errors), the start view holds
    the whole bird (no bird pixel on the canvas's edge), and with the light behind the bird its pixels are dark
    grey (ambient), not black, in the LUT and the physical mode."""
    from PIL import Image

    from rockdove.web.browser import Browser

    _, page_path = web_asset
    with Browser() as browser:
        page = browser.open(f"file://{page_path}", 480, 400, timeout_s=120)
        page.evaluate("window.rockdoveReady", timeout_s=120, step="viewer ready")
        height = int(page.evaluate("document.getElementById('view').getBoundingClientRect().height"))
        shots = {}
        for mode in ("lut", "physical", "preview"):
            page.evaluate(f"document.querySelector('input[value={mode}]').click()")
            for azimuth in (0, 180):
                page.evaluate(f"window.rockdoveSetLight({azimuth})")
                shots[mode, azimuth] = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB"),
                                                  np.int32)[:height]
        console = page.console
    assert console == []
    for (mode, azimuth), im in shots.items():
        bird = np.abs(im - im[0, 0]).max(-1) > 6
        ys, xs = np.nonzero(bird)
        assert bird.sum() > 2000, (mode, azimuth)
        inside = ys.min() > 0 and xs.min() > 0 and ys.max() < im.shape[0] - 1 and xs.max() < im.shape[1] - 1
        assert inside, (mode, azimuth)
        assert np.percentile(im[bird].max(-1), 5) > 20, (mode, azimuth)  # dark grey at the darkest, not black


def test_no_build_machine_path_in_the_verify_folder(small_asset, tmp_path):
    """Every file a report ships (the whole verify folder: report, images, the viewer and the web host's page)
    names no folder of this machine, also when the build names the asset by its absolute path."""
    import os
    import subprocess
    import sys

    from conftest import OUTSIDE, copy_asset

    from rockdove.web.viewer import write_viewer

    asset = copy_asset(small_asset, tmp_path / "copy" / "pigeon")
    exe = os.path.join(os.path.dirname(sys.executable), "rockdove")
    p = subprocess.run([exe, "verify", str(asset), "--width", "48", "--height", "48", "--hosts", "glsl,web",
                        "--quiet"], capture_output=True, text=True, cwd=OUTSIDE, timeout=600,
                       env=dict(os.environ, PYOPENGL_PLATFORM="egl"))
    assert p.returncode == 0, p.stderr[-2000:]
    write_viewer(asset, asset / "pigeon.glb", asset / "verify" / "built", asset_name=str(asset / "pigeon.usda"))
    machine = {str(tmp_path), str(OUTSIDE), os.path.dirname(os.path.dirname(__file__)), sys.prefix}
    files = [f for f in (asset / "verify").rglob("*") if f.is_file()]
    assert len(files) > 20 and any(f.name == "viewer_data.js" for f in files)
    for f in files:
        data = f.read_bytes()
        for path in machine:
            assert path.encode() not in data, (f, path)
    report = json.loads((asset / "verify" / "report.json").read_text())
    assert report["asset"] == "pigeon.usda" and report["out_dir"] == "verify"

"""The viewer's film panel and its API ``window.rockdove`` in a real browser (headless Chromium, SwiftShader): the
page's LUT against rockdove.lut and the exact reference, the round trip through the printed build command, bad
films, and ``rockdove verify`` writing the viewer."""

from __future__ import annotations

import base64
import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import OUTSIDE, copy_asset

#: The page's result with ``rgb`` as base64 (a Float32Array does not cross the DevTools protocol by value).
AS_DATA = """.then(r => {
  const u = new Uint8Array(r.rgb.buffer); let s = '';
  for (let i = 0; i < u.length; i += 0x8000) { s += String.fromCharCode.apply(null, u.subarray(i, i + 0x8000)); }
  return Object.assign({}, r, {rgb: btoa(s)});
})"""


def set_film(page, film: dict) -> tuple[np.ndarray, dict]:
    """``window.rockdove.setFilm(film)``: the LUT (thicknesses, angles, 3) and the rest of the result."""
    r = page.evaluate(f"window.rockdove.setFilm({json.dumps(film)}){AS_DATA}", timeout_s=120, step="setFilm")
    rgb = np.frombuffer(base64.b64decode(r.pop("rgb")), np.float32).reshape(r["thicknesses"], r["angles"], 3)
    return rgb, r


@pytest.fixture(scope="module")
def viewer(small_asset, tmp_path_factory):
    """The small measured asset's viewer page, open in one browser for the module's tests."""
    from rockdove.web.browser import Browser
    from rockdove.web.viewer import write_viewer

    page_path = write_viewer(small_asset, small_asset / "pigeon.glb", tmp_path_factory.mktemp("film") / "verify")
    with Browser() as browser:
        page = browser.open(Path(page_path).as_uri(), 640, 480, timeout_s=120)
        page.evaluate("window.rockdoveReady", timeout_s=120, step="viewer ready")
        yield page


#: Films over the schema's ranges the three routes of film_bake.js take: dispersive (quadrature), absorbing with a
#: substrate (complex), non-dispersive on a substrate (Fourier), total internal reflection (complex, k = 0).
FILMS = [
    {"cauchy_a": 1.45, "cauchy_b_nm2": 12000.0, "k": 0.0, "n_substrate": 1.0, "base_nm": [100, 300],
     "top_nm": [1500, 2000]},
    {"cauchy_a": 1.8, "cauchy_b_nm2": 3000.0, "k": 0.05, "n_substrate": 1.6, "base_nm": [200, 600],
     "top_nm": [800, 1200]},
    {"cauchy_a": 2.2, "cauchy_b_nm2": 0.0, "k": 0.0, "n_substrate": 1.4, "base_nm": [300, 500], "top_nm": [700, 900]},
    {"cauchy_a": 1.3, "cauchy_b_nm2": 2000.0, "k": 0.0, "n_incident": 1.5, "n_substrate": 2.0,
     "base_nm": [400, 600], "top_nm": [600, 800]},
]


@pytest.mark.parametrize("film", FILMS, ids=["dispersive", "absorbing", "fourier", "tir"])
def test_page_lut_is_rockdove_lut_and_the_exact_reference(viewer, film):
    """Every texel of the page's LUT against rockdove.lut's bake of the same film and grid, and against the exact
    0.1 nm reference: max dE2000 <= 0.1 (measured: <= 0.02)."""
    from rockdove.films import FilmModel
    from rockdove.lut import bake
    from rockdove.lut.reference import delta_E, reference_colour

    rgb, r = set_film(viewer, film)
    full = {"n_incident": 1.0, **viewer.evaluate("window.rockdove.film()")}
    model = FilmModel("page", **{k: full[k] for k in ("cauchy_a", "cauchy_b_nm2", "k", "n_incident", "n_substrate")})
    assert full["base_nm"] == film["base_nm"] and r["colourSpace"] == "lin_rec709" and r["ms"] > 0
    lut = bake(film=model, angles=r["angles"], thicknesses=r["thicknesses"], thickness_range=r["thicknessRangeNm"],
               angle_warp_gamma=r["angleWarpGamma"])
    assert rgb.shape == lut.rgb.shape and lut.thickness_range_nm == tuple(r["thicknessRangeNm"])
    cos, d = np.meshgrid(lut.cos_theta, lut.thickness_nm)
    ref = reference_colour(cos, d, model)
    assert delta_E(rgb, lut.rgb).max() <= 0.1
    assert delta_E(rgb, ref).max() <= 0.1


def test_bad_films_reject_naming_the_key_and_the_page_keeps_its_film(viewer):
    before = viewer.evaluate("window.rockdove.film()")
    command = viewer.evaluate("window.rockdove.command()")
    for bad, key in [({"k": -1}, "film.k"), ({"cauchy_a": "1.5"}, "film.cauchy_a"), ({"base_nm": [600, 500]}, "base_nm"),
                     ({"top_nm": [100]}, "thickness.top_nm"), ({"n_substrate": 3.5}, "film.n_substrate"),
                     ({"colour": 1}, "colour")]:
        with pytest.raises(Exception, match=key):
            viewer.evaluate(f"window.rockdove.setFilm({json.dumps(bad)})", step="bad film")
    with pytest.raises(Exception, match="film.cauchy_b_nm2"):
        viewer.evaluate("window.rockdove.setFilm({cauchy_b_nm2: NaN})", step="NaN")
    assert viewer.evaluate("window.rockdove.film()") == before
    assert viewer.evaluate("window.rockdove.command()") == command
    assert viewer.errors == []


def test_round_trip_the_printed_command_builds_the_pages_thickness_and_colours(viewer, build_root, tmp_path):
    """A film set in the page, the build of ``window.rockdove.command()`` run as a user would (a shell's words,
    with an output folder): the same thickness on every feather vertex (as the page placed it for the new ranges)
    and the page's LUT, max dE2000 <= 0.1."""
    from rockdove.lut.reference import delta_E
    from rockdove.render.scene import load_scene

    film = {"cauchy_a": 1.6, "cauchy_b_nm2": 3000.0, "k": 0.02, "n_substrate": 1.3, "base_nm": [300, 420],
            "top_nm": [700.5, 900]}
    rgb, r = set_film(viewer, film)
    placed = viewer.evaluate("""(() => {
      const p = window.rockdoveViewer.parts.find((q) => q.feather), u = p.lut.uniforms.u_thickness_range_nm.value;
      const uv1 = p.mesh.geometry.attributes.uv1, n = window.ROCKDOVE_DATA.ramp_texels;
      return Array.from({length: uv1.count}, (_, v) => u.x + (uv1.getX(v) * n - 0.5) / (n - 1) * (u.y - u.x));
    })()""")
    argv = shlex.split(viewer.evaluate("window.rockdove.command()"))
    assert argv[:2] == ["rockdove", "build"] and "thickness.top_nm=[700.5, 900]" in argv
    assert "geometry.card_count=200" in argv and "lut.angles=32" in argv  # the asset's other settings, as built
    exe = os.path.join(os.path.dirname(sys.executable), "rockdove")
    out = tmp_path / "pigeon"
    p = subprocess.run([exe, *argv[1:], "--out", str(out), "--cache", str(build_root / "cache"), "--no-verify",
                        "--quiet"], capture_output=True, text=True, cwd=OUTSIDE, timeout=900)
    assert p.returncode == 0, p.stderr[-2000:]
    scene = load_scene(out)
    built = [q for q in scene.parts if q.is_feather][0].thickness_nm
    assert np.abs(np.asarray(placed) - built).max() < 1e-3
    lut = scene.load_lut()
    assert lut.thickness_range_nm == tuple(r["thicknessRangeNm"]) and lut.rgb.shape == rgb.shape
    assert delta_E(rgb, lut.rgb).max() <= 0.1


def test_the_asset_records_its_field_and_it_places_its_thickness(small_asset):
    """The feathers' ``thicknessField`` placed with the ranges the asset records gives its thickness primvar."""
    from pxr import Sdf

    from rockdove.geometry.thickness import place_thickness_nm
    from rockdove.render.scene import load_scene
    from rockdove.usd.stage import BUILD_CONFIG_KEY, LOOKS_LAYER

    scene = load_scene(small_asset)
    part = [q for q in scene.parts if q.is_feather][0]
    config = json.loads(Sdf.Layer.FindOrOpen(str(small_asset / LOOKS_LAYER)).customLayerData[BUILD_CONFIG_KEY])
    d = place_thickness_nm(part.thickness_field.astype(np.float64), config["thickness"]["base_nm"],
                           config["thickness"]["top_nm"])
    assert np.abs(d - part.thickness_nm).max() < 1e-3 and np.ptp(part.thickness_nm) > 50


def test_verify_writes_the_viewer_beside_its_report_when_the_asset_has_its_glb(small_asset, tmp_path):
    from rockdove import api

    asset = copy_asset(small_asset, tmp_path / "pigeon")
    api.verify(asset, ["glsl"], width=32, height=32, n_views=1, beauty={"renderer": "off"})
    assert (asset / "verify" / "viewer.html").is_file() and (asset / "verify" / "film_panel.js").is_file()
    assert "viewer.html" in (asset / "verify" / "report.html").read_text()
    (asset / "pigeon.glb").unlink()
    api.verify(asset, ["glsl"], out=tmp_path / "report", width=32, height=32, n_views=1, beauty={"renderer": "off"})
    assert (tmp_path / "report" / "report.html").is_file() and not (tmp_path / "report" / "viewer.html").exists()


def test_an_asset_without_a_valid_record_edits_its_index_only_and_quotes_what_it_prints(small_asset, tmp_path):
    """A looks layer whose recorded configuration is not a valid one (here: a negative card count) is ignored: the
    panel starts from the film the USD records, its ranges cannot change (they reject, saying why) and the index
    can. ``command()`` quotes each word for a shell, also a hostile value put into the page's data."""
    from pxr import Sdf

    from rockdove.render.scene import load_scene
    from rockdove.usd.stage import BUILD_CONFIG_KEY, LOOKS_LAYER
    from rockdove.web.browser import Browser
    from rockdove.web.viewer import write_viewer

    asset = copy_asset(small_asset, tmp_path / "pigeon")
    looks = Sdf.Layer.FindOrOpen(str(asset / LOOKS_LAYER))
    looks.customLayerData = {BUILD_CONFIG_KEY: json.dumps({"geometry": {"card_count": -5}})}
    looks.Save()
    page_path = Path(write_viewer(asset, asset / "pigeon.glb", tmp_path / "verify"))
    data = page_path.with_name("viewer_data.js")
    hostile = "x'; touch pwned #"
    data.write_text(data.read_text().replace('"sets": []', f'"sets": [["geometry.seed", {json.dumps(hostile)}]]'))
    with Browser() as browser:
        page = browser.open(page_path.as_uri(), 480, 360, timeout_s=120)
        page.evaluate("window.rockdoveReady", timeout_s=120)
        film = page.evaluate("window.rockdove.film()")
        with pytest.raises(Exception, match="base_nm.*records no thickness field"):
            page.evaluate("window.rockdove.setFilm({base_nm: [500, 600]})")
        rgb, r = set_film(page, {"cauchy_a": 1.6})
        words = shlex.split(page.evaluate("window.rockdove.command()"))
        assert page.errors == []
    assert film["cauchy_a"] == 1.532 and film["base_nm"] is None and film["top_nm"] is None
    lut = load_scene(asset).load_lut()  # the ranges stay: the asset's own thickness, its LUT's range and size
    assert tuple(r["thicknessRangeNm"]) == lut.thickness_range_nm and rgb.shape == lut.rgb.shape
    assert words[-2:] == ["--set", f"geometry.seed={hostile}"] and "film.cauchy_a=1.6" in words
    assert not any(w.startswith("thickness.") for w in words)

"""End-to-end tests of ``rockdove verify`` on the session's small real builds, and of the boundary measure on rendered
scenes with uniform and graded film thickness."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import OUTSIDE, copy_asset, real_build
from PIL import Image

from rockdove.films import FilmModel
from rockdove.render.film import ThinFilmParams
from rockdove.render.scene import RenderScene, ScenePart
from rockdove.render.views import light_sweep_views
from rockdove.usd.stage import LOOKS_LAYER
from rockdove.verify import boundary
from rockdove.verify import compare as cmp
from rockdove.verify.reference_image import render_reference

PAPER_FILM = dict(model=FilmModel("paper", cauchy_a=1.5), thickness_primvar="thickness", thickness_units="nm",
                  lut_file="unused.exr", lut_colour_space="lin_rec709", angle_warp_gamma=1.0,
                  thickness_range_nm=(480.0, 700.0))


def _rockdove(*args, timeout=300):
    env = dict(os.environ, PYOPENGL_PLATFORM="egl")
    exe = os.path.join(os.path.dirname(sys.executable), "rockdove")
    return subprocess.run([exe, *args], capture_output=True, text=True, cwd=OUTSIDE, env=env, timeout=timeout)


@pytest.fixture(scope="module")
def assets(paper_asset, small_asset, tmp_path_factory):
    """The small real paper-preset build, and a copy of the measured one whose LUT (same header: film, range,
    warp) holds a gradient, not the film's colour: R = the angle node coordinate, G = the thickness one."""
    import dataclasses

    from rockdove.lut.exr import read_exr, write_exr

    base = tmp_path_factory.mktemp("verify")
    wrong = copy_asset(small_asset, base / "wrong_lut")
    exr = wrong / "textures" / "thinfilm_lut.exr"
    lut = read_exr(exr)
    rgb = np.zeros_like(lut.rgb)
    rgb[..., 0] = np.linspace(0.0, 1.0, lut.n_angle)[None, :]
    rgb[..., 1] = np.linspace(0.0, 1.0, lut.n_thickness)[:, None]
    rgb[..., 2] = 0.25
    os.chmod(exr, 0o644)
    write_exr(dataclasses.replace(lut, rgb=rgb), exr)
    return {"good": str(paper_asset / "pigeon.usda"), "wrong": str(wrong), "base": base}


@pytest.mark.gl
def test_verify_passes_on_a_small_built_asset_and_writes_the_report(assets):
    out = assets["base"] / "report_good"
    p = _rockdove("verify", os.path.dirname(assets["good"]), "--out", str(out), "--width", "96", "--height", "96",
                  "--json", "--hosts", "glsl")  # the other hosts: tests/test_hosts.py
    assert p.returncode == 0, (p.stdout, p.stderr)
    assert "NaN" not in p.stdout  # strict JSON
    summary = json.loads(p.stdout)
    assert summary["passed"] and summary["validation"]
    assert set(summary["views"]) >= {"sweep_060", "sweep_120", "sweep_090"}
    for name, v in summary["views"].items():
        assert v["n_pixels"] > 0 and v["de_median"] <= cmp.MEDIAN_DE_GOAL and v["de_p95"] <= cmp.P95_DE_GOAL, name
    assert summary["hue_sweep"]["green"] > 0 and summary["hue_sweep"]["purple"] > 0
    assert set(summary["boundary_shape"]) == {"sweep_060", "sweep_120", "sweep_090"}
    report = json.loads((out / "report.json").read_text())
    assert report["versions"]["numpy"] == np.__version__ and report["timings_s"]["reference"] > 0
    assert report["film"]["cauchy_a"] == pytest.approx(1.5) and report["lut"]["shape"][0] == 1  # paper: 1-D LUT
    html = (out / "report.html").read_text()
    for name in ("sweep_060_gl.png", "sweep_060_reference.png", "sweep_060_dE.png", "contact_sheet.png",
                 "lut.png", "spectra.png", "hue.png"):
        assert (out / name).is_file() and name in html, name
    assert Image.open(out / "sweep_060_gl.png").size == (96, 96)


@pytest.mark.gl
def test_verify_fails_with_exit_1_when_the_lut_is_not_the_film(assets):
    out = assets["base"] / "report_wrong"
    p = _rockdove("verify", assets["wrong"], "--out", str(out), "--width", "48", "--height", "48", "--hosts", "glsl")
    assert p.returncode == 1, (p.stdout, p.stderr)
    assert "dE2000" in p.stderr and "failed" in p.stderr
    report = json.loads((out / "report.json").read_text())
    assert not report["passed"] and any("median dE2000" in f for f in report["failures"])


ABSORBING_K = 0.05  # film index 1.5 + 0.05 i: the wave through a 650 nm film loses about 80 % at 550 nm


@pytest.fixture(scope="module")
def absorbing(build_root):
    """A small paper-preset build whose film absorbs (k = 0.05): LUT, schema and verification all carry k."""
    return str(real_build(build_root / "absorbing" / "pigeon", build_root / "cache", f"film.k={ABSORBING_K}",
                          preset="paper") / "pigeon.usda")


@pytest.mark.gl
def test_an_absorbing_film_builds_records_k_and_verifies(absorbing, tmp_path):
    from rockdove.films import FilmModel
    from rockdove.lut.reference import reference_colour
    from rockdove.render.scene import load_scene

    assert load_scene(absorbing).film.model.k == pytest.approx(ABSORBING_K)
    # k changes the colour: otherwise this test could not tell a film that carries k from one that drops it
    clear = reference_colour(0.7, 650.0, FilmModel("paper", cauchy_a=1.5), colour_space="lin_rec709")
    absorbed = reference_colour(0.7, 650.0, FilmModel("paper", cauchy_a=1.5, k=ABSORBING_K),
                                colour_space="lin_rec709")
    assert np.abs(np.asarray(clear) - np.asarray(absorbed)).max() > 0.02
    p = _rockdove("verify", os.path.dirname(absorbing), "--out", str(tmp_path / "r"), "--width", "96", "--height",
                  "96", "--json")
    assert p.returncode == 0, (p.stdout, p.stderr)
    report = json.loads((tmp_path / "r" / "report.json").read_text())
    assert report["passed"] and report["film"]["k"] == pytest.approx(ABSORBING_K)


def test_a_schema_that_drops_k_disagrees_with_the_lut_it_records(absorbing, tmp_path):
    import shutil

    from pxr import Sdf

    from rockdove.usd.validate import validate_asset

    out = tmp_path / "pigeon"
    shutil.copytree(os.path.dirname(absorbing), out)
    layer = Sdf.Layer.FindOrOpen(str(out / LOOKS_LAYER))  # the film record's layer
    layer.GetAttributeAtPath("/Pigeon/Geom/NeckFeathers.rockdove:film:k").default = 0.0
    layer.Save()
    issues = [i for i in validate_asset(str(out)).errors if i.check == "thinFilm"]
    assert [i.path for i in issues] == ["/Pigeon/Geom/NeckFeathers.rockdove:film:k"], issues
    assert "differs from the LUT file's film:k = '0.05'" in issues[0].message


def test_verify_bad_usage_exits_2(tmp_path):
    p = _rockdove("verify", str(tmp_path / "no_such_asset"))
    assert p.returncode == 2 and "no_such_asset" in p.stderr and "Traceback" not in p.stderr
    p = _rockdove("verify", str(tmp_path), "--width", "3")
    assert p.returncode == 2 and "--width" in p.stderr


def _plane_scene(tmp_path, thickness_fn, light, n=16, size_m=0.08):
    """An opaque feather plane (no mask texture: structural everywhere) through the origin, facing the half
    vector of the camera direction +Z and ``light``, so it is lit at N.L = N.V; thickness per vertex."""
    Image.fromarray(np.full((4, 4, 4), 255, np.uint8), "RGBA").save(tmp_path / "white.png")
    h = np.array([0.0, 0.0, 1.0]) + light
    nrm = h / np.linalg.norm(h)
    u = np.cross([0.0, 1.0, 0.0], nrm)
    s, t = (g.ravel() for g in np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1)))
    pts = ((s[:, None] - 0.5) * u + (t[:, None] - 0.5) * np.array([0.0, 1.0, 0.0])) * size_m
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int32)
    part = ScenePart("NeckFeathers", "/Pigeon/Geom/NeckFeathers", "feather", pts.astype(np.float32),
                     np.tile(nrm, (len(pts), 1)).astype(np.float32), tris, np.stack([s, t], 1).astype(np.float32),
                     thickness_nm=thickness_fn(s, t).astype(np.float32),
                     base_colour_texture=str(tmp_path / "white.png"))
    return RenderScene(str(tmp_path / "plane.usda"), (part,), ThinFilmParams(**PAPER_FILM), {})


def test_boundary_is_straight_for_uniform_thickness_and_bends_for_a_gradient(tmp_path):
    """The paper's observation, rendered: at the 90 degree light sweep the green/purple boundary of a 650 nm
    film is a straight line (the pixels where L.V is constant lie on a plane through the eye); a thickness that
    varies across the neck bends it."""
    view = light_sweep_views((0, 0, 0), 1, 64, 64, angles_deg=[90.0], distance_m=0.12, camera_direction=(0, 0, 1))[0]
    results = {}
    for name, fn in (("uniform", lambda s, t: np.full_like(s, 650.0)),
                     ("graded", lambda s, t: 560.0 + 120.0 * (2 * t - 1) ** 2),
                     ("bent", lambda s, t: 650.0 + 60.0 * (t - 0.67 + 0.35 * (2 * s - 1) ** 2))):
        ref = render_reference(_plane_scene(tmp_path, fn, view.light_direction), [view])[0]
        feather = ref.part_id == 1
        cls = np.full(feather.shape, -1, np.int8)
        cls[feather] = cmp.hue_classes(ref.rgb[feather].astype(np.float64), sides=True)[2]
        assert (cls == 1).sum() > 50 and (cls == 2).sum() > 50, name  # both hues on the plane
        results[name] = boundary.boundary_straightness(cls), boundary.boundary_curvature(cls)
    (uniform, uniform_curve), (graded, _), (_, bent_curve) = results["uniform"], results["graded"], results["bent"]
    assert uniform.n_centreline >= 20 and graded.n_centreline >= 8
    # issue 12's curvature measure: the cubic fits the uniform film's boundary no better than a line
    assert uniform_curve.ratio < 1.5
    assert bent_curve.ratio >= boundary.CURVED_RATIO  # one parabolic iso-thickness line
    assert uniform.rms_px < 0.5
    assert graded.rms_px > 1.5
    assert graded.rms_fraction > 0.02 > 5 * uniform.rms_fraction


FAKE_HOST = """
import numpy as np
from rockdove.hosts import Host
GREY = 0.25
CALLS = []
class Fake(Host):
    def render(self, asset_path, views, out_dir):
        CALLS.append([v.name for v in views])
        return {v.name: np.full((v.height, v.width, 3), GREY, np.float32) for v in views}
HOST = Fake("fake", "physical", "view_angle")
"""


@pytest.mark.gl
def test_one_verification_reuses_what_it_checked_and_reruns_a_host_whose_code_changed(assets, tmp_path,
                                                                                      monkeypatch):
    """The build's verification and ``rockdove verify`` are one function with one cache: a second run renders
    nothing and gives the same numbers; an edit to the code a host runs re-renders that host alone; a subset of
    views without a light-sweep view says the hue check did not run rather than passing it silently."""
    import importlib

    from rockdove import hosts
    from rockdove.verify.results import ItemNames
    from rockdove.verify.verification import verify

    (tmp_path / "fake_host.py").write_text(FAKE_HOST)
    monkeypatch.syspath_prepend(str(tmp_path))
    fake = importlib.import_module("fake_host")
    monkeypatch.setitem(hosts.HOSTS, "fake", fake.HOST)
    layer, cache, names = assets["good"], tmp_path / "cache", ["turntable_030", "sweep_090"]

    def run(out, views=names):
        return verify(layer, ["glsl", "fake"], cache=cache, out_dir=tmp_path / out, width=96, height=96,
                      views=views, beauty={"renderer": "off"})

    first = run("first")
    assert first.cache.ran.views == tuple(names) and first.cache.ran.hosts == ("glsl", "fake")
    assert len(fake.CALLS) == 1 and first.passed is False  # a grey bird has no green nor purple
    second = run("second")
    assert second.cache.ran == ItemNames() and len(fake.CALLS) == 1
    assert second.views == first.views and second.hosts == first.hosts
    assert second.hue_sweep == first.hue_sweep and second.boundary == first.boundary
    assert second.views_reused == tuple(names) and second.failures == first.failures
    assert second.to_json()["hosts"] == first.to_json()["hosts"]  # as report.json records them
    for f in ("sweep_090_gl.png", "sweep_090_dE.png", "sweep_090_fake.png", "sweep_090_view_angle_reference.png"):
        assert (tmp_path / "second" / f).is_file(), f
    assert [n[:22] for n in second.notes] == ["boundary at sweep_090:"]  # the closing note, nothing else
    (tmp_path / "fake_host.py").write_text(FAKE_HOST.replace("GREY = 0.25", "GREY = 0.5"))  # what fake runs
    third = run("third")
    assert third.cache.ran == ItemNames(hosts=("fake",)) and len(fake.CALLS) == 2
    only_turntable = run("tt", ["turntable_030"])
    assert any(n.startswith("hue check not run") for n in only_turntable.notes)
    assert "Notes" in (tmp_path / "tt" / "report.html").read_text()
    with pytest.raises(ValueError, match="views=.*sweep_999.*allowed names"):
        run("x", ["sweep_999"])


@pytest.mark.gl
def test_an_image_that_cannot_be_written_fails_the_views_it_belongs_to(assets, tmp_path, monkeypatch):
    """The per-view images are written in a background thread; a write that fails is raised from the
    verification, not lost with the thread."""
    from rockdove import png
    from rockdove.verify.verification import verify

    real = png.save_png

    def full_disk(image, path):
        if str(path).endswith("_gl.png"):
            raise OSError(28, "No space left on device", str(path))
        return real(image, path)

    monkeypatch.setattr(png, "save_png", full_disk)
    with pytest.raises(OSError, match="No space left"):
        verify(assets["good"], cache=tmp_path / "cache", views=["turntable_030"], out_dir=tmp_path / "x", width=48,
               height=48)


@pytest.mark.gl
def test_physical_only_asset_is_verified_with_a_verification_only_lut_and_says_so(physical_asset, tmp_path):
    asset = str(physical_asset)
    out = tmp_path / "report"
    p = _rockdove("verify", asset, "--out", str(out), "--width", "64", "--height", "64", "--quiet",
                  "--hosts", "glsl")
    assert p.returncode == 0, (p.stdout, p.stderr)
    assert "note: physical-only asset (no LUT)" in p.stdout and "verification-only LUT" in p.stdout
    report = json.loads((out / "report.json").read_text())
    assert report["passed"] and len(report["views"]) == 6 and all(m["n_pixels"] > 0 for m in report["views"][2:])
    assert len(report["notes"]) == 2 and "verification-only LUT" in report["notes"][0]
    assert report["notes"][1].startswith("boundary at sweep_090:")  # the closing note on the pattern
    # measured film: the thickness varies, so the verification-only LUT has a thickness axis
    assert report["lut"]["verification_only"] and report["lut"]["shape"][0] > 1 and report["lut"]["shape"][1] == 256
    assert report["variants"] == {"shading": "physical", "motion": "rest"} and report["film"]["lut_file"] is None
    assert not os.path.exists(os.path.join(asset, "textures", "thinfilm_lut.exr"))  # nothing added
    assert "verification-only LUT" in (out / "report.html").read_text()

"""The pyrender/GLSL renderer (rockdove.render.gl), checked against the shading formula of docs/design.md
evaluated on the CPU from the LUT at each pixel's interpolated inputs.

The formula checks need a scene whose geometry is known in closed form (a card facing the camera at a known
distance, a thickness that runs linearly up each card) and LUTs chosen to expose lookup errors, so this module
writes a minimal analytic scene with the real authoring functions (rockdove.usd.textures_io.write_base_textures / write_film_textures,
rockdove.usd.stage.write_layers): a UV-sphere body and a ring of square feather cards. The renderer's agreement
with the CPU reference and the ``rockdove render`` command also run on the session's small real build.
"""

import math

import numpy as np
import pytest
from scipy import ndimage

from rockdove.lut import ThinFilmLUT
from rockdove.render import scene as sc
from rockdove.render import texture
from rockdove.render.views import View, default_views, look_at

pytestmark = pytest.mark.gl

SIZE = 96
LIGHT = np.array([0.35, 0.45, 1.0]) / np.linalg.norm([0.35, 0.45, 1.0])
LIGHT_RGB = np.array([1.0, 0.9, 0.8])

# -- the analytic scene, metres ---------------------------------------------------------------------------------
BODY_RADIUS_M = 0.1
BODY_CENTRE_M = (0.0, 0.15, 0.0)
NECK_CENTRE_M = (0.0, 0.28, 0.0)
NECK_RING_RADIUS_M = 0.05
CARD_SIZE_M = 0.045
#: The cards' thickness runs from THICKNESS_RANGE_NM[0] at their base (t = 0) to [1] at their tip (t = 1).
THICKNESS_RANGE_NM = (480.0, 700.0)


def _uv_sphere(radius, centre, n_lon=24, n_lat=12):
    """A UV sphere as quads (degenerate at the poles), vertices split at the seam, counter-clockwise outside."""
    lon = np.linspace(0, 2 * np.pi, n_lon + 1)
    lat = np.linspace(-np.pi / 2, np.pi / 2, n_lat + 1)
    lo, la = np.meshgrid(lon, lat)
    nrm = np.stack([np.cos(la) * np.sin(lo), np.sin(la), np.cos(la) * np.cos(lo)], axis=-1).reshape(-1, 3)
    st = np.stack([lo / (2 * np.pi), (la + np.pi / 2) / np.pi], axis=-1).reshape(-1, 2)
    idx = np.arange((n_lat + 1) * (n_lon + 1)).reshape(n_lat + 1, n_lon + 1)
    quads = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], axis=-1).reshape(-1, 4)
    return nrm * radius + np.asarray(centre), nrm, st, quads


def _ring_of_cards(n_cards):
    """Square cards on a ring around the neck, each facing outward (card 0 faces +Z); thickness base to tip."""
    lo, hi = THICKNESS_RANGE_NM
    pts, nrm, st, thick, neck_s = [], [], [], [], []
    up = np.array([0.0, 1.0, 0.0])
    for k in range(n_cards):
        phi = 2 * np.pi * k / n_cards
        out = np.array([np.sin(phi), 0.0, np.cos(phi)])
        tangent = np.array([np.cos(phi), 0.0, -np.sin(phi)])  # tangent x up = out: counter-clockwise from out
        c = np.asarray(NECK_CENTRE_M) + NECK_RING_RADIUS_M * out
        h = CARD_SIZE_M / 2
        pts += [c - h * tangent - h * up, c + h * tangent - h * up, c + h * tangent + h * up, c - h * tangent + h * up]
        nrm += [out] * 4
        st += [(0, 0), (1, 0), (1, 1), (0, 1)]
        thick += [lo, lo, hi, hi]
        neck_s += [k / max(n_cards - 1, 1)] * 4
    return (np.asarray(pts), np.asarray(nrm), np.asarray(st), np.arange(4 * n_cards).reshape(-1, 4),
            np.asarray(thick, np.float32), np.asarray(neck_s, np.float32))


def _feather_textures(size=64):
    """Base RGBA (grey, alpha = an ellipse) and mask (1 on the tip half, a soft ramp), uint8."""
    yy, xx = np.mgrid[0:size, 0:size]
    u = (xx + 0.5) / size
    t = 1 - (yy + 0.5) / size  # image row 0 is the top, t = 1
    inside = ((u - 0.5) / 0.42) ** 2 + ((t - 0.5) / 0.48) ** 2 <= 1.0
    base = np.zeros((size, size, 4), np.uint8)
    base[..., 0], base[..., 1], base[..., 2] = 110, 100, 105
    base[..., 3] = np.where(inside, 255, 0)
    mask = (np.clip((t - 0.35) / 0.2, 0, 1) * 255).astype(np.uint8)
    return base, mask


def write_analytic_asset(out_dir, lut, n_cards=6) -> str:
    """Write the analytic scene as an asset with the real authoring functions; return its root layer."""
    from rockdove import __version__
    from rockdove.films import get_film
    from rockdove.geometry import Bird, MeshPart, Primvar
    from rockdove.usd.material import lut_info
    from rockdove.usd.stage import write_layers
    from rockdove.usd.textures_io import write_base_textures, write_film_textures

    f32, i32 = np.float32, np.int32
    spts, snrm, sst, squads = _uv_sphere(BODY_RADIUS_M, BODY_CENTRE_M)
    body = MeshPart("Body", spts.astype(f32), np.full(len(squads), 4, i32), squads.ravel().astype(i32),
                    snrm.astype(f32), sst.astype(f32), "body", (0.3, 0.3, 0.35))
    cpts, cnrm, cst, cquads, thick, neck_s = _ring_of_cards(n_cards)
    feathers = MeshPart("NeckFeathers", cpts.astype(f32), np.full(n_cards, 4, i32), cquads.ravel().astype(i32),
                        cnrm.astype(f32), cst.astype(f32), "feather", (0.4, 0.38, 0.4),
                        {"thickness": Primvar(thick, "vertex", "film thickness, nm"),
                         "neckS": Primvar(neck_s, "vertex", "position along the neck band, 0 (base) to 1")})
    base, mask = _feather_textures()
    yy, xx = np.mgrid[0:32, 0:64]
    body_rgb = np.stack([90 + 40 * (xx % 16 < 8), 95 + 0 * xx, 110 + 30 * (yy % 8 < 4)], axis=-1).astype(np.uint8)
    out_dir = str(out_dir)
    write_base_textures(out_dir, {"base": base, "mask": mask}, body_rgb)
    write_film_textures(out_dir, lut, {"base": base, "mask": mask}, thickness_range_nm=THICKNESS_RANGE_NM)
    return write_layers(out_dir, Bird((body, feathers)), get_film("paper"), lut_info(lut),
                        version=__version__)["interface"]


def _coarse_lut():
    """5 angle x 4 thickness nodes of unrelated values, warped angle axis: an axis swap, a missing texel-centre
    offset or a wrong warp changes the lookup by ~0.1 or more."""
    rng = np.random.default_rng(7)
    rgb = rng.uniform(0.1, 0.9, size=(4, 5, 3)).astype(np.float32)
    return ThinFilmLUT(rgb, THICKNESS_RANGE_NM, angle_warp_gamma=1.7)


def _fine_lut():
    """Steps of 1e-4 along the angle axis (40x finer than 8-bit quantisation)."""
    n = 64
    rgb = np.empty((2, n, 3), np.float32)
    rgb[..., 0] = 0.5 + 1e-4 * np.arange(n)
    rgb[..., 1] = 0.6 - 1e-4 * np.arange(n)
    rgb[0, :, 2], rgb[1, :, 2] = 0.3, 0.3004
    return ThinFilmLUT(rgb, THICKNESS_RANGE_NM, angle_warp_gamma=1.0)


def _front_view(distance_m=0.12, yfov_deg=30.0, light=LIGHT):
    """Camera on +Z looking straight at card 0 (centre NECK + ring radius * Z, facing +Z)."""
    centre = np.asarray(NECK_CENTRE_M) + np.array([0.0, 0.0, NECK_RING_RADIUS_M])
    c2w = look_at(centre + [0.0, 0.0, distance_m], centre)
    return View("front", c2w, math.radians(yfov_deg), SIZE, SIZE, light, LIGHT_RGB), centre


def _pixel_rays(view):
    """Unit world directions from the eye through each pixel centre, (H, W, 3); row 0 at the top (the CPU
    reference's pinhole rays, rockdove.verify.rays.camera_rays)."""
    from rockdove.verify.rays import camera_rays

    return camera_rays(view)[1].reshape(view.height, view.width, 3)


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    """The analytic asset with the coarse LUT, rendered (front view + the default views) by one renderer."""
    from rockdove.render.gl import GLRenderer

    lut = _coarse_lut()
    root = write_analytic_asset(tmp_path_factory.mktemp("coarse"), lut=lut)
    scene = sc.load_scene(root)
    front, centre = _front_view()
    with GLRenderer(scene) as r:
        results = {"front": r.render(front)}
        for v in default_views(scene, SIZE, SIZE):
            results[v.name] = r.render(v)
    return scene, lut, results


def _card0(res, distance_m=0.12):
    """Pixels of card 0 in a front view: its plane lies ``distance_m`` along the view axis (other cards
    show through its discarded corners or beside it)."""
    return np.abs(res.depth_m - distance_m) < 2e-3


def _feather_interior(res, scene, erode=2):
    fid = scene.part_id("NeckFeathers")
    m = res.part_id == fid
    return ndimage.binary_erosion(m, iterations=erode)


def test_renders_are_finite_and_lit_feathers_are_not_black(coarse):
    scene, _, results = coarse
    lit_views = {}
    for name, res in results.items():
        for a in (res.radiance_rgb, res.depth_m, res.cos_theta, res.thickness_nm, res.st):
            assert np.all(np.isfinite(a)), name
        assert res.radiance_rgb.shape == (SIZE, SIZE, 3) and res.radiance_rgb.dtype == np.float32
        assert set(np.unique(res.alpha)) <= {0.0, 1.0}
        np.testing.assert_array_equal(res.alpha > 0, res.part_id > 0)
        assert np.all(res.depth_m[res.part_id > 0] > 0) and np.all(res.depth_m[res.part_id == 0] == 0)
        lit = _feather_interior(res, scene) & (res.n_dot_l > 0.2)
        lit_views[name] = int(lit.sum())
        if lit.any():
            assert res.radiance_rgb[lit].sum(axis=1).min() > 0.02, name
    # every view shows lit feathers (the check above then ran on each), the front view most
    assert lit_views["front"] > 100 and all(n > 20 for n in lit_views.values()), lit_views
    assert _feather_interior(results["front"], scene).sum() > 300
    assert (results["front"].part_id == scene.part_id("Body")).sum() > 100


def test_alpha_discards_outside_the_feather_silhouette(coarse):
    """Front view of card 0: a pixel shows the feather exactly where the base texture's alpha >= 0.5."""
    scene, _, results = coarse
    res = results["front"]
    view = res.view
    rays = _pixel_rays(view)
    eye = view.eye_m
    plane_z = NECK_CENTRE_M[2] + NECK_RING_RADIUS_M
    hit = eye + rays * ((plane_z - eye[2]) / rays[..., 2])[..., None]
    s = (hit[..., 0] - NECK_CENTRE_M[0]) / CARD_SIZE_M + 0.5
    t = (hit[..., 1] - NECK_CENTRE_M[1]) / CARD_SIZE_M + 0.5
    on_card = (s > 0.03) & (s < 0.97) & (t > 0.03) & (t < 0.97)
    base = texture.read_texture(scene.part("NeckFeathers").base_colour_texture, srgb=True)
    alpha = texture.sample_texture(base, np.stack([s, t], axis=-1))[..., 3]
    # card 0 lies in the plane at 0.12 m along the view axis; other cards (behind it) may show through
    feather = (res.part_id == scene.part_id("NeckFeathers")) & _card0(res)
    sure_in = on_card & (alpha > 0.9)
    sure_out = on_card & (alpha < 0.1)
    assert sure_in.sum() > 300 and sure_out.sum() > 50
    assert np.all(feather[sure_in])
    assert not np.any(feather[sure_out])  # discarded: what lies behind card 0 shows through
    np.testing.assert_allclose(res.st[sure_in], np.stack([s, t], axis=-1)[sure_in], atol=2e-3)


def test_feather_colour_matches_the_shading_formula_on_the_cpu(coarse):
    """radiance = mix(base, LUT(dot(L, H), d), mask) * light_rgb * max(N.L, 0), per pixel, 8-bit tolerance."""
    scene, lut, results = coarse
    part = scene.part("NeckFeathers")
    base_img = texture.read_texture(part.base_colour_texture, srgb=True)
    mask_img = texture.read_texture(part.mask_texture, srgb=False)
    lo, hi = THICKNESS_RANGE_NM
    checked = 0
    for name, res in results.items():
        px = _feather_interior(res, scene)
        if not px.any():
            continue
        view = res.view
        V = -_pixel_rays(view)[px]
        L = view.light_direction
        H = (L + V) / np.linalg.norm(L + V, axis=1, keepdims=True)
        cos_theta = H @ L
        np.testing.assert_allclose(res.cos_theta[px], cos_theta, atol=2e-4, err_msg=name)
        st = res.st[px]
        # the cards' thickness runs linearly from lo at t = 0 to hi at t = 1
        np.testing.assert_allclose(res.thickness_nm[px], lo + (hi - lo) * st[:, 1], atol=0.05, err_msg=name)
        base = texture.sample_texture(base_img, st)[:, :3]
        mask = texture.sample_texture(mask_img, st)[:, 0]
        np.testing.assert_allclose(res.mask[px], mask, atol=2e-3, err_msg=name)
        structural = lut.sample(cos_theta, res.thickness_nm[px])
        colour = base + (structural - base) * mask[:, None]
        expected = colour * view.light_rgb * res.n_dot_l[px][:, None]
        np.testing.assert_allclose(res.radiance_rgb[px], expected, atol=3e-3, err_msg=name)
        checked += px.sum()
    assert checked > 1000
    # the structural colour is really in play: masked pixels far from the base colour
    res = results["front"]
    px = _feather_interior(res, scene) & (res.mask > 0.99) & _card0(res)
    assert px.sum() > 50
    # the front card's normal is +Z
    np.testing.assert_allclose(res.n_dot_l[px], max(LIGHT[2], 0), atol=1e-4)


def test_the_lut_texel_mapping_is_not_the_naive_one(coarse):
    """Guards the test above: the naive lookup (u = x, no texel-centre offset) differs measurably here."""
    scene, lut, results = coarse
    res = results["front"]
    px = _feather_interior(res, scene) & (res.mask >= 0.99999)
    x = res.cos_theta[px] ** (1 / lut.angle_warp_gamma)
    y = (res.thickness_nm[px] - THICKNESS_RANGE_NM[0]) / np.ptp(THICKNESS_RANGE_NM)
    # naive: treat texcoord x as a node coordinate of an N-texel image with texel centres
    n, m = lut.n_angle, lut.n_thickness
    naive_fx, naive_fy = x * n - 0.5, y * m - 0.5
    naive = lut.sample((np.clip(naive_fx / (n - 1), 0, 1)) ** lut.angle_warp_gamma,
                       THICKNESS_RANGE_NM[0] + np.clip(naive_fy / (m - 1), 0, 1) * np.ptp(THICKNESS_RANGE_NM))
    correct = lut.sample(res.cos_theta[px], res.thickness_nm[px])
    assert np.abs(naive - correct).max() > 0.02
    gl_structural = res.radiance_rgb[px] / (LIGHT_RGB * res.n_dot_l[px][:, None])
    np.testing.assert_allclose(gl_structural, correct, atol=3e-3)


def test_float_lut_upload_is_not_quantised(tmp_path):
    from rockdove.render.gl import render_views

    lut = _fine_lut()
    scene = sc.load_scene(write_analytic_asset(tmp_path, lut=lut))
    view, _ = _front_view(light=np.array([0.0, 0.0, 1.0]))  # N.L = 1 on the front card
    (res,) = render_views(scene, [view])
    px = _feather_interior(res, scene) & (res.mask >= 0.99999) & _card0(res)
    assert px.sum() > 50
    np.testing.assert_array_equal(res.n_dot_l[px], 1.0)
    structural = res.radiance_rgb[px] / LIGHT_RGB
    expected = lut.sample(res.cos_theta[px], res.thickness_nm[px])
    np.testing.assert_allclose(structural, expected, atol=5e-5)
    # 8-bit storage could not hold these: many distinct values within less than one 8-bit step
    assert np.ptp(structural[:, 0]) < 1 / 255 and len(np.unique(np.round(structural[:, 0], 6))) > 10


def test_materialx_baked_angle_uses_n_dot_v(coarse):
    from rockdove.render.gl import render_views

    scene, lut, results = coarse
    view = results["front"].view
    (res,) = render_views(scene, [view], angle_mode="materialx_baked", lut=lut)
    px = _feather_interior(res, scene) & _card0(res)
    V = -_pixel_rays(view)[px]
    np.testing.assert_allclose(res.cos_theta[px], np.abs(V[:, 2]), atol=2e-4)  # N = +Z
    assert not np.allclose(res.cos_theta[px], results["front"].cos_theta[px], atol=1e-2)
    with pytest.raises(ValueError, match="angle_mode"):
        render_views(scene, [view], angle_mode="nope")


def test_one_renderer_is_reused_across_views(coarse, monkeypatch):
    from rockdove._compat import import_pyrender
    from rockdove.render.gl import render_views

    pyrender = import_pyrender()
    created = []
    real = pyrender.OffscreenRenderer

    class Counting(real):
        def __init__(self, *a, **k):
            created.append(1)
            super().__init__(*a, **k)

    monkeypatch.setattr(pyrender, "OffscreenRenderer", Counting)
    scene, lut, results = coarse
    views = [results["front"].view, results["sweep_060"].view, results["front"].view]
    out = render_views(scene, views, lut=lut)
    assert len(created) == 1
    np.testing.assert_array_equal(out[0].radiance_rgb, out[2].radiance_rgb)
    np.testing.assert_array_equal(out[0].radiance_rgb, results["front"].radiance_rgb)
    assert not np.array_equal(out[0].radiance_rgb, out[1].radiance_rgb)


def test_closing_a_renderer_leaves_the_others_open(coarse):
    """EGL keeps one display per process, and pyrender's own delete() terminates it: a renderer closed (by the GL
    views' thread, a host's, or a leaked one collected) broke every other open one with EGL_BAD_DISPLAY. Ours end
    their own context only, and give the thread back the one it had."""
    import ctypes
    import gc

    from OpenGL import EGL

    from rockdove.render.gl import GLRenderer, offscreen_renderer

    address = lambda p: ctypes.cast(p, ctypes.c_void_p).value  # noqa: E731

    scene, lut, results = coarse
    view = results["front"].view
    with GLRenderer(scene, lut=lut, width=view.width, height=view.height) as kept:
        before = kept.render(view).radiance_rgb
        GLRenderer(scene, lut=lut, width=view.width, height=view.height).delete()
        offscreen_renderer(8, 8).delete()  # what the MaterialX GL host opens and closes
        np.testing.assert_array_equal(kept.render(view).radiance_rgb, before)
        left_open = GLRenderer(scene, lut=lut, width=view.width, height=view.height)
        del left_open  # not closed: the garbage collector deletes it, at any time, e.g. in the middle of a draw:
        kept._offscreen._platform.make_current()
        gc.collect()
        assert address(EGL.eglGetCurrentContext()) == address(kept._offscreen._platform._egl_context)


def test_render_cli_writes_pngs_and_exit_codes(small_asset, tmp_path, capsys):
    """``rockdove render`` on the small real build."""
    from PIL import Image

    from rockdove.cli import main

    scene = sc.load_scene(small_asset)
    out = tmp_path / "renders"
    assert main(["render", scene.root_layer, "--out", str(out), "--width", "48", "--height", "40", "--views", "3"]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == [".rockdove-output.json", "contact_sheet.png", "sweep_090.png", "turntable_030.png",
                     "turntable_210.png"]  # the marker: a folder rockdove made, so a later render may write again
    with Image.open(out / "sweep_090.png") as im:
        assert im.size == (48, 40)
    printed = capsys.readouterr().out
    assert "contact_sheet.png" in printed and "render 3 views" in printed
    assert main(["render", str(tmp_path / "missing"), "--out", str(out)]) == 2
    assert main(["render", scene.root_layer, "--out", str(out), "--views", "0"]) == 2
    assert main(["render", scene.root_layer, "--out", str(out), "--shading", "nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(line.startswith("rockdove render: error:") for line in err)


def test_gl_agrees_with_the_cpu_ray_cast_given_the_same_lut(coarse):
    """Same scene, views and LUT: pyrender and the CPU reference (rockdove.verify.reference_image, trimesh rays) must
    agree pixel for pixel; catches camera, row-order, texture-origin or normal conventions drifting apart."""
    from rockdove.verify.reference_image import render_reference

    scene, lut, results = coarse
    gl = [results[k] for k in ("front", "turntable_030", "sweep_060", "sweep_120")]
    ref = render_reference(scene, [r.view for r in gl], structural_fn=lambda c, d: lut.sample(c, d))
    for g, r in zip(gl, ref):
        assert (g.part_id == r.part_id).mean() > 0.995, g.view.name
        inner = ndimage.binary_erosion((g.part_id == r.part_id) & (g.part_id > 0), iterations=1)
        assert inner.sum() > 500
        diff = np.abs(g.radiance_rgb - r.rgb)[inner]
        assert np.percentile(diff, 99.5) < 1e-4, g.view.name
        np.testing.assert_allclose(g.depth_m[inner], r.depth_m[inner], rtol=1e-4)


def test_gl_agrees_with_the_cpu_ray_cast_on_the_real_asset(small_asset):
    """The same agreement on the small real build, with its own LUT: every part (body, wings, beak, eyes, legs,
    bent and lifted feather cards), both renderers' default views."""
    from rockdove.render.gl import render_views
    from rockdove.verify.reference_image import render_reference

    scene = sc.load_scene(small_asset)
    lut = scene.load_lut()
    views = default_views(scene, SIZE, SIZE)
    gl = render_views(scene, views)
    ref = render_reference(scene, views, structural_fn=lambda c, d: lut.sample(c, d))
    for g, r in zip(gl, ref):
        assert (g.part_id == r.part_id).mean() > 0.995, g.view.name
        inner = ndimage.binary_erosion((g.part_id == r.part_id) & (g.part_id > 0), iterations=1)
        feathers = inner & (g.part_id == scene.part_id("NeckFeathers"))
        assert inner.sum() > 500 and feathers.sum() > 20, g.view.name
        diff = np.abs(g.radiance_rgb - r.rgb)[inner]
        assert np.percentile(diff, 99.5) < 1e-4, (g.view.name, np.percentile(diff, 99.5))
        assert np.percentile(np.abs(g.radiance_rgb - r.rgb)[feathers], 95) < 1e-4, g.view.name


def test_parts_that_tie_in_depth_show_the_first_part_in_scene_order():
    """Two parts with the same quad: depth ties everywhere, and the part drawn first wins (GL_LESS). The renderer
    draws in scene order, so the first part shows, whichever it is (pyrender's own order comes from a set)."""
    from rockdove.render.gl import GLRenderer

    quad = np.array([[-0.05, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.05, 0.05, 0.0]], np.float32)

    def part(name):
        return sc.ScenePart(name, f"/{name}", "body", quad, np.tile([0.0, 0.0, 1.0], (4, 1)).astype(np.float32),
                            np.array([[0, 1, 2], [0, 2, 3]], np.int32), np.zeros((4, 2), np.float32))

    view = View("v", look_at([0.0, 0.0, 0.3], [0.0, 0.0, 0.0]), 0.6, 32, 32, [0, 0, 1], [1, 1, 1])
    for names in (("A", "B"), ("B", "A"), ("C", "D", "E")):
        with GLRenderer(sc.RenderScene("x.usda", tuple(map(part, names)), None, {})) as r:
            ids = r.render(view).part_id
        assert (ids > 0).sum() > 100 and set(np.unique(ids[ids > 0])) == {1}, names


def test_multisampled_pictures_antialias_the_alpha_cut_out_by_coverage(coarse):
    """Pictures (``samples=4``: multisampling with alpha-to-coverage) draw the card's alpha-cut ellipse close to
    16 samples a pixel of the discard path (a 4x render box-filtered); one sample a pixel, or multisampling with a
    per-pixel discard, would leave the stair steps: at the ellipse's edge the picture is nearer the truth by half.
    The single-sample path the verification compares stays binary (test_renders_are_finite_...)."""
    import dataclasses

    from rockdove.render.gl import GLRenderer
    from rockdove.render.images import box_downsample

    scene, lut, results = coarse
    front = results["front"].view
    with GLRenderer(scene, lut=lut) as r:
        one, four = r.render(front), r.render(front, samples=4)
        big = r.render(dataclasses.replace(front, width=4 * SIZE, height=4 * SIZE))
    truth = box_downsample(big.radiance_rgb, 4)
    card = box_downsample((np.abs(big.depth_m - 0.12) < 2e-3).astype(np.float32), 4)  # card 0's share of a pixel
    edge = (card > 0.1) & (card < 0.9)
    assert edge.sum() > 60 and ((four.alpha > 0) & (four.alpha < 1)).sum() > 20
    err_one, err_four = (np.abs(x.radiance_rgb - truth)[edge].mean() for x in (one, four))
    assert err_four < 0.5 * err_one, (err_four, err_one)
    inside = card == 1
    np.testing.assert_allclose(four.radiance_rgb[inside], one.radiance_rgb[inside], atol=2e-3)  # same shading

"""Tests of the CPU reference render (rockdove.verify.reference_image) on tiny hand-made scenes."""

import numpy as np
import pytest
from PIL import Image

from rockdove.films import FilmModel
from rockdove.lut.reference import reference_colour
from rockdove.render.film import ThinFilmParams
from rockdove.render.scene import RenderScene, ScenePart
from rockdove.render.views import View, look_at
from rockdove.verify import rays
from rockdove.verify import reference_image as reference

BODY_RGB = np.array([0.2, 0.4, 0.6])


def _quad(z, size, normal_sign=1.0):
    s = size / 2
    pts = np.array([[-s, -s, z], [s, -s, z], [s, s, z], [-s, s, z]], np.float32)
    tris = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    if normal_sign < 0:
        tris = tris[:, ::-1].copy()
    nrm = np.tile([0.0, 0.0, normal_sign], (4, 1)).astype(np.float32)
    st = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    return pts, nrm, tris, st


def _film(a=1.5, b=0.0):
    return ThinFilmParams(FilmModel("paper", a, b), lut_file="unused.exr", lut_colour_space="lin_rec709",
                          angle_warp_gamma=1.0, thickness_range_nm=(650.0, 650.0))


def _scene(tmp_path, alpha_left=0, mask_value=255, normal_sign=1.0, thickness=(650.0, 650.0), film=None):
    """A feather quad at z = 0 (0.1 m, facing +Z, texture alpha ``alpha_left`` on its left half, opaque
    right half, grey base 128, constant mask) in front of a large body quad at z = -0.05."""
    base = np.zeros((8, 8, 4), np.uint8)
    base[..., :3] = 128
    base[:, :4, 3] = alpha_left
    base[:, 4:, 3] = 255
    Image.fromarray(base, "RGBA").save(tmp_path / "base.png")
    Image.fromarray(np.full((8, 8), mask_value, np.uint8), "L").save(tmp_path / "mask.png")
    p, n, t, st = _quad(0.0, 0.1, normal_sign)
    d = np.array([thickness[0], thickness[0], thickness[1], thickness[1]], np.float32)  # graded along t
    feather = ScenePart("NeckFeathers", "/Pigeon/Geom/NeckFeathers", "feather", p, n, t, st, thickness_nm=d,
                        base_colour_texture=str(tmp_path / "base.png"), mask_texture=str(tmp_path / "mask.png"))
    p2, n2, t2, st2 = _quad(-0.05, 0.4)
    body = ScenePart("Body", "/Pigeon/Geom/Body", "body", p2, n2, t2, st2, base_colour=BODY_RGB.astype(np.float32))
    return RenderScene(str(tmp_path / "pigeon.usda"), (feather, body), film or _film(), {})


def _view(light=(0.0, 0.0, 1.0), size=16, eye=(0.0, 0.0, 0.3)):
    return View("v", look_at(eye, (0.0, 0.0, 0.0)), np.radians(20.0), size, size, light, (1.0, 1.0, 1.0))


def _red(c, d):
    return np.tile([1.0, 0.0, 0.0], (len(c), 1))


def test_camera_rays_follow_the_opengl_pinhole_convention():
    v = _view(size=4)
    origin, dirs, fwd = rays.camera_rays(v)
    np.testing.assert_allclose(origin, [0, 0, 0.3])
    np.testing.assert_allclose(fwd, [0, 0, -1], atol=1e-12)
    assert dirs.shape == (16, 3)
    # the top-left pixel looks up and to the left; its direction's slope is the pixel centre's tangent
    t = np.tan(np.radians(10.0))
    np.testing.assert_allclose(dirs[0] / -dirs[0, 2], [-0.75 * t, 0.75 * t, -1.0], rtol=1e-12)


def test_alpha_cut_out_lets_rays_continue_to_the_body_behind(tmp_path):
    res = reference.render_reference(_scene(tmp_path), [_view()], structural_fn=_red)[0]
    row = res.part_id[8]
    # the feather spans the middle of the image; its transparent left half shows the body (id 2)
    covered = np.nonzero(np.abs(np.arange(16) + 0.5 - 8) / 8 * np.tan(np.radians(10)) * 0.3 < 0.05)[0]
    left, right = covered[covered < 8], covered[covered >= 8]
    assert (row[left] == 2).all() and (row[right] == 1).all()
    np.testing.assert_allclose(res.rgb[8, left], np.tile(BODY_RGB, (len(left), 1)), rtol=1e-6)
    np.testing.assert_allclose(res.rgb[8, right], np.tile([1.0, 0.0, 0.0], (len(right), 1)), rtol=1e-6)
    assert res.stats["alpha_layers"] >= 2
    # with an opaque texture every covered pixel is the feather
    opaque = reference.render_reference(_scene(tmp_path, alpha_left=255), [_view()], structural_fn=_red)[0]
    assert (opaque.part_id[8, covered] == 1).all()
    assert np.isfinite(res.depth_m[res.coverage]).all() and res.depth_m[8, 12] == pytest.approx(0.3, rel=1e-4)


def test_views_sharing_a_camera_share_the_hits_but_not_the_light(tmp_path):
    scene = _scene(tmp_path)
    a, b = reference.render_reference(scene, [_view((0.0, 0.0, 1.0)), _view((0.0, 0.6, 0.8))], structural_fn=_red)
    np.testing.assert_array_equal(a.part_id, b.part_id)
    np.testing.assert_allclose(b.rgb[8, 12], 0.8 * a.rgb[8, 12], rtol=1e-6)
    other = reference.render_reference(scene, [_view(eye=(0.02, 0.0, 0.3))], structural_fn=_red)[0]
    assert not np.allclose(other.depth_m, a.depth_m)  # a different camera is cast again


def test_the_ray_casts_key_follows_the_geometry_not_the_film(tmp_path):
    """ray_digest (part of the surfaces' key) ignores the film and changes with the geometry."""
    import dataclasses

    scene = _scene(tmp_path)
    digest = rays.ray_digest(scene)
    assert rays.ray_digest(dataclasses.replace(scene, film=_film(1.6, 5000.0))) == digest
    moved = dataclasses.replace(scene.parts[1], positions_m=scene.parts[1].positions_m + np.float32(0.001))
    assert rays.ray_digest(dataclasses.replace(scene, parts=(scene.parts[0], moved))) != digest


def test_cached_surfaces_give_the_same_render_and_follow_the_shading_inputs_not_the_film(tmp_path):
    """Surfaces cached by camera (cast_surfaces, stored as arrays) render exactly as shading afresh, under any
    light and film, without loading the scene's geometry; their key (surface_digest) ignores the film and
    changes with the normals, thickness and textures (not only with what the rays hit)."""
    import dataclasses

    scene = _scene(tmp_path, thickness=(500.0, 700.0))
    views = [_view((0.0, 0.0, 1.0)), _view((0.0, 0.6, 0.8)), _view(eye=(0.02, 0.0, 0.3))]
    surfaces = reference.cast_surfaces(scene, views)
    assert surfaces.keys() == {rays.camera_key(v) for v in views} and len(surfaces) == 2
    stored = {k: reference.Surface.from_arrays(srf.to_arrays(), srf.stats) for k, srf in surfaces.items()}
    fresh = reference.render_reference(scene, views)
    no_geometry = dataclasses.replace(scene, parts=tuple(dataclasses.replace(p, positions_m=p.positions_m * np.nan)
                                                         for p in scene.parts))
    cached = reference.render_reference(no_geometry, views, surfaces=stored)  # the geometry is never read
    for a, b in zip(fresh, cached):
        for f in ("rgb", "part_id", "depth_m", "n_dot_l", "cos_theta", "thickness_nm", "mask"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    # a film change shades the same surfaces with the new film
    other = _film(1.6, 5000.0)
    np.testing.assert_array_equal(
        reference.render_reference(dataclasses.replace(scene, film=other), views[:1])[0].rgb,
        reference.render_reference(dataclasses.replace(no_geometry, film=other), views[:1], surfaces=stored)[0].rgb)
    digest = reference.surface_digest(scene)
    assert reference.surface_digest(dataclasses.replace(scene, film=other)) == digest
    feather = scene.parts[0]
    for change in ({"thickness_nm": feather.thickness_nm + np.float32(1.0)},
                   {"normals": -feather.normals},
                   {"mask_texture": str(tmp_path / "base.png")}):
        changed = dataclasses.replace(scene, parts=(dataclasses.replace(feather, **change), scene.parts[1]))
        assert reference.surface_digest(changed) != digest, change
        assert rays.ray_digest(changed) == rays.ray_digest(scene), change  # the rays need not be cast again


def test_lambert_and_two_sided_cards(tmp_path):
    light = np.array([0.0, 0.6, 0.8])
    front = reference.render_reference(_scene(tmp_path, alpha_left=255), [_view(light)], structural_fn=_red)[0]
    np.testing.assert_allclose(front.n_dot_l[8, 8], 0.8, rtol=1e-5)
    np.testing.assert_allclose(front.rgb[8, 8], [0.8, 0.0, 0.0], rtol=1e-5)
    # the same card authored facing away from the camera: the shader flips N toward the viewer
    back = reference.render_reference(
        _scene(tmp_path, alpha_left=255, normal_sign=-1.0), [_view(light)], structural_fn=_red
    )[0]
    np.testing.assert_allclose(back.rgb[8, 8], front.rgb[8, 8], rtol=1e-5)


def test_mask_mixes_base_and_structural_colour(tmp_path):
    # mask 0.5: colour = 0.5 base + 0.5 structural; base 128 is sRGB-decoded to linear
    import colour

    res = reference.render_reference(_scene(tmp_path, alpha_left=255, mask_value=128), [_view()],
                                     structural_fn=_red)[0]
    base = float(colour.cctf_decoding(128 / 255, function="sRGB"))
    m = 128 / 255
    np.testing.assert_allclose(res.rgb[8, 8], [(1 - m) * base + m, (1 - m) * base, (1 - m) * base], rtol=1e-5)
    assert res.mask[8, 8] == pytest.approx(m, rel=1e-6)


def test_pixels_equal_the_exact_spectral_colour_times_n_dot_l(tmp_path):
    """One opaque feather quad facing the camera, graded thickness: every feather pixel equals the exact
    colour of its own (cos_theta, thickness) (integrated here at 0.1 nm, independently of the reference's
    step choice) times N.L."""
    from rockdove import optics, spectral

    light = np.array([0.6, 0.0, 0.8])
    film = _film(1.532, 5890.0)
    scene = _scene(tmp_path, alpha_left=255, thickness=(480.0, 700.0), film=film)
    v = _view(light, size=12)
    res = reference.render_reference(scene, [v])[0]
    feather = res.part_id == 1
    assert feather.sum() > 20
    origin, dirs, _ = rays.camera_rays(v)
    dirs = dirs.reshape(12, 12, 3)[feather]
    hit = origin + dirs * (-origin[2] / dirs[:, 2:3])  # intersection with the plane z = 0
    t = (hit[:, 1] + 0.05) / 0.1
    d = 480.0 + 220.0 * t  # thickness interpolated along t
    cos_theta = np.sqrt((1.0 + (-dirs) @ light) / 2.0)
    wl = np.linspace(360.0, 780.0, 4201)
    w = spectral.spectral_weights(wl, colour_space="lin_rec709")
    n = 1.532 + 5890.0 / wl**2
    refl = optics.reflectance(wl[None, :], cos_theta[:, None], d[:, None], n_film=n[None, :])
    expected = (refl @ w) * light[2]  # N = +Z, N.L = 0.8
    np.testing.assert_allclose(res.thickness_nm[feather], d, rtol=1e-5)
    np.testing.assert_allclose(res.cos_theta[feather], cos_theta, rtol=1e-5)
    np.testing.assert_allclose(res.rgb[feather], expected, atol=2e-4)


@pytest.mark.parametrize("thickness_nm", [(450.0, 720.0), (1500.0, 2000.0), (4000.0, 5000.0)])
def test_spectral_step_is_exact_against_a_finer_grid(thickness_nm):
    """The cos_theta-dependent wavelength steps err by < 0.01 dE2000 against a much finer integration
    everywhere, grazing included (where the spectrum is a comb of sharp lines), at every thickness the
    configuration allows (thicker films scale the steps down: their fringes are narrower)."""
    from rockdove import spectral

    film = _film(1.532, 5890.0)
    rng = np.random.default_rng(1)
    bands = [(0.0, 0.001), (0.001, 0.003), (0.003, 0.01), (0.01, 0.03), (0.03, 0.08), (0.08, 0.12), (0.12, 1.0)]
    n = 12 if thickness_nm[0] > 1000 else 25
    c = np.concatenate([rng.uniform(lo, hi, n) for lo, hi in bands])
    d = rng.uniform(*thickness_nm, c.size)
    exact = np.empty((c.size, 3))
    for (lo, hi), step in zip(bands, (0.002, 0.005, 0.01, 0.02, 0.02, 0.02, 0.05)):
        sel = (c >= lo) & (c < hi)
        exact[sel] = reference_colour(c[sel], d[sel], film.model, steps_nm=((0.0, step),))
    ours = reference.structural_rgb(c, d, film)
    lab = lambda x: spectral.RGB_to_Lab(np.clip(x, 0, 1))
    assert np.max(spectral.delta_E_2000(lab(ours), lab(exact))) < 0.003  # measured <= 0.0008 (lut.reference docstring)
    # the wavenumber interpolant (cos_theta >= 0.01): phase steps about 3x coarser are visibly wrong
    sel = c >= reference.IMAGE_INTERPOLATION[0]
    coarse = reference_colour(c[sel], d[sel], film.model, interpolation=(0.01, 1.0, 1.5),
                              order=reference.IMAGE_INTERPOLANT_ORDER)
    assert np.max(spectral.delta_E_2000(lab(coarse), lab(exact[sel]))) > 0.02
    if thickness_nm[0] > 1000:  # the steps validated for a 720 nm film are visibly wrong here, unscaled
        plain = reference_colour(c, d, film.model, steps_nm=reference.IMAGE_STEPS_NM)
        assert np.max(spectral.delta_E_2000(lab(plain), lab(exact))) > 0.02
    else:  # and near grazing the fine steps are needed: a uniform 1 nm grid is visibly wrong there
        sel = (c > 0.001) & (c < 0.03)
        coarse = reference_colour(c[sel], d[sel], film.model, steps_nm=((0.0, 1.0),))
        assert np.max(spectral.delta_E_2000(lab(coarse), lab(exact[sel]))) > 0.02


def test_coarse_steps_integrate_the_cubic_interpolant_against_the_fine_weights():
    """A step coarser than 0.1 nm integrates the spectrum's cubic interpolant against the 0.1 nm weights:
    exact for any cubic spectrum (a perfect reflector stays Y = 1), and the same number as interpolating by
    hand and integrating on the 0.1 nm grid."""
    from rockdove.lut import reference as lut_reference

    fine = lut_reference.reference_wavelengths(0.1)
    w_fine = lut_reference.colour_weights(fine, colour_space=None)
    for step in (0.5, 4.0):
        coarse = lut_reference.reference_wavelengths(step)
        w = lut_reference.product_weights(step, colour_space=None)
        assert w.shape == (coarse.size, 3)
        assert np.sum(w[:, 1]) == pytest.approx(1.0, abs=1e-12)  # R = 1: Y = 1
        x = (coarse - 570.0) / 210.0
        cubic = 0.4 + 0.2 * x - 0.3 * x**2 + 0.25 * x**3
        xf = (fine - 570.0) / 210.0
        assert cubic @ w == pytest.approx((0.4 + 0.2 * xf - 0.3 * xf**2 + 0.25 * xf**3) @ w_fine, abs=1e-12)
    # a smooth non-polynomial spectrum: equal to its own cubic interpolation integrated on the fine grid
    coarse = lut_reference.reference_wavelengths(4.0)
    spectrum = 0.5 + 0.4 * np.sin(coarse / 23.0)
    t = (fine - coarse[0]) / 4.0
    k0 = np.clip(np.floor(t).astype(int) - 1, 0, coarse.size - 4)
    by_hand = np.zeros_like(fine)
    for j in range(4):
        lj = np.prod([(t - (k0 + m)) / (j - m) for m in range(4) if m != j], axis=0)
        by_hand += lj * spectrum[k0 + j]
    assert spectrum @ lut_reference.product_weights(4.0, colour_space=None) == pytest.approx(by_hand @ w_fine, abs=1e-12)
    with pytest.raises(ValueError, match="step_nm"):
        lut_reference.product_weights(300.0)


def test_deduplication_keys_are_far_below_visible():
    """structural_rgb de-duplicates on quantised (cos_theta, d); perturbing inputs within a key changes the
    colour by far less than 0.01 dE2000."""
    from rockdove import spectral

    film = _film(1.532, 5890.0)
    rng = np.random.default_rng(2)
    c = rng.uniform(0.05, 1.0, 200)
    d = rng.uniform(480.0, 700.0, 200)
    a = reference.structural_rgb(c, d, film)
    b = reference_colour(c + 0.5 * reference.COS_THETA_QUANTUM, d + 0.5 * reference.THICKNESS_QUANTUM_NM, film.model,
                         steps_nm=((0.0, 1.0),))
    lab = lambda x: spectral.RGB_to_Lab(np.clip(x, 0, 1))
    assert np.max(spectral.delta_E_2000(lab(a), lab(b))) < 0.01
    stats = {}
    reference.structural_rgb(np.repeat(c[:10], 5), np.repeat(d[:10], 5), film, stats)
    assert stats == {"spectral_pixels": 50, "spectral_keys": 10}


def test_render_needs_views_and_film(tmp_path):
    scene = _scene(tmp_path)
    with pytest.raises(ValueError, match="views"):
        reference.render_reference(scene, [])
    no_film = RenderScene(scene.root_layer, scene.parts, None, {})
    with pytest.raises(ValueError, match="film"):
        reference.render_reference(no_film, [_view()])


def test_display_transform_is_the_clipped_srgb_oetf():
    from rockdove.srgb import linear_to_srgb8

    # the sRGB OETF of the clipped value, rounded: checked against the formula, not against itself
    rgb = np.array([[0.0, 1.0, 2.0], [-0.05, 0.3, 0.1]])
    assert linear_to_srgb8(rgb).tolist() == [[0, 255, 255], [0, round(255 * (1.055 * 0.3 ** (1 / 2.4) - 0.055)),
                                                                     round(255 * (1.055 * 0.1 ** (1 / 2.4) - 0.055))]]
    grey = linear_to_srgb8(np.array([[0.18, 0.18, 0.18]]))[0, 0]
    assert grey == round(255 * (1.055 * 0.18 ** (1 / 2.4) - 0.055))
    assert linear_to_srgb8(np.array([[np.nan, np.inf, 0.5]]))[0, :2].tolist() == [0, 255]


def test_view_angle_lobe_is_mask_times_the_film_at_n_dot_v_whatever_the_light(tmp_path):
    """The view_angle lobe (mirror lobe of a smooth film under a uniform unit environment): a feather pixel is
    mask * structural(|N.V|), base colour black, independent of the View's light; the body is black; both lobes
    of one call share the ray casts (same part ids and coverage)."""
    scene = _scene(tmp_path, alpha_left=255, mask_value=128)
    views = [_view(light=(0.0, 0.0, 1.0), eye=(0.05, 0.02, 0.3)), _view(light=(0.8, 0.0, 0.6), eye=(0.05, 0.02, 0.3))]
    lobes = reference.render_reference_lobes(scene, views, ("half_angle", "view_angle"),
                                             structural_fn=lambda c, d: np.stack([c, 1 - c, 0 * c], axis=1))
    va, ha = lobes["view_angle"], lobes["half_angle"]
    feather = va[0].part_id == 1
    np.testing.assert_array_equal(va[0].part_id, ha[0].part_id)
    np.testing.assert_array_equal(va[0].rgb, va[1].rgb)  # no light
    origin, dirs, _ = rays.camera_rays(views[0])
    n_dot_v = np.abs(dirs.reshape(16, 16, 3)[..., 2])[feather]  # N = +Z
    m = 128 / 255
    np.testing.assert_allclose(va[0].cos_theta[feather], n_dot_v, rtol=1e-5)
    np.testing.assert_allclose(va[0].rgb[feather], m * np.stack([n_dot_v, 1 - n_dot_v, 0 * n_dot_v], 1), rtol=1e-4,
                               atol=1e-6)
    assert np.all(va[0].rgb[va[0].part_id == 2] == 0)  # other parts: diffuse off
    assert not np.allclose(ha[1].rgb[feather], va[1].rgb[feather], atol=1e-3)  # a different model
    with pytest.raises(ValueError, match="lobe"):
        reference.render_reference(scene, views, lobe="phong")


@pytest.mark.parametrize("film", [FilmModel("keratin", 1.532, 5890.0), FilmModel("paper", 1.5),
                                  FilmModel("glass-on-melanin", 1.56, 4000.0, n_substrate=1.75)])
def test_real_film_kernel_is_the_airy_reflectance(film):
    """The reference's real-film kernel (transmission form, float32 or float64) integrates the same spectrum as
    optics.reflectance on the same nodes: to rounding in float64, within 1e-4 of linear colour in float32 at
    cos_theta >= 0.05 and films up to 5000 nm; grazing (R = 1) and bare interfaces (d = 0) included."""
    from rockdove import optics
    from rockdove.lut import reference as lut_reference

    rng = np.random.default_rng(3)
    c = np.concatenate([[0.0, 1.0, 0.3], rng.uniform(0.0, 1.0, 60)])
    d = np.concatenate([[600.0, 0.0, 5000.0], rng.uniform(0.0, 5000.0, 60)])
    assert lut_reference.real_film(film)
    wl = lut_reference.wavenumber_nodes(64)
    w = lut_reference.interpolant_weights(64)
    r = optics.reflectance(wl[None, :], c[:, None], d[:, None], n_film=film.n_film(wl)[None, :],
                           n_incident=film.n_incident, n_substrate=film.n_substrate)
    expected = r @ w
    got = lut_reference._real_colour(wl, w, c, d, film, np.float64)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    hi = c >= lut_reference.FLOAT32_MIN_COS
    got32 = lut_reference._real_colour(wl, w, c[hi], d[hi], film, np.float32)
    np.testing.assert_allclose(got32, expected[hi], rtol=0, atol=1e-4)
    assert not lut_reference.real_film(FilmModel("absorbing", 1.5, k=0.01))  # those take optics.reflectance


@pytest.mark.parametrize("film", [FilmModel("keratin", 1.532, 5890.0),
                                  FilmModel("glass-on-melanin", 1.56, 4000.0, n_substrate=1.75),
                                  FilmModel("absorbing", 1.5, k=0.01)])
def test_wavelength_steps_integrate_the_airy_reflectance(film):
    """reference_colour's wavelength-step bands (the LUT error check's reference) are optics.reflectance integrated
    with the band's weights: to rounding for every film, real ones through the float64 kernel included, in each
    band of REFERENCE_STEPS_NM (0.01, 0.05, 0.1 nm), a coarse (product-weight) step, grazing and d = 0 included
    (no film between equal media at grazing: R = 0, not the grazing limit R = 1 of a film)."""
    from rockdove import optics
    from rockdove.lut import reference as lut_reference

    rng = np.random.default_rng(5)
    c = np.concatenate([[0.0, 0.0, 1.0, 0.0005, 0.002], rng.uniform(0.003, 1.0, 6)])
    d = np.concatenate([[600.0, 0.0, 0.0, 700.0, 5000.0], rng.uniform(0.0, 5000.0, 6)])

    def integrated(step, rows):
        wl = lut_reference.reference_wavelengths(step)
        w = (lut_reference.product_weights(step) if step > lut_reference.REFERENCE_STEP_NM
             else lut_reference.colour_weights(wl))
        r = optics.reflectance(wl[None, :], c[rows, None], d[rows, None], n_film=film.n_film(wl)[None, :],
                               n_incident=film.n_incident, n_substrate=film.n_substrate)
        return r @ w

    steps = lut_reference.reference_step_nm(c)
    expected = np.empty((c.size, 3))
    for step in np.unique(steps):
        expected[steps == step] = integrated(float(step), steps == step)
    np.testing.assert_allclose(reference_colour(c, d, film), expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(reference_colour(c[5:], d[5:], film, steps_nm=((0.0, 2.0),)),
                               integrated(2.0, slice(5, None)), rtol=0, atol=1e-12)


def test_wavenumber_interpolant_integrates_polynomials_in_wavenumber_exactly():
    """interpolant_weights: a polynomial of degree < order in 1 / lambda integrates to its 0.1 nm reference
    integral (a perfect reflector has Y = 1), and a smooth fringe spectrum converges fast with the order."""
    from rockdove.lut import reference as lut_reference

    fine = lut_reference.reference_wavelengths(0.1)
    w_fine = lut_reference.colour_weights(fine, colour_space=None)
    for order in (4, 16):
        wl = lut_reference.wavenumber_nodes(40, order)
        w = lut_reference.interpolant_weights(40, order, colour_space=None)
        assert wl.shape == (40 + order - 1,) and w.shape == (wl.size, 3)
        assert (wl[order // 2 - 1], wl[order // 2 - 1 + 40]) == (360.0, 780.0)
        assert np.sum(w[:, 1]) == pytest.approx(1.0, abs=1e-12)
        poly = lambda lam: (1e3 / lam) ** (order - 1) - 0.5 * (1e3 / lam) ** 2
        assert poly(wl) @ w == pytest.approx(poly(fine) @ w_fine, abs=1e-9)
    fringe = lambda lam: 0.1 * np.cos(2.0e4 / lam)
    err = [np.abs(fringe(lut_reference.wavenumber_nodes(40, o)) @ lut_reference.interpolant_weights(40, o)
                  - fringe(fine) @ lut_reference.colour_weights(fine)).max() for o in (4, 16)]
    assert err[1] < 1e-6 < err[0]
    with pytest.raises(ValueError, match="order"):
        lut_reference.interpolant_weights(40, 5)


def test_interpolation_leaves_what_it_cannot_do_to_the_wavelength_steps():
    """Absorbing films, and points whose grid would exceed NODE_LADDER (a dense film near grazing), take the
    wavelength steps exactly as without ``interpolation``; a film less dense than its substrate runs in float64."""
    from rockdove.lut import reference as lut_reference

    steps = reference.IMAGE_STEPS_NM
    interp = reference.IMAGE_INTERPOLATION
    c = np.array([0.0101, 0.02, 0.5, 1.0])
    d = np.array([5000.0, 5000.0, 600.0, 0.0])
    absorbing = FilmModel("absorbing", 1.5, k=0.01)
    np.testing.assert_array_equal(reference_colour(c, d, absorbing, steps_nm=steps, interpolation=interp),
                                  reference_colour(c, d, absorbing, steps_nm=steps))
    dense = FilmModel("dense", 2.6)
    assert lut_reference.interval_count(c, d, dense, *interp[1:]).tolist()[:2] == [0, 0]
    np.testing.assert_array_equal(reference_colour(c[:2], d[:2], dense, steps_nm=steps, interpolation=interp),
                                  reference_colour(c[:2], d[:2], dense, steps_nm=steps))
    on_melanin = FilmModel("on-melanin", 1.56, 4000.0, n_substrate=1.75)
    n = lut_reference.interval_count(c[2:3], d[2:3], on_melanin, *interp[1:])[0]
    expected = lut_reference._real_colour(lut_reference.wavenumber_nodes(n), lut_reference.interpolant_weights(n),
                                          c[2:3], d[2:3], on_melanin, np.float64)
    got = reference_colour(c[2:3], d[2:3], on_melanin, interpolation=interp)
    np.testing.assert_array_equal(got, expected)

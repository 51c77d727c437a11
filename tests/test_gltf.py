"""glTF export (rockdove.web.gltf): pigeon.glb validates with the Khronos glTF-Validator and carries the film."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="session")
def built_glb(small_asset, tmp_path_factory):
    """The ``pigeon.glb`` the small real build published (its ``gltf`` stage), and the summary of exporting
    that asset again: (asset dir, glb path, summary)."""
    from rockdove.web.gltf import export_glb

    summary = export_glb(small_asset, tmp_path_factory.mktemp("gltf") / "pigeon.glb")
    return small_asset, small_asset / "pigeon.glb", summary


def test_glb_validates_with_zero_errors(built_glb):
    from rockdove.web.gltf import validate_glb

    report = validate_glb(built_glb[1])
    issues = report["issues"]
    assert issues["numErrors"] == 0, issues["messages"]
    assert issues["numWarnings"] == 0, issues["messages"]
    assert set(report["info"]["extensionsUsed"]) == {"KHR_materials_iridescence", "KHR_materials_ior"}
    assert report["info"]["maxUVs"] == 2


def test_validator_reports_a_broken_glb(built_glb, tmp_path):
    """The validator really checks: a GLB whose index accessor points past its vertices has errors."""
    import pygltflib

    from rockdove.web.gltf import validate_glb

    gltf = pygltflib.GLTF2().load(str(built_glb[1]))
    gltf.accessors[gltf.meshes[0].primitives[0].attributes.POSITION].count = 1
    gltf.save(str(tmp_path / "broken.glb"))
    assert validate_glb(tmp_path / "broken.glb")["issues"]["numErrors"] > 0


def test_feather_material_carries_the_film(built_glb):
    import pygltflib

    from rockdove.render.scene import load_scene

    asset, glb, summary = built_glb
    scene = load_scene(asset)
    gltf = pygltflib.GLTF2().load(str(glb))
    feathers = next(m for m in gltf.materials if m.name == "NeckFeathersMaterial")
    assert feathers.alphaMode == "MASK" and feathers.alphaCutoff == 0.5 and feathers.doubleSided
    ir = feathers.extensions["KHR_materials_iridescence"]
    film = scene.film
    # the Cauchy index at the stated wavelength, n = A + B / lambda^2
    assert ir["iridescenceIor"] == pytest.approx(film.model.cauchy_a + film.model.cauchy_b_nm2 / 550.0**2)
    assert feathers.extras["rockdove"]["iridescenceIorWavelengthNm"] == 550.0
    assert (ir["iridescenceThicknessMinimum"], ir["iridescenceThicknessMaximum"]) == tuple(film.thickness_range_nm)
    assert ir["iridescenceThicknessTexture"]["texCoord"] == 1
    assert feathers.extensions["KHR_materials_ior"]["ior"] == film.model.n_substrate
    assert summary["ior_wavelength_nm"] == 550.0


def test_thickness_texture_returns_each_vertex_thickness(built_glb):
    """Reading the glTF the way a renderer does (G of the ramp at TEXCOORD_1, linear filtering, then
    mix(min, max, G)) gives back the USD thickness primvar per vertex."""
    import io

    import pygltflib
    from PIL import Image

    from rockdove.render.scene import load_scene

    asset, glb, _ = built_glb
    gltf = pygltflib.GLTF2().load(str(glb))
    blob = gltf.binary_blob()

    def view_bytes(i):
        bv = gltf.bufferViews[i]
        return blob[bv.byteOffset:bv.byteOffset + bv.byteLength]

    mesh = next(m for m in gltf.meshes if m.name == "NeckFeathers")
    acc = gltf.accessors[mesh.primitives[0].attributes.TEXCOORD_1]
    uv1 = np.frombuffer(view_bytes(acc.bufferView), np.float32).reshape(-1, 2)
    ir = gltf.materials[mesh.primitives[0].material].extensions["KHR_materials_iridescence"]
    tex = gltf.textures[ir["iridescenceThicknessTexture"]["index"]]
    ramp = np.asarray(Image.open(io.BytesIO(view_bytes(gltf.images[tex.source].bufferView))))[0, :, 1] / 255.0
    n = ramp.size
    x = uv1[:, 0] * n - 0.5  # texel-centre coordinates, as linear filtering uses them
    i0 = np.clip(np.floor(x).astype(int), 0, n - 1)
    i1 = np.clip(i0 + 1, 0, n - 1)
    g = ramp[i0] + (x - i0) * (ramp[i1] - ramp[i0])
    d = ir["iridescenceThicknessMinimum"] + g * (ir["iridescenceThicknessMaximum"] - ir["iridescenceThicknessMinimum"])
    expected = load_scene(asset).part("NeckFeathers").thickness_nm
    np.testing.assert_allclose(d, expected, atol=1e-3)


def test_asset_without_rockdove_data_gets_a_clear_message(tmp_path, capsys):
    from pxr import Usd, UsdGeom

    from rockdove.web.gltf import export_glb

    stage = Usd.Stage.CreateNew(str(tmp_path / "plain.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    mesh = UsdGeom.Mesh.Define(stage, "/World/Tri")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    stage.SetDefaultPrim(stage.GetPrimAtPath("/World"))
    stage.Save()
    with pytest.raises(ValueError, match="no rockdove thin-film data.*RockDoveThinFilmAPI"):
        export_glb(tmp_path / "plain.usda", tmp_path / "plain.glb")
    assert not (tmp_path / "plain.glb").exists()
    # the command says it in one line, exit status 2
    from rockdove.cli import main

    assert main(["gltf", str(tmp_path / "plain.usda"), "--out", str(tmp_path / "plain.glb")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no rockdove thin-film data" in err


def test_gltf_command_exports_and_validates(built_glb, tmp_path, capsys):
    from rockdove.cli import main

    assert main(["gltf", str(built_glb[0]), "--out", str(tmp_path / "p.glb"), "--validate"]) == 0
    out = capsys.readouterr().out
    assert "glTF-Validator: 0 errors" in out and (tmp_path / "p.glb").is_file()


def test_an_absorbing_film_exports_the_real_part_of_its_index():
    """glTF's iridescence takes a real index: an absorbing film (n + i k) exports n, without a ComplexWarning
    that would say the imaginary part was dropped by accident."""
    import warnings

    from rockdove.films import FilmModel
    from rockdove.render.film import ThinFilmParams
    from rockdove.web.gltf import IOR_WAVELENGTH_NM, film_ior

    film = ThinFilmParams(FilmModel("keratin", 1.532, 5890.0, k=0.05))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert film_ior(film) == pytest.approx(1.532 + 5890.0 / IOR_WAVELENGTH_NM**2)

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
    assert report.errors == 0, report.messages
    assert report.warnings == 0, report.messages
    assert set(report.extensions_used) == {"KHR_materials_iridescence", "KHR_materials_ior", "KHR_materials_variants"}
    assert report.max_uvs == 3


def test_validator_reports_a_broken_glb(built_glb, tmp_path):
    """The validator really checks: a GLB whose index accessor points past its vertices has errors."""
    import pygltflib

    from rockdove.web.gltf import validate_glb

    gltf = pygltflib.GLTF2().load(str(built_glb[1]))
    gltf.accessors[gltf.meshes[0].primitives[0].attributes.POSITION].count = 1
    gltf.save(str(tmp_path / "broken.glb"))
    assert validate_glb(tmp_path / "broken.glb").errors > 0


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
    assert summary.ior_wavelength_nm == 550.0


def test_default_feather_material_is_the_preview_atlas_and_the_film_a_variant(built_glb):
    """A consumer without KHR_materials_iridescence (or that ignores the variants) gets the USD preview's atlas
    through previewST (TEXCOORD_2); the variant thin_film maps the primitive to the film material."""
    import pygltflib

    from rockdove.render.scene import load_scene

    asset, glb, _ = built_glb
    gltf = pygltflib.GLTF2().load(str(glb))
    blob = gltf.binary_blob()
    assert [v["name"] for v in gltf.extensions["KHR_materials_variants"]["variants"]] == ["thin_film", "preview"]
    prim = next(m for m in gltf.meshes if m.name == "NeckFeathers").primitives[0]
    default = gltf.materials[prim.material]
    assert default.name == "NeckFeathersPreview" and not default.extensions
    tex = default.pbrMetallicRoughness.baseColorTexture
    assert tex.texCoord == 2 and gltf.images[gltf.textures[tex.index].source].name == "feather_preview.png"
    assert (default.alphaMode, default.doubleSided) == ("MASK", True)
    mappings = {tuple(m["variants"]): gltf.materials[m["material"]]
                for m in prim.extensions["KHR_materials_variants"]["mappings"]}
    assert "KHR_materials_iridescence" in mappings[(0,)].extensions and mappings[(1,)] is default
    acc = gltf.accessors[prim.attributes.TEXCOORD_2]
    bv = gltf.bufferViews[acc.bufferView]
    uv2 = np.frombuffer(blob[bv.byteOffset:bv.byteOffset + bv.byteLength], np.float32).reshape(-1, 2)
    preview_st = load_scene(asset).part("NeckFeathers").preview_st
    np.testing.assert_allclose(uv2, np.stack([preview_st[:, 0], 1.0 - preview_st[:, 1]], axis=1))


_BLENDER_IMPORT = """
import bpy, json, sys
import numpy as np
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-1])
obj = bpy.data.objects["NeckFeathers"]
mat = obj.material_slots[0].material
bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
link = bsdf.inputs["Base Color"].links[0]
image = link.from_node.image
uv_node = next((n for n in mat.node_tree.nodes if n.type == "UVMAP"), None)
uv_layer = obj.data.uv_layers[uv_node.uv_map] if uv_node else obj.data.uv_layers.active
uv = np.zeros(2 * len(uv_layer.data)); uv_layer.data.foreach_get("uv", uv); uv = uv.reshape(-1, 2)
w, h = image.size
px = np.asarray(image.pixels[:], np.float32).reshape(h, w, 4)  # linear, bottom row first
rgb = []  # the atlas's opaque texels under each card (its UV box), sRGB as stored
for poly in obj.data.polygons:
    box = uv[list(poly.loop_indices)]
    (i0, j0), (i1, j1) = np.floor(box.min(0) * (w, h)).astype(int), np.ceil(box.max(0) * (w, h)).astype(int)
    tile = px[max(j0, 0):j1, max(i0, 0):i1].reshape(-1, 4)
    rgb.extend(tile[tile[:, 3] > 0.5, :3][::7].tolist())
print(json.dumps({"material": mat.name, "image": image.name, "rgb": rgb}))
"""


def test_blenders_gltf_importer_shows_green_and_purple_feathers(built_glb):
    """Blender 5.0's importer (no KHR_materials_iridescence) takes the default material: the preview atlas, whose
    colours at the feathers' texcoords (as Blender reads them) hold green and purple."""
    import json
    import subprocess

    from rockdove.hosts.bpy_runner import bpy_python, unavailable
    from rockdove.verify.compare import hue_classes

    if unavailable():
        pytest.skip(f"bpy is not available: {unavailable()}")
    res = subprocess.run([bpy_python(), "-c", _BLENDER_IMPORT, "--", str(built_glb[1])], capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    got = json.loads(res.stdout.strip().splitlines()[-1])
    assert got["material"] == "NeckFeathersPreview" and got["image"].startswith("feather_preview")
    srgb = np.asarray(got["rgb"], np.float64)
    _, _, cls = hue_classes(np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4))
    green, purple = int(np.sum(cls == 1)), int(np.sum(cls == 2))
    assert green > 0.05 * len(cls) and purple > 0.05 * len(cls), (green, purple, len(cls))


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
    ir = next(m for m in gltf.materials if m.name == "NeckFeathersMaterial").extensions["KHR_materials_iridescence"]
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

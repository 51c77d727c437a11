"""The USD asset: layers, meshes, primvars, materials, variants, schema values, byte-identical rebuilds, usdz,
atomic publication. Read from the session's small real builds (tests/conftest.py: the build graph that
``rockdove build`` runs, at a small size)."""

import filecmp
import os
import zipfile

import numpy as np
import pytest
from conftest import SMALL_BUILD, built_value, real_build

from rockdove.films import get_film
from rockdove.geometry.types import drop_unreferenced_points

#: ``geometry.card_count`` of the small builds
CARDS = int(dict(s.split("=") for s in SMALL_BUILD)["geometry.card_count"])


def _paths(folder) -> dict:
    """The files of an asset folder by role (absolute paths; ``lut`` only when the EXR exists)."""
    d = str(folder)
    paths = {"dir": d, "interface": os.path.join(d, "pigeon.usda"), "payload": os.path.join(d, "pigeon_payload.usda"),
             "looks": os.path.join(d, "pigeon_looks.usda"), "geometry": os.path.join(d, "pigeon_geom.usdc"),
             "usdz": os.path.join(d, "pigeon.usdz"), "lut": os.path.join(d, "textures", "thinfilm_lut.exr")}
    for role in ("feather_base", "feather_mask", "feather_preview", "body_base", "plumage_base", "plumage_normal"):
        paths[role] = os.path.join(d, "textures", f"{role}.png")
    return {k: v for k, v in paths.items() if k == "dir" or os.path.exists(v)}


@pytest.fixture(scope="module")
def asset(small_asset):
    """The small real build (measured preset, both variants): its files by role. Read-only."""
    return _paths(small_asset)


@pytest.fixture(scope="module")
def bird(small_asset):
    """The bird that build generated (its cached ``bird`` stage value)."""
    return built_value(small_asset, "bird")


@pytest.fixture(scope="module")
def stage(asset):
    from rockdove.usd.stage import open_asset

    return open_asset(asset["interface"])


def test_interface_layer_metadata_kind_assetinfo_payload(asset, stage):
    from pxr import Gf, Kind, Sdf, Usd, UsdGeom

    layer = Sdf.Layer.FindOrOpen(asset["interface"])
    assert layer.defaultPrim == "Pigeon"
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    spec = layer.GetPrimAtPath("/Pigeon")
    assert [p.assetPath for p in spec.payloadList.GetAddedOrExplicitItems()] == ["./pigeon_payload.usda"]
    assert not layer.GetPrimAtPath("/Pigeon/Geom")  # the interface layer stays light
    prim = stage.GetDefaultPrim()
    model = Usd.ModelAPI(prim)
    assert model.GetKind() == Kind.Tokens.component
    assert model.GetAssetName() == "pigeon" and model.GetAssetVersion()
    assert model.GetAssetIdentifier().path == "./pigeon.usda"
    hint = np.asarray(UsdGeom.ModelAPI(prim).GetExtentsHint(), float)
    # the meshes' bound at rest (the SkelRoot's own, UsdSkel's padded bound of the posed joints, is looser)
    cache, bbox = UsdGeom.BBoxCache(Usd.TimeCode.Default(), ["default"]), Gf.Range3d()
    for mesh in (p for p in Usd.PrimRange(prim) if p.IsA(UsdGeom.Mesh)):
        bbox.UnionWith(cache.ComputeWorldBound(mesh).ComputeAlignedRange())
    assert np.allclose(hint[0], bbox.GetMin(), atol=1e-6) and np.allclose(hint[1], bbox.GetMax(), atol=1e-6)
    vset = prim.GetVariantSet("shading")
    assert vset.GetVariantNames() == ["baked", "physical"] and vset.GetVariantSelection() == "baked"


def test_meshes_carry_normals_st_display_colour_extent_and_binding(stage, bird):
    from pxr import UsdGeom, UsdShade

    for part in map(drop_unreferenced_points, bird.parts):  # as written: validators reject unused points
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"/Pigeon/Geom/{part.name}"))
        assert mesh, part.name
        pts = np.asarray(mesh.GetPointsAttr().Get())
        assert np.array_equal(pts, part.points_m)
        assert np.array_equal(np.asarray(mesh.GetNormalsAttr().Get()), part.normals)
        assert mesh.GetNormalsInterpolation() == "vertex"
        st = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st")
        assert st.GetTypeName() == "texCoord2f[]" and st.GetInterpolation() == "vertex"
        assert np.array_equal(np.asarray(st.Get()), part.st)
        assert np.allclose(mesh.GetDisplayColorPrimvar().Get()[0], part.display_color)
        ext = np.asarray(mesh.GetExtentAttr().Get())
        assert np.allclose(ext, [pts.min(0), pts.max(0)])
        assert mesh.GetSubdivisionSchemeAttr().Get() == "none"
        mat, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
        assert mat.GetPath().GetParentPath() == "/Pigeon/Looks"
    feathers = UsdGeom.Mesh(stage.GetPrimAtPath("/Pigeon/Geom/NeckFeathers"))
    assert feathers.GetDoubleSidedAttr().Get() is True
    n_faces = len(bird.part("NeckFeathers").face_vertex_counts)  # all cards in one mesh
    assert len(feathers.GetFaceVertexCountsAttr().Get()) == n_faces and n_faces % CARDS == 0


def test_author_mesh_writes_only_points_that_a_face_uses(bird):
    import dataclasses

    from pxr import Usd

    from rockdove.usd.stage import author_mesh

    part = drop_unreferenced_points(bird.part("Beak"))
    extra = dataclasses.replace(part, points_m=np.vstack([part.points_m, [[9.0, 9.0, 9.0]]]).astype(np.float32),
                                normals=np.vstack([part.normals, [[0.0, 1.0, 0.0]]]).astype(np.float32),
                                st=np.vstack([part.st, [[0.5, 0.5]]]).astype(np.float32))
    stage = Usd.Stage.CreateInMemory()
    mesh = author_mesh(stage, "/Beak", extra)
    pts = np.asarray(mesh.GetPointsAttr().Get())
    assert len(pts) == part.n_points and not np.any(np.all(pts == 9.0, axis=1))
    assert np.unique(np.asarray(mesh.GetFaceVertexIndicesAttr().Get())).size == len(pts)


def test_thickness_primvar_is_documented_float_vertex_nm(stage, bird):
    from pxr import UsdGeom

    pv = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Pigeon/Geom/NeckFeathers")).GetPrimvar("thickness")
    assert pv.GetTypeName() == "float[]" and pv.GetInterpolation() == "vertex"
    assert "nanometres" in pv.GetAttr().GetDocumentation()
    expected = drop_unreferenced_points(bird.part("NeckFeathers")).primvars["thickness"].values
    assert np.array_equal(np.asarray(pv.Get()), expected)


def test_schema_records_the_film_and_lut(stage, asset):
    from rockdove.lut.exr import read_exr
    from rockdove.usd.schema import read_thin_film

    film = read_thin_film(stage.GetPrimAtPath("/Pigeon/Geom/NeckFeathers"))
    keratin = get_film("keratin")
    lut = read_exr(asset["lut"])
    assert film["model"] == "keratin"
    assert film["cauchy_a"] == pytest.approx(keratin.cauchy_a) and film["cauchy_b_nm2"] == pytest.approx(5890)
    assert film["incident_index"] == 1.0 and film["substrate_index"] == 1.0
    assert film["thickness_primvar"] == "thickness" and film["thickness_units"] == "nm"
    assert film["lut_file"] == "./textures/thinfilm_lut.exr"
    assert os.path.samefile(film["lut_file_resolved"], asset["lut"])
    assert film["thickness_range_nm"] == pytest.approx(lut.thickness_range_nm)
    assert film["angle_warp_gamma"] == pytest.approx(lut.angle_warp_gamma)
    assert film["lut_colour_space"] == "lin_rec709" and film["illuminant"] == "D65"


def test_universal_and_mtlx_surfaces_resolve(stage):
    from pxr import UsdShade

    feather = UsdShade.Material(stage.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial"))
    universal, _, _ = feather.ComputeSurfaceSource()
    mtlx, _, _ = feather.ComputeSurfaceSource("mtlx")
    assert universal.GetShaderId() == "UsdPreviewSurface"
    assert mtlx.GetShaderId() == "ND_surface"  # the baked network: a bare Lambert BSDF (materials/thinfilm.mtlx)
    assert universal.GetInput("opacityThreshold").Get() == 0.5
    src = universal.GetInput("diffuseColor").GetConnectedSources()[0][0].source
    tex = UsdShade.Shader(src.GetPrim())
    assert tex.GetInput("file").Get().path == "./textures/feather_preview.png"
    assert tex.GetInput("sourceColorSpace").Get() == "sRGB"
    assert (tex.GetInput("wrapS").Get(), tex.GetInput("wrapT").Get()) == ("clamp", "clamp")
    reader = UsdShade.Shader(stage.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial/StReader"))
    assert reader.GetInput("varname").GetTypeName() == "string" and reader.GetInput("varname").Get() == "previewST"
    body = UsdShade.Material(stage.GetPrimAtPath("/Pigeon/Looks/BodyMaterial"))
    assert body.ComputeSurfaceSource()[0].GetShaderId() == "UsdPreviewSurface"
    body_tex = UsdShade.Shader(stage.GetPrimAtPath("/Pigeon/Looks/BodyMaterial/BaseColorTexture"))
    assert body_tex.GetInput("file").Get().path == "./textures/body_base.png"
    assert body_tex.GetInput("sourceColorSpace").Get() == "sRGB"


def test_feather_texture_shaders_named_for_the_renderer(stage):
    from pxr import UsdShade

    base = UsdShade.Shader(stage.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial/BaseColorTexture"))
    mask = UsdShade.Shader(stage.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial/MaskTexture"))
    lut = UsdShade.Shader(stage.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial/LutTexture"))
    assert base.GetInput("file").Get().path == "./textures/feather_base.png"
    assert base.GetInput("file").GetAttr().GetColorSpace() == "srgb_texture"
    assert mask.GetInput("file").Get().path == "./textures/feather_mask.png"
    assert mask.GetInput("file").GetAttr().GetColorSpace() == "lin_rec709"
    assert lut.GetInput("file").Get().path == "./textures/thinfilm_lut.exr"
    assert lut.GetInput("file").GetAttr().GetColorSpace() == "lin_rec709"  # linear, in the working space
    for name in ("wrapS", "wrapT"):  # UsdUVTexture (thinfilm.mtlx): linear filtering, clamped
        assert lut.GetInput(name).Get() == "clamp"
    assert lut.GetShaderId() == "ND_UsdUVTexture_23"


def test_shading_variants_switch_the_mtlx_network(asset):
    from pxr import UsdShade

    from rockdove.usd.stage import open_asset

    def surface(variant):
        st = open_asset(asset["interface"], shading=variant)
        mat = UsdShade.Material(st.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial"))
        return st, mat.ComputeSurfaceSource("mtlx")[0]

    st, baked = surface("baked")
    assert baked.GetPath().name == "MtlxBakedSurface"
    bsdf = UsdShade.Shader(baked.GetInput("bsdf").GetConnectedSources()[0][0].source.GetPrim())
    assert bsdf.GetShaderId() == "ND_oren_nayar_diffuse_bsdf" and bsdf.GetInput("roughness").Get() == 0.0  # Lambert
    mix = bsdf.GetInput("color").GetConnectedSources()[0][0].source
    assert UsdShade.Shader(mix.GetPrim()).GetShaderId() == "ND_mix_color3"
    st, physical = surface("physical")
    assert physical.GetPath().name == "MtlxPhysicalSurface"
    thick = UsdShade.Shader(physical.GetInput("thin_film_thickness").GetConnectedSources()[0][0].source.GetPrim())
    assert thick.GetShaderId() == "ND_multiply_float" and thick.GetInput("in2").Get() == pytest.approx(1e-3)
    ior = UsdShade.Shader(physical.GetInput("thin_film_ior").GetConnectedSources()[0][0].source.GetPrim())
    assert ior.GetInput("value").Get() == pytest.approx(float(get_film("keratin").n_film(550.0)))
    # the universal network is the same in both variants
    assert UsdShade.Material(st.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial")).ComputeSurfaceSource()[0]


def _mesh_thickness_range(stage) -> tuple:
    """(min, max) nm of the feather mesh's thickness primvar: what the preview atlas spans."""
    from pxr import UsdGeom

    prim = stage.GetPrimAtPath("/Pigeon/Geom/NeckFeathers")
    d = np.asarray(UsdGeom.PrimvarsAPI(prim).GetPrimvar("thickness").Get(), np.float64)
    return float(d.min()), float(d.max())


def _preview_tiles(preview, thickness_range_nm):
    """The atlas tiles of feather_preview.png, thinnest first (bottom row first), and their thickness, nm."""
    from rockdove.usd.textures_io import PREVIEW_TILE_TEXELS, preview_atlas_shape, preview_tile_thickness_nm

    d = preview_tile_thickness_nm(thickness_range_nm)
    cols, rows = preview_atlas_shape(d.size)
    t = PREVIEW_TILE_TEXELS
    assert preview.shape == (rows * t, cols * t, 4)
    tiles = [preview[(rows - 1 - k // cols) * t:(rows - k // cols) * t, (k % cols) * t:(k % cols + 1) * t]
             for k in range(d.size)]
    return tiles, d


def _tile(image, t):
    from PIL import Image

    return np.asarray(Image.fromarray(image).resize((t, t), Image.BOX))


def test_preview_atlas_mixes_base_and_the_structural_colour_of_each_thickness_by_the_mask(asset, stage):
    import colour
    from PIL import Image

    from rockdove.lut.exr import read_exr
    from rockdove.usd.textures_io import PREVIEW_COS_THETA, PREVIEW_TILE_TEXELS

    lut = read_exr(asset["lut"])
    t = PREVIEW_TILE_TEXELS
    base = _tile(np.asarray(Image.open(asset["feather_base"])), t)
    mask = _tile(np.asarray(Image.open(asset["feather_mask"])), t)
    tiles, d = _preview_tiles(np.asarray(Image.open(asset["feather_preview"])), _mesh_thickness_range(stage))
    assert len(tiles) > 1  # the measured film's thickness varies: one tile per thickness step
    tip, plain = (mask == 255) & (base[..., 3] == 255), (mask == 0) & (base[..., 3] == 255)
    assert tip.any() and plain.any()
    for tile, dk in zip(tiles, d):
        assert np.abs(tile[..., 3].astype(int) - base[..., 3]).max() <= 1
        structural = colour.cctf_encoding(np.clip(lut.sample(PREVIEW_COS_THETA, dk), 0, 1), function="sRGB")
        assert np.abs(tile[tip][:, :3] - np.round(structural * 255)).max() <= 1, dk
        assert np.abs(tile[plain][:, :3].astype(int) - base[plain][:, :3]).max() <= 1
    assert len({tuple(tile[tip][0, :3]) for tile in tiles}) > len(tiles) // 2  # the colours differ


def test_write_png_is_lossless_and_byte_deterministic(tmp_path):
    """write_png (rockdove.png at a fixed zlib level) decodes to the same pixels for grey, RGB and
    RGBA, writes the same bytes twice, and holds only the IHDR, IDAT and IEND chunks (no time or text)."""
    import struct

    from PIL import Image

    from rockdove.usd.textures_io import write_png

    rng = np.random.default_rng(7)
    smooth = np.linspace(0, 255, 96 * 64).reshape(96, 64).astype(np.uint8)
    for shape in [(96, 64), (96, 64, 3), (96, 64, 4)]:
        pixels = rng.integers(0, 256, shape, dtype=np.uint8)
        pixels[:48] = smooth[:48, :, None] if len(shape) == 3 else smooth[:48]
        a, b = (write_png(str(tmp_path / f"{name}.png"), pixels) for name in "ab")
        data = open(a, "rb").read()
        assert data == open(b, "rb").read()
        np.testing.assert_array_equal(np.asarray(Image.open(a)), pixels)
        chunks, pos = [], 8
        while pos < len(data):
            length, kind = struct.unpack(">I4s", data[pos:pos + 8])
            chunks.append(kind.decode())
            pos += 12 + length
        assert chunks[0] == "IHDR" and chunks[-1] == "IEND" and set(chunks[1:-1]) == {"IDAT"}, chunks


@pytest.mark.parametrize("side", [40, 256])
def test_preview_atlas_is_the_texel_by_texel_mix_of_each_tile_resized(side):
    """feather_preview_atlas's bytes are those of the plain formula: every texel mixed in linear light and
    sRGB-encoded (its alpha kept), each tile resized alone with Pillow's box filter, placed bottom row first;
    random texels (every one distinct), colours out of [0, 1] included, up- and down-sized tiles."""
    from PIL import Image

    from rockdove.srgb import srgb_decode, srgb_encode
    from rockdove.usd.textures_io import PREVIEW_TILE_TEXELS, feather_preview_atlas, preview_atlas_shape

    rng = np.random.default_rng(side)
    base = rng.integers(0, 256, (side, side, 4), dtype=np.uint8)
    mask = rng.choice(np.array([0, 1, 37, 128, 254, 255], np.uint8), (side, side))
    colours = rng.uniform(-0.2, 1.2, (11, 3))
    t = PREVIEW_TILE_TEXELS
    cols, rows = preview_atlas_shape(len(colours))
    expected = np.zeros((rows * t, cols * t, 4), np.uint8)
    m = mask[..., None] / 255.0
    for k, c in enumerate(colours):
        tile = base.copy()
        lin = srgb_decode(base[..., :3] / 255.0) * (1.0 - m) + np.clip(c, 0.0, 1.0) * m
        tile[..., :3] = np.round(srgb_encode(np.clip(lin, 0.0, 1.0)) * 255.0).astype(np.uint8)
        tile = np.asarray(Image.fromarray(tile, "RGBA").resize((t, t), Image.BOX))
        top = (rows - 1 - k // cols) * t
        expected[top:top + t, (k % cols) * t:(k % cols + 1) * t] = tile
    np.testing.assert_array_equal(feather_preview_atlas(base, mask, colours), expected)


def test_each_card_reads_the_preview_tile_of_its_own_thickness(stage, asset):
    from pxr import UsdGeom

    from rockdove.lut.exr import read_exr
    from rockdove.usd.textures_io import PREVIEW_COLUMNS, PREVIEW_TILE_TEXELS

    lut = read_exr(asset["lut"])
    api = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Pigeon/Geom/NeckFeathers"))
    pst = np.asarray(api.GetPrimvar("previewST").Get())
    st = np.asarray(api.GetPrimvar("st").Get())
    d = np.asarray(api.GetPrimvar("thickness").Get(), np.float64)
    assert api.GetPrimvar("previewST").GetInterpolation() == "vertex" and pst.shape == st.shape
    from rockdove.usd.textures_io import preview_tile_thickness_nm

    tiles = preview_tile_thickness_nm((d.min(), d.max()))  # the mesh's range, not the LUT's (rounded out to nm)
    assert tuple(lut.thickness_range_nm) != (d.min(), d.max())
    cols = min(tiles.size, PREVIEW_COLUMNS)
    rows = -(-tiles.size // cols)
    k = (np.floor(pst[:, 0] * cols) + cols * np.floor(pst[:, 1] * rows)).astype(int)
    nearest = np.argmin(np.abs(d[:, None] - tiles[None, :]), axis=1)
    assert np.array_equal(k, nearest)  # the tile whose thickness is nearest the card's
    inner = np.stack([(pst[:, 0] * cols) % 1.0, (pst[:, 1] * rows) % 1.0], axis=1) * PREVIEW_TILE_TEXELS
    assert np.allclose(inner, 0.5 + st * (PREVIEW_TILE_TEXELS - 1), atol=2e-3)  # the feather's st in the tile


def test_rebuild_is_byte_identical(asset, tmp_path):
    """The same configuration built again from nothing (a fresh cache) gives the same bytes in every file."""
    again = _paths(real_build(tmp_path / "pigeon", tmp_path / "cache"))
    a, b = asset["dir"], again["dir"]
    names = sorted(os.path.relpath(os.path.join(d, f), a) for d, _, fs in os.walk(a) for f in fs)
    assert "pigeon.usdz" in names and "textures/thinfilm_lut.exr" in names
    assert {"pigeon_geom.usdc", "pigeon_looks.usda", "pigeon_payload.usda", "pigeon.glb"} <= set(names)
    with open(os.path.join(a, "pigeon_geom.usdc"), "rb") as fh:
        assert fh.read(8) == b"PXR-USDC"  # the geometry is a crate file, and rebuilt byte for byte
    match, mismatch, errors = filecmp.cmpfiles(a, b, names, shallow=False)
    assert mismatch == [] and errors == [] and len(match) == len(names)


def test_film_change_rewrites_the_looks_and_leaves_the_geometry_layer_bytes(asset, build_root, tmp_path):
    """Layers split by what changes them: another film gives another looks layer over the same geometry."""
    from pxr import Sdf, Usd

    other = _paths(real_build(tmp_path / "pigeon", build_root / "cache", 'film.model="paper"', "film.cauchy_a=1.5",
                              "film.cauchy_b_nm2=0.0"))
    same = [n for n in ("pigeon_geom.usdc", "pigeon.usda", "pigeon_payload.usda")
            if filecmp.cmp(os.path.join(asset["dir"], n), os.path.join(other["dir"], n), shallow=False)]
    assert same == ["pigeon_geom.usdc", "pigeon.usda", "pigeon_payload.usda"]
    assert not filecmp.cmp(asset["looks"], other["looks"], shallow=False)
    assert Sdf.Layer.FindOrOpen(asset["payload"]).subLayerPaths == ["./pigeon_looks.usda", "./pigeon_rig.usdc",
                                                                     "./pigeon_geom.usdc"]
    geom = Sdf.Layer.FindOrOpen(asset["geometry"])
    assert geom.GetFileFormat().formatId == "usdc" and not geom.GetPrimAtPath("/Pigeon/Looks")
    assert not geom.GetAttributeAtPath("/Pigeon/Geom/NeckFeathers.rockdove:film:cauchyA")
    looks = Sdf.Layer.FindOrOpen(asset["looks"])
    assert not looks.GetAttributeAtPath("/Pigeon/Geom/NeckFeathers.points")
    composed = Usd.Stage.Open(other["interface"])
    film = composed.GetPrimAtPath("/Pigeon/Geom/NeckFeathers")
    assert film.GetTypeName() == "Mesh" and film.GetAttribute("rockdove:film:model").Get() == "paper"


def test_usdz_reopens_and_holds_every_texture(asset):
    from pxr import Sdf, Usd

    from rockdove.usd.validate import read_texture_asset

    names = zipfile.ZipFile(asset["usdz"]).namelist()
    assert names[0] == "pigeon.usda"
    for role in ("lut", "feather_base", "feather_mask", "feather_preview", "body_base", "plumage_base",
                 "plumage_normal"):
        assert os.path.relpath(asset[role], asset["dir"]) in names
    st = Usd.Stage.Open(asset["usdz"])
    resolved = []
    for prim in st.Traverse():
        for attr in prim.GetAttributes():
            if attr.GetTypeName() == Sdf.ValueTypeNames.Asset and attr.Get() is not None:
                path = attr.Get().resolvedPath
                assert path.startswith(asset["usdz"] + "["), (attr.GetPath(), path)
                read_texture_asset(path)  # decodes from inside the package
                resolved.append(path)
    assert len(set(resolved)) == 7


def test_usdz_in_place_is_the_same_package_as_from_a_copy(asset, tmp_path):
    """write_usdz(in_place=True) (the build's usdz stage, packaging its own scratch copy) writes the bytes of the
    copying route, which leaves the folder's files as they were; both equal the built package."""
    import shutil

    from rockdove.usd.usdz import ZIP_EPOCH, write_usdz

    copied, in_place = tmp_path / "copied", tmp_path / "in_place"
    for folder in (copied, in_place):
        shutil.copytree(asset["dir"], folder, ignore=shutil.ignore_patterns("*.usdz", "*.glb"))
    looks_mtime = os.stat(copied / "pigeon_looks.usda").st_mtime_ns
    a = write_usdz(str(copied))
    b = write_usdz(str(in_place), in_place=True)
    assert open(a, "rb").read() == open(b, "rb").read() == open(asset["usdz"], "rb").read()
    assert os.stat(copied / "pigeon_looks.usda").st_mtime_ns == looks_mtime != ZIP_EPOCH * 10**9
    assert os.stat(in_place / "textures" / "feather_base.png").st_mtime == ZIP_EPOCH
    assert sorted(os.listdir(in_place)) == sorted(os.listdir(copied))  # no temporaries left


def test_failed_build_keeps_previous_asset_and_leaves_no_temporaries(build_root, tmp_path, monkeypatch):
    """A build that fails mid-way (here: the glTF export, which runs on the asset assembled in the staging folder
    beside the output) publishes nothing: the asset already there is left as it was, and no staging folder is
    left beside it."""
    from rockdove.graph import stages

    out = tmp_path / "pigeon"
    first = _paths(real_build(out, build_root / "cache"))
    before = {n: open(first[n], "rb").read() for n in ("payload", "looks", "lut")}

    def fails(ctx):
        assert ctx.asset_dir.name.startswith(".pigeon.") and ctx.asset_dir.parent == tmp_path  # the staging
        raise ValueError("gltf failed on purpose")

    monkeypatch.setattr(stages, "run_gltf", fails)
    with pytest.raises(ValueError, match="on purpose"):
        real_build(out, build_root / "cache", "film.cauchy_a=1.6")  # a new film: layers and glb are rewritten
    assert {n: open(first[n], "rb").read() for n in before} == before
    assert sorted(p for p in os.listdir(tmp_path) if not p.endswith(".rockdove.lock")) == ["pigeon"]
    umask = os.umask(0)
    os.umask(umask)
    assert os.stat(out).st_mode & 0o777 == 0o777 & ~umask  # not mkdtemp's 0700


def test_bad_inputs_raise_value_errors_naming_them(bird, tmp_path):
    from rockdove.errors import UsageError
    from rockdove.geometry import Bird
    from rockdove.usd.stage import write_layers

    with pytest.raises(UsageError, match="pigeon"):
        real_build(tmp_path / "x", tmp_path / "cache", preset="pigeon")
    no_feathers = Bird(tuple(p for p in bird.parts if p.material != "feather"))
    with pytest.raises(ValueError, match="feather"):
        write_layers(str(tmp_path / "y"), no_feathers, get_film("keratin"), None, version="0", shading="physical")
    assert not (tmp_path / "x").exists()


def test_paper_preset_bakes_a_one_texel_high_lut_over_exactly_650_nm_and_validates(paper_asset):
    """The paper preset's single film thickness gives a one-texel-high LUT whose domain is exactly 650 nm, and
    the asset validates clean."""
    from rockdove.lut.exr import read_exr
    from rockdove.usd.validate import validate_asset

    lut = read_exr(_paths(paper_asset)["lut"])
    angles = int(dict(s.split("=") for s in SMALL_BUILD)["lut.angles"])
    assert lut.n_thickness == 1 and lut.thickness_range_nm == (650.0, 650.0) and lut.n_angle == angles
    assert lut.metadata["film:name"] == "paper"  # the baker's provenance, which validation compares with USD
    report = validate_asset(str(paper_asset))
    assert report.clean, report.format()


# ------------------------------------------------------------------------- shading.variant: physical / baked only
@pytest.fixture(scope="module")
def physical(physical_asset):
    """The small physical-only build (measured preset: keratin, thickness varies): its files by role."""
    return _paths(physical_asset)


def test_physical_only_asset_has_no_lut_and_only_the_physical_variant(physical):
    from pxr import Usd, UsdShade

    from rockdove.usd.schema import read_thin_film
    from rockdove.usd.stage import open_asset
    from rockdove.usd.validate import validate_asset

    assert "lut" not in physical
    assert not os.path.exists(os.path.join(physical["dir"], "textures", "thinfilm_lut.exr"))
    assert not [n for n in zipfile.ZipFile(physical["usdz"]).namelist() if n.endswith(".exr")]
    stage = open_asset(physical["interface"])
    vset = stage.GetPrimAtPath("/Pigeon").GetVariantSet("shading")
    assert vset.GetVariantNames() == ["physical"] and vset.GetVariantSelection() == "physical"
    mat = UsdShade.Material(stage.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial"))
    surface, _, _ = mat.ComputeSurfaceSource("mtlx")
    assert surface.GetPath().name == "MtlxPhysicalSurface"
    assert mat.ComputeSurfaceSource()[0].GetShaderId() == "UsdPreviewSurface"
    names = {p.GetName() for p in Usd.PrimRange(mat.GetPrim())}
    assert not names & {"LutTexture", "LutAngleCount", "MtlxBakedSurface", "StructuralMix", "LutTexcoord"}
    assert {"BaseColorTexture", "MaskTexture", "ThicknessUm", "FilmIor"} <= names
    film = read_thin_film(stage.GetPrimAtPath("/Pigeon/Geom/NeckFeathers"))
    assert film["model"] == "keratin" and film["cauchy_b_nm2"] == pytest.approx(5890)
    assert film["lut_file"] == "" and film["thickness_range_nm"] is None and film["angle_warp_gamma"] is None
    assert not [a for a in stage.GetPrimAtPath("/Pigeon/Geom/NeckFeathers").GetAuthoredAttributes()
                if a.GetName().startswith("rockdove:lut:")]
    for path in (physical["dir"], physical["usdz"]):
        report = validate_asset(path)
        assert report.clean and report.variants == [f"motion={m}, shading=physical" for m in ("idle", "rest", "walk")]


def test_physical_only_preview_atlas_holds_the_exact_colours(physical):
    import colour
    from PIL import Image

    from rockdove.lut.reference import reference_colour
    from rockdove.usd.stage import open_asset
    from rockdove.usd.textures_io import PREVIEW_COS_THETA, PREVIEW_TILE_TEXELS

    mask = _tile(np.asarray(Image.open(physical["feather_mask"])), PREVIEW_TILE_TEXELS)
    alpha = _tile(np.asarray(Image.open(physical["feather_base"])), PREVIEW_TILE_TEXELS)[..., 3]
    tiles, d = _preview_tiles(np.asarray(Image.open(physical["feather_preview"])),
                              _mesh_thickness_range(open_asset(physical["interface"])))
    for k in (0, len(d) // 2, len(d) - 1):
        exact = reference_colour(PREVIEW_COS_THETA, d[k], get_film("keratin"), colour_space="lin_rec709")
        structural = colour.cctf_encoding(np.clip(exact, 0, 1), function="sRGB")
        tip = (mask == 255) & (alpha == 255)
        assert tip.any() and np.abs(tiles[k][tip][:, :3] - np.round(structural * 255)).max() <= 1


def test_baked_only_asset_has_only_the_baked_variant(build_root, tmp_path):
    from pxr import Usd, UsdShade

    from rockdove.usd.stage import open_asset
    from rockdove.usd.validate import validate_asset

    a = _paths(real_build(tmp_path / "pigeon", build_root / "cache", 'shading.variant="baked"', "usd.usdz=false",
                          "gltf.glb=false"))
    assert "usdz" not in a  # usd.usdz = false writes none
    stage = open_asset(a["interface"])
    vset = stage.GetPrimAtPath("/Pigeon").GetVariantSet("shading")
    assert vset.GetVariantNames() == ["baked"] and vset.GetVariantSelection() == "baked"
    mat = UsdShade.Material(stage.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial"))
    assert mat.ComputeSurfaceSource("mtlx")[0].GetPath().name == "MtlxBakedSurface"
    names = {p.GetName() for p in Usd.PrimRange(mat.GetPrim())}
    assert "MtlxPhysicalSurface" not in names and "ThicknessUm" not in names and "LutTexture" in names
    report = validate_asset(a["dir"])
    assert report.clean and report.variants == [f"motion={m}, shading=baked" for m in ("idle", "rest", "walk")]


def test_lutless_layers_refuse_a_baked_variant(small_asset, bird, tmp_path):
    from rockdove.usd.stage import write_layers

    with pytest.raises(ValueError, match="shading='both' needs a LUT"):
        write_layers(str(tmp_path), bird, get_film("keratin"), None, version="0",
                     shading="both")
    with pytest.raises(ValueError, match="shading='gold'"):
        write_layers(str(tmp_path), bird, get_film("keratin"), None, version="0",
                     shading="gold")
    from rockdove.usd.textures_io import write_film_textures

    feather, body = built_value(small_asset, "texture_images")
    with pytest.raises(ValueError, match="lut=None needs the film"):
        write_film_textures(str(tmp_path), None, feather, thickness_range_nm=(500.0, 600.0))
    assert not (tmp_path / "textures").exists()  # nothing written


def _source(shader_input):
    from pxr import UsdShade

    return UsdShade.Shader(shader_input.GetConnectedSources()[0][0].source.GetPrim())


def test_physical_variant_is_the_recorded_film_in_each_shaders_units(asset):
    """OpenPBR's thin film lies on the base's specular_ior: the authored network must put the recorded film
    (RockDoveThinFilmAPI: film index at 550 nm, substrate index) on the recorded substrate, with the thickness
    primvar in micrometres. Fails on an asset whose specular_ior is left at OpenPBR's 1.5 (film on glass)."""
    from pxr import UsdShade

    from rockdove.usd.schema import read_thin_film
    from rockdove.usd.stage import FILM_IOR_WAVELENGTH_NM, open_asset

    st = open_asset(asset["interface"], shading="physical")
    film = read_thin_film(st.GetPrimAtPath("/Pigeon/Geom/NeckFeathers"))
    surface = UsdShade.Material(st.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial")).ComputeSurfaceSource("mtlx")[0]
    assert surface.GetShaderId() == "ND_open_pbr_surface_surfaceshader"

    def value(name):
        inp = surface.GetInput(name)
        assert inp, f"{name} is not authored (OpenPBR's default would be used)"
        return _source(inp).GetInput("value").Get() if inp.HasConnectedSource() else inp.Get()

    n_incident = film["incident_index"]
    n_550 = film["cauchy_a"] + film["cauchy_b_nm2"] / FILM_IOR_WAVELENGTH_NM**2
    assert value("specular_ior") == pytest.approx(film["substrate_index"] / n_incident, abs=1e-6)
    assert value("specular_ior") == pytest.approx(1.0)  # the asset models a film in air
    assert value("thin_film_ior") == pytest.approx(n_550 / n_incident, abs=1e-5)
    thickness = _source(surface.GetInput("thin_film_thickness"))
    assert thickness.GetShaderId() == "ND_multiply_float" and thickness.GetInput("in2").Get() == pytest.approx(1e-3)
    primvar = _source(thickness.GetInput("in1"))
    assert primvar.GetShaderId() == "ND_geompropvalue_float"
    assert primvar.GetInput("geomprop").Get() == film["thickness_primvar"] and film["thickness_units"] == "nm"
    assert _source(surface.GetInput("thin_film_weight")).GetPath().name == "MaskTexture"

"""materials/thinfilm.mtlx: validates against MaterialX's libraries, generates GLSL headlessly, is copied
faithfully into USD, and its LUT texcoord arithmetic is exactly ThinFilmLUT.texcoords (texel centres, warp)."""

import numpy as np
import pytest

from rockdove.lut import ThinFilmLUT
from rockdove.usd.material import (
    MTLX_MATERIALS,
    author_feather_material,
    load_thinfilm_document,
    lut_info,
    lut_transform,
    mtlx_nodes,
)


@pytest.fixture(scope="module")
def doc():
    return load_thinfilm_document()


def _glsl(doc, material):
    import MaterialX as mx
    import MaterialX.PyMaterialXGenGlsl as mx_glsl
    import MaterialX.PyMaterialXGenShader as mx_gen

    gen = mx_glsl.GlslShaderGenerator.create()
    ctx = mx_gen.GenContext(gen)
    ctx.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
    shader = gen.generate(material, doc.getChild(material), ctx)
    return shader.getSourceCode(mx_gen.VERTEX_STAGE), shader.getSourceCode(mx_gen.PIXEL_STAGE)


def test_document_validates_against_the_standard_libraries(doc):
    ok, message = doc.validate()
    assert ok, message
    assert {n.getName() for n in doc.getNodes() if n.getType() == "material"} == set(MTLX_MATERIALS.values())
    for node in mtlx_nodes(doc):  # every node names its nodedef explicitly, as USD's info:id will
        assert node.getNodeDefString() == node.getNodeDef().getName()


def test_glsl_generation_of_the_baked_network_reads_thickness_and_three_textures(doc):
    vertex, pixel = _glsl(doc, MTLX_MATERIALS["baked"])
    assert "i_geomprop_thickness" in vertex
    for sampler in ("LutTexture_file", "BaseColorTexture_file", "MaskTexture_file"):
        assert f"uniform sampler2D {sampler};" in pixel
    assert "IMP_UsdUVTexture_23(LutTexture_file" in pixel and "void main()" in pixel


def _call_arguments(source: str, function: str) -> dict:
    """Parameter name -> argument expression of the (last) call to ``function`` in generated GLSL."""
    import re

    signature = re.search(rf"void {function}\(([^)]*)\)", source).group(1)
    params = [p.split()[-1] for p in signature.split(",")]
    call = re.findall(rf"\n\s*{function}\(([^;]*)\);", source)[-1]
    return dict(zip(params, (a.strip() for a in call.split(","))))


def test_glsl_generation_of_the_physical_network_drives_the_thin_film(doc):
    """The generated OpenPBR call takes its film from our network: thickness = the thickness primvar in
    micrometres, weight = the tip mask, index = the film's, specular_ior = the recorded substrate."""
    _, pixel = _glsl(doc, MTLX_MATERIALS["physical"])
    assert "LutTexture_file" not in pixel and "void main()" in pixel  # no LUT: OpenPBR's own thin film
    args = _call_arguments(pixel, "NG_open_pbr_surface_surfaceshader")
    assert args["thin_film_weight"] == "MaskTexture_r"
    assert args["thin_film_ior"] == "MtlxPhysicalSurface_thin_film_ior"
    assert args["specular_ior"] == "MtlxPhysicalSurface_specular_ior"
    assert args["thin_film_thickness"] == "ThicknessUm_out"
    assert "float ThicknessUm_out = ThicknessPrimvar_out * ThicknessUm_in2;" in pixel
    assert "float ThicknessPrimvar_out = vd.i_geomprop_thickness;" in pixel


def _stage_with_material(lut):
    from pxr import Usd

    stage = Usd.Stage.CreateInMemory()
    mat = author_feather_material(stage, "/Looks/FeatherMaterial", lut=lut_info(lut), film_ior=1.55)
    return stage, mat


def test_usd_network_is_the_document_node_for_node(doc):
    from pxr import UsdShade

    lut = ThinFilmLUT(np.zeros((4, 8, 3), np.float32), (500.0, 700.0), angle_warp_gamma=2.0)
    stage, mat = _stage_with_material(lut)
    set_by_build = {"LutTransform", "LutAngleWarpExponent", "FilmIor"}
    for node in mtlx_nodes(doc):
        shader = UsdShade.Shader(stage.GetPrimAtPath(f"/Looks/FeatherMaterial/{node.getName()}"))
        assert shader, node.getName()
        assert shader.GetShaderId() == node.getNodeDefString()
        assert sorted(i.GetBaseName() for i in shader.GetInputs()) == sorted(i.getName() for i in node.getInputs())
        for inp in node.getInputs():
            usd_in = shader.GetInput(inp.getName())
            if inp.getNodeName():
                src = usd_in.GetConnectedSources()[0][0]
                assert src.source.GetPath().name == inp.getNodeName(), (node.getName(), inp.getName())
                assert src.sourceName == (inp.getOutputString() or "out"), (node.getName(), inp.getName())
            elif inp.getType() == "filename":
                assert usd_in.Get().path.endswith(inp.getValueString())
            elif node.getName() not in set_by_build and inp.getType() in ("float", "integer", "string", "boolean"):
                assert usd_in.Get() == pytest.approx(inp.getValue()), (node.getName(), inp.getName())
    values = {n: UsdShade.Shader(stage.GetPrimAtPath(f"/Looks/FeatherMaterial/{n}")).GetInput("value").Get()
              for n in set_by_build}
    assert np.ravel(values.pop("LutTransform")) == pytest.approx([7 / 8, 0, 0, 0, 3 / 800, 0, 1 / 16, -1.75, 1])
    assert values == pytest.approx({"LutAngleWarpExponent": -0.5, "FilmIor": 1.55})


# A numpy evaluator of the arithmetic nodes the LUT lookup uses, reading the USD shaders as authored.
_OPS = {
    "ND_constant_float": lambda i: i["value"],
    "ND_add_float": lambda i: i["in1"] + i["in2"],
    "ND_subtract_float": lambda i: i["in1"] - i["in2"],
    "ND_multiply_float": lambda i: i["in1"] * i["in2"],
    "ND_divide_float": lambda i: i["in1"] / i["in2"],
    "ND_max_float": lambda i: np.maximum(i["in1"], i["in2"]),
    "ND_clamp_float": lambda i: np.clip(i["in"], i["low"], i["high"]),
    "ND_power_float": lambda i: np.power(i["in1"], i["in2"]),
    "ND_absval_float": lambda i: np.abs(i["in"]),
    "ND_combine2_vector2": lambda i: np.stack(np.broadcast_arrays(i["in1"], i["in2"]), -1),
    "ND_constant_matrix33": lambda i: i["value"],
    "ND_transformmatrix_vector2M3": lambda i: (np.c_[i["in"], np.ones(len(i["in"]))] @ i["mat"])[:, :2],
}


def _evaluate(shader, leaves):
    from pxr import UsdShade

    name = shader.GetPath().name
    if name in leaves:
        return leaves[name]
    inputs = {}
    for inp in shader.GetInputs():
        sources = inp.GetConnectedSources()[0]
        if sources:
            inputs[inp.GetBaseName()] = _evaluate(UsdShade.Shader(sources[0].source.GetPrim()), leaves)
        else:
            inputs[inp.GetBaseName()] = np.asarray(inp.Get(), np.float64)
    return _OPS[shader.GetShaderId()](inputs)


@pytest.mark.parametrize("shape, rng_nm, gamma", [((8, 16), (480.0, 700.0), 2.0), ((5, 7), (450.0, 750.0), 1.0),
                                                   ((1, 32), (650.0, 650.0), 1.5)])
def test_lut_texcoords_match_the_table_contract_exactly(shape, rng_nm, gamma):
    from pxr import UsdShade

    lut = ThinFilmLUT(np.zeros(shape + (3,), np.float32), rng_nm, angle_warp_gamma=gamma)
    stage, _ = _stage_with_material(lut)
    texcoord = UsdShade.Shader(stage.GetPrimAtPath("/Looks/FeatherMaterial/LutTexture")).GetInput("st")
    graph = UsdShade.Shader(texcoord.GetConnectedSources()[0][0].source.GetPrim())
    rng = np.random.default_rng(1)
    n_dot_v = rng.uniform(-1, 1, 200)  # cards are seen from both sides: |N.V|
    n_dot_v[:3] = (0.0, 1.0, -1.0)
    d = rng.uniform(rng_nm[0] - 50, rng_nm[1] + 50, 200)  # outside the domain too: clamped
    uv = _evaluate(graph, {"NDotV": n_dot_v, "ThicknessPrimvar": d})
    n, m = shape[1], shape[0]  # the texture's clamp-to-edge reads the edge texel past the first or last centre
    uv = np.clip(uv, [0.5 / n, 0.5 / m], [1 - 0.5 / n, 1 - 0.5 / m])
    u, v = lut.texcoords(np.abs(n_dot_v), d)
    assert np.allclose(uv[:, 0], u, rtol=0, atol=1e-7)  # the warp exponent 1 / gamma - 1 is a float (32-bit) input
    assert np.allclose(uv[:, 1], v, rtol=0, atol=1e-12)


@pytest.mark.parametrize("space, tag", [("lin_rec709", "lin_rec709"), ("acescg", "acescg")])
def test_lut_texture_is_tagged_with_the_space_it_was_baked_in_a_name_materialx_knows(doc, space, tag):
    from pxr import UsdShade

    from rockdove.usd.material import MTLX_WORKING_SPACE

    assert doc.getColorSpace() == MTLX_WORKING_SPACE
    lut = ThinFilmLUT(np.zeros((2, 4, 3), np.float32), (500.0, 600.0), colour_space=space)
    stage, _ = _stage_with_material(lut)
    file_in = UsdShade.Shader(stage.GetPrimAtPath("/Looks/FeatherMaterial/LutTexture")).GetInput("file")
    assert file_in.GetAttr().GetColorSpace() == tag


@pytest.mark.parametrize("variant", ["baked", "physical"])
def test_authored_usd_network_rebuilt_as_hydra_does_validates_and_generates_glsl(variant):
    import MaterialX as mx
    import MaterialX.PyMaterialXGenGlsl as mx_glsl
    import MaterialX.PyMaterialXGenShader as mx_gen
    from pxr import UsdShade

    from rockdove.usd.material import usd_to_mtlx_document

    lut = ThinFilmLUT(np.zeros((4, 8, 3), np.float32), (500.0, 700.0), angle_warp_gamma=2.0)
    stage, _ = _stage_with_material(lut)
    name = {"baked": "MtlxBakedSurface", "physical": "MtlxPhysicalSurface"}[variant]
    surface = UsdShade.Shader(stage.GetPrimAtPath(f"/Looks/FeatherMaterial/{name}"))
    rebuilt = usd_to_mtlx_document(surface)
    ok, message = rebuilt.validate()
    assert ok, message
    if variant == "baked":
        assert rebuilt.getNode("LutTransform").getInput("value").getValueString().startswith("0.875, 0.0, 0.0")
        lut_file = rebuilt.getNode("LutTexture").getInput("file")
        assert lut_file.getValueString() == "./textures/thinfilm_lut.exr" and lut_file.getColorSpace() == "lin_rec709"
    else:
        assert rebuilt.getNode("LutTexture") is None  # only what the surface reaches
        assert rebuilt.getNode("FilmIor").getInput("value").getValue() == pytest.approx(1.55)
    gen = mx_glsl.GlslShaderGenerator.create()
    ctx = mx_gen.GenContext(gen)
    ctx.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
    material = [n for n in rebuilt.getNodes() if n.getType() == "material"][0]
    assert "void main()" in gen.generate("rebuilt", material, ctx).getSourceCode(mx_gen.PIXEL_STAGE)


def test_standalone_document_carries_the_default_builds_constants(doc):
    """materials/thinfilm.mtlx used on its own with the default build's LUT must be exact: its Lut* constants
    are the default configuration's LUT (size, warp, the thickness range on the default bird, rounded outward
    as the build does), FilmIor/SubstrateIor the default film, and the thickness default lies inside the LUT
    (a host that falls back to it, as generated OSL does, shows a colour of the bird, not the thinnest)."""
    import math

    from rockdove.config import load_config
    from rockdove.films import film_from_config
    from rockdove.geometry import build_bird
    from rockdove.geometry.params import BirdParams
    from rockdove.usd.stage import FILM_IOR_WAVELENGTH_NM

    cfg = load_config()
    d = np.asarray(build_bird(BirdParams.from_config(cfg)).part("NeckFeathers").primvars["thickness"].values, np.float64)
    lo, hi = float(math.floor(d.min())), float(math.ceil(d.max()))
    film = film_from_config(cfg["film"])
    n_inc = float(np.real(film.n_incident))
    transform = lut_transform({"n_angle": cfg["lut"]["angles"], "n_thickness": cfg["lut"]["thicknesses"],
                               "thickness_range_nm": (lo, hi)})
    matrix = doc.getNode("LutTransform").getInput("value").getValue()
    assert [matrix[i, j] for i in range(3) for j in range(3)] == pytest.approx(transform, rel=1e-6)  # float32
    expected = {"LutAngleWarpExponent": 1 / cfg["lut"]["angle_warp_gamma"] - 1,
                "FilmIor": float(np.real(film.n_film(FILM_IOR_WAVELENGTH_NM))) / n_inc,
                "SubstrateIor": float(np.real(film.n_substrate)) / n_inc}
    got = {name: doc.getNode(name).getInput("value").getValue() for name in expected}
    assert got == pytest.approx(expected, rel=1e-6)
    default = doc.getNode("ThicknessPrimvar").getInput("default").getValue()
    assert lo <= default <= hi

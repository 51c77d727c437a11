"""RockDoveThinFilmAPI: schema.usda, generatedSchema.usda, plugInfo.json and USD's registry agree; it applies
to meshes only; read_thin_film round-trips apply_thin_film."""

import json
import os
import subprocess
import sys

import pytest
from conftest import OUTSIDE

from rockdove import resources
from rockdove.usd.schema import ATTRIBUTE_TYPES, SCHEMA_NAME, apply_thin_film, read_thin_film, register

DESIGN_ATTRS = {  # docs/design.md, "USD asset"
    "rockdove:film:model": "token", "rockdove:film:cauchyA": "float", "rockdove:film:cauchyB_nm2": "float",
    "rockdove:film:k": "float",
    "rockdove:film:incidentIndex": "float", "rockdove:film:substrateIndex": "float",
    "rockdove:film:thicknessPrimvar": "token", "rockdove:film:thicknessUnits": "token",
    "rockdove:lut:file": "asset", "rockdove:lut:colorSpace": "token", "rockdove:lut:angleWarpGamma": "float",
    "rockdove:lut:thicknessRangeNm": "float2", "rockdove:lut:illuminant": "token",
    "rockdove:lut:observer": "string",
}


def _class_attrs(path):
    from pxr import Sdf

    layer = Sdf.Layer.OpenAsAnonymous(path)  # keep the layer alive while its specs are read
    spec = layer.GetPrimAtPath(f"/{SCHEMA_NAME}")
    return {a.name: (str(a.typeName), a.default, a.documentation or a.customData.get("userDocBrief"))
            for a in spec.attributes}


def test_source_and_generated_schema_agree_with_the_design():
    source = _class_attrs(os.path.join(str(resources.folder("schemas")), "schema.usda"))
    generated = _class_attrs(os.path.join(str(resources.folder("schemas")), "generatedSchema.usda"))
    assert {k: v[:2] for k, v in source.items()} == {k: v[:2] for k, v in generated.items()}
    assert {k: v[0] for k, v in generated.items()} == DESIGN_ATTRS
    for name, (_, _, doc) in source.items():  # every attribute documented; usdGenSchema keeps the first sentence
        assert doc and doc.startswith(generated[name][2].rstrip(".")), name


def test_usdgenschema_regenerates_the_committed_schema_files(tmp_path):
    """generatedSchema.usda and plugInfo.json are usdGenSchema's output for schema.usda (usd-core + jinja2)."""
    import shutil

    schemas = resources.folder("schemas")
    for name in ("schema.usda", "plugInfo.json"):  # plugInfo's hand-set paths (Root, ResourcePath) survive
        shutil.copy(schemas / name, tmp_path / name)
    out = subprocess.run([sys.executable, "-m", "pxr.Usd.usdGenSchema", "schema.usda", "."], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    for name in ("generatedSchema.usda", "plugInfo.json"):
        assert (tmp_path / name).read_text() == (schemas / name).read_text(), (
            f"schemas/{name} is not what usdGenSchema writes; run: python -m pxr.Usd.usdGenSchema "
            "schemas/schema.usda schemas")


def test_pluginfo_declares_a_single_apply_api_schema_for_meshes():
    text = (resources.folder("schemas") / "plugInfo.json").read_text()  # USD's JSON allows # comment lines
    info = json.loads("".join(line for line in text.splitlines(True) if not line.lstrip().startswith("#")))
    (plugin,) = info["Plugins"]
    (entry,) = plugin["Info"]["Types"].values()
    assert entry["schemaIdentifier"] == SCHEMA_NAME and entry["schemaKind"] == "singleApplyAPI"
    assert entry["apiSchemaCanOnlyApplyTo"] == ["Mesh"]


def _python(code):
    env = dict(os.environ)
    env.pop("PXR_PLUGINPATH_NAME", None)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=OUTSIDE, env=env,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_registry_definition_matches_generated_schema():
    # a fresh interpreter: USD builds its schema registry once per process, at the first stage opened
    names = _python(
        "from rockdove.usd.schema import register, SCHEMA_NAME\n"
        "assert register()\n"
        "from pxr import Usd\n"
        "d = Usd.SchemaRegistry().FindAppliedAPIPrimDefinition(SCHEMA_NAME)\n"
        "assert Usd.SchemaRegistry().GetSchemaKind(SCHEMA_NAME) == Usd.SchemaKind.SingleApplyAPI\n"
        "print(' '.join(sorted(d.GetPropertyNames())))\n")
    assert names.split() == sorted(DESIGN_ATTRS)


def test_attribute_types_in_code_match_generated_schema():
    generated = _class_attrs(os.path.join(str(resources.folder("schemas")), "generatedSchema.usda"))
    assert {f"rockdove:{k}": v for k, v in ATTRIBUTE_TYPES.items()} == {k: v[0] for k, v in generated.items()}


def test_applied_schema_is_written_the_same_whether_or_not_usd_registered_it():
    code = (
        "import sys\n"
        "from pxr import Usd\n"
        "{first}"
        "from rockdove.usd.schema import apply_thin_film, read_thin_film, register\n"
        "known = register()\n"
        "stage = Usd.Stage.CreateInMemory()\n"
        "mesh = stage.DefinePrim('/M', 'Mesh')\n"
        "apply_thin_film(mesh, model='keratin', cauchy_a=1.532, cauchy_b_nm2=5890.0, incident_index=1.0,\n"
        "                substrate_index=1.0, lut_file='./t.exr', lut_colour_space='lin_rec709',\n"
        "                angle_warp_gamma=2.0, thickness_range_nm=(480, 700))\n"
        "assert read_thin_film(mesh)['thickness_range_nm'] == (480.0, 700.0)\n"
        "sys.stdout.write(str(known) + '\\n' + stage.GetRootLayer().ExportToString())\n")
    registered = _python(code.format(first=""))
    frozen = _python(code.format(first="Usd.Stage.CreateInMemory().DefinePrim('/A', 'Mesh')  # registry built before register()\n"))
    assert registered.split("\n", 1)[0] == "True" and frozen.split("\n", 1)[0] == "False"
    assert registered.split("\n", 1)[1] == frozen.split("\n", 1)[1]
    assert 'prepend apiSchemas = ["RockDoveThinFilmAPI"]' in frozen


def test_apply_and_read_round_trip_and_refusals():
    from pxr import Usd

    register()
    stage = Usd.Stage.CreateInMemory()
    mesh = stage.DefinePrim("/M", "Mesh")
    apply_thin_film(mesh, model="paper", cauchy_a=1.5, cauchy_b_nm2=0.0, incident_index=1.0, substrate_index=1.0,
                    lut_file="./textures/thinfilm_lut.exr", lut_colour_space="acescg", angle_warp_gamma=2.5,
                    thickness_range_nm=(600, 700))
    film = read_thin_film(mesh)
    assert film["model"] == "paper" and film["cauchy_a"] == 1.5 and film["lut_colour_space"] == "acescg"
    assert film["angle_warp_gamma"] == 2.5 and film["thickness_range_nm"] == (600.0, 700.0)
    assert film["lut_file"] == "./textures/thinfilm_lut.exr" and film["lut_file_resolved"] == ""
    assert film["observer"] == "CIE 1931 2 Degree Standard Observer"
    xform = stage.DefinePrim("/X", "Xform")
    with pytest.raises(ValueError, match="Mesh"):
        apply_thin_film(xform, model="paper", cauchy_a=1.5, cauchy_b_nm2=0, incident_index=1, substrate_index=1,
                        lut_file="a.exr", lut_colour_space="lin_rec709", angle_warp_gamma=1,
                        thickness_range_nm=(1, 2))
    with pytest.raises(ValueError, match=SCHEMA_NAME):
        read_thin_film(stage.DefinePrim("/Plain", "Mesh"))


def test_every_film_value_is_also_a_custom_user_property_that_survives_schema_dropping_tools():
    from pxr import Usd

    from rockdove.usd.schema import ATTRIBUTE_TYPES, USER_PROPERTIES_PREFIX, apply_thin_film, register

    register()
    stage = Usd.Stage.CreateInMemory()
    mesh = stage.DefinePrim("/M", "Mesh")
    apply_thin_film(mesh, model="keratin", cauchy_a=1.532, cauchy_b_nm2=5890.0, incident_index=1.0,
                    substrate_index=1.0, lut_file="./textures/thinfilm_lut.exr", lut_colour_space="lin_rec709",
                    angle_warp_gamma=2.0, thickness_range_nm=(480, 700))
    for name in ATTRIBUTE_TYPES:
        schema_attr = mesh.GetAttribute(f"rockdove:{name}")
        user = mesh.GetAttribute(USER_PROPERTIES_PREFIX + name)
        assert user and user.IsCustom() and not schema_attr.IsCustom(), name
        value = schema_attr.Get()
        assert user.Get() == (value.path if ATTRIBUTE_TYPES[name] == "asset" else value), name

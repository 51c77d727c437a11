"""Validation of a written asset: clean on a good one; each kind of breakage reported by name and path;
``rockdove validate`` exit statuses 0 / 1 / 2."""

import json
import os
import shutil
import subprocess
import sys

import pytest
from conftest import OUTSIDE, built_value, copy_asset

from rockdove.lut.exr import read_exr
from rockdove.usd.stage import GEOMETRY_LAYER, LOOKS_LAYER
from rockdove.usd.validate import validate_asset

FEATHERS = "/Pigeon/Geom/NeckFeathers"


@pytest.fixture(scope="module")
def good(small_asset):
    """The session's small real build (read-only; ``broken`` edits a copy)."""
    return str(small_asset)


def _lut(out):
    return read_exr(os.path.join(out, "textures", "thinfilm_lut.exr"))


@pytest.fixture
def broken(good, tmp_path):
    """A copy of the good asset (without its usdz) and a function to edit one of its payload's layers (default
    the looks; ``GEOMETRY_LAYER`` for the meshes), written back in its own format (usda text, usdc crate)."""
    out = str(tmp_path / "pigeon")
    shutil.copytree(good, out, ignore=shutil.ignore_patterns("*.usdz"))

    def edit(fn, name=LOOKS_LAYER):
        _edit_layer(os.path.join(out, name), fn)

    return out, edit


def _edit_layer(path, fn):
    from pxr import Sdf

    layer = Sdf.Layer.OpenAsAnonymous(path)
    fn(layer)
    assert layer.Export(path), path


def _in(shading: str) -> tuple:
    """The variant labels of one shading variant under every motion."""
    return tuple(f"motion={m}, {shading}" for m in ("idle", "rest", "walk"))


def _errors(report, check):
    return [i for i in report.errors if i.check == check]


def test_good_asset_is_clean_in_every_variant_and_as_usdz(good):
    report = validate_asset(good)
    assert report.clean, report.format()
    assert report.variants == [f"motion={m}, shading={v}" for m in ("idle", "rest", "walk")
                               for v in ("baked", "physical")]
    assert report.counts["mtlx shaders"] >= 20 and report.counts["assets"] == 8  # + the plumage atlas and its normals
    n_materials = len({p.material for p in built_value(good, "bird").parts})  # body, feather, beak, eye, ...
    assert report.counts["thin films"] == 1 and report.counts["materials"] == n_materials > 3
    usdz = validate_asset(os.path.join(good, "pigeon.usdz"))
    assert usdz.clean, usdz.format()


def test_nvidia_validator_runs_and_its_nd_sdr_findings_are_left_to_materialx(good):
    report = validate_asset(good)
    assert not [i for i in report.errors if i.check.startswith("nvidia:")], report.format()
    # usd-core has no MaterialX Sdr plugin: NVIDIA's validator fails every ND_* id; check 2 covers them instead
    assert report.counts["nvidia ND_* ids left to mtlx"] >= report.counts["mtlx shaders"]
    assert not any("sdrRegistry" in i.message for i in report.issues)


def test_nvidia_validator_findings_are_reported_as_errors(broken):
    from pxr import Vt

    out, edit = broken

    def fn(layer):  # a point no face uses
        attr = layer.GetAttributeAtPath("/Pigeon/Geom/Beak.points")
        attr.default = Vt.Vec3fArray(list(attr.default) + [(1.0, 1.0, 1.0)])
        for name in ("normals", "primvars:st"):
            a = layer.GetAttributeAtPath(f"/Pigeon/Geom/Beak.{name}")
            a.default = type(a.default)(list(a.default) + [a.default[0]])

    edit(fn, GEOMETRY_LAYER)
    (issue,) = _errors(validate_asset(out), "nvidia:UnusedMeshTopologyChecker")
    assert issue.path == "/Pigeon/Geom/Beak" and "not referenced by the faces" in issue.message


def test_missing_texture_is_reported_with_its_attribute(broken):
    out, _ = broken
    os.remove(os.path.join(out, "textures", "feather_mask.png"))
    (issue,) = _errors(validate_asset(out), "texture")
    assert issue.path == "/Pigeon/Looks/FeatherMaterial/MaskTexture.inputs:file"
    assert "feather_mask.png" in issue.message and "does not resolve" in issue.message


def test_unreadable_texture_is_reported(broken):
    out, _ = broken
    with open(os.path.join(out, "textures", "body_base.png"), "wb") as fh:
        fh.write(b"not a png")
    (issue,) = _errors(validate_asset(out), "texture")
    assert issue.path == "/Pigeon/Looks/BodyMaterial/BaseColorTexture.inputs:file"
    assert "does not read" in issue.message


def test_wrong_primvar_size_is_reported(broken):
    from pxr import Vt

    out, edit = broken
    n_points = []

    def fn(layer):
        n_points.append(len(layer.GetAttributeAtPath(f"{FEATHERS}.points").default))
        layer.GetAttributeAtPath(f"{FEATHERS}.primvars:neckS").SetInfo("default", Vt.FloatArray([0.5] * 5))

    edit(fn, GEOMETRY_LAYER)
    (issue,) = _errors(validate_asset(out), "primvar")
    assert issue.path == f"{FEATHERS}.primvars:neckS"
    assert "5 values" in issue.message and f"expected {n_points[0]} " in issue.message


def test_unknown_nd_id_and_wrong_input_type_are_reported(broken):
    out, edit = broken

    def fn(layer):
        layer.GetAttributeAtPath("/Pigeon/Looks/FeatherMaterial/AngleX.info:id").default = "ND_bogus_float"
        spec = layer.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial/CosThetaFloor")
        spec.properties["inputs:in2"].SetInfo("typeName", "int")
        spec.properties["inputs:in2"].default = 1

    edit(fn)
    issues = {i.path: i.message for i in _errors(validate_asset(out), "mtlx")}
    assert "ND_bogus_float" in issues["/Pigeon/Looks/FeatherMaterial/AngleX.info:id"]
    assert "expects float" in issues["/Pigeon/Looks/FeatherMaterial/CosThetaFloor.inputs:in2"]
    assert len(issues) == 2


def test_thickness_outside_the_lut_domain_is_reported(broken):
    from pxr import Vt

    out, edit = broken

    def fn(layer):
        attr = layer.GetAttributeAtPath(f"{FEATHERS}.primvars:thickness")
        attr.default = Vt.FloatArray([900.0] * len(attr.default))

    edit(fn, GEOMETRY_LAYER)
    (issue,) = _errors(validate_asset(out), "thinFilm")
    assert issue.path == f"{FEATHERS}.primvars:thickness"
    lo, hi = _lut(out).thickness_range_nm
    assert f"[900, 900] nm, outside the LUT domain [{lo:g}, {hi:g}]" in issue.message


def test_lut_network_constants_that_disagree_with_the_exr_are_reported(broken):
    out, edit = broken
    edit(lambda layer: setattr(layer.GetAttributeAtPath(
        "/Pigeon/Looks/FeatherMaterial/LutAngleWarpExponent.inputs:value"), "default", 17.0))
    (issue,) = _errors(validate_asset(out), "thinFilm")
    assert issue.path == "/Pigeon/Looks/FeatherMaterial/LutAngleWarpExponent.inputs:value"
    assert "17.0 does not describe the LUT file" in issue.message
    assert f"x {_lut(out).n_angle} texels" in issue.message


def test_schema_film_that_is_not_the_lut_film_is_reported(paper_asset, tmp_path):
    """The paper asset's LUT rewritten with a header that says it was baked for keratin: the film the schema
    records (paper) no longer matches the LUT it names."""
    import dataclasses

    from rockdove.lut.exr import write_exr

    out = copy_asset(paper_asset, tmp_path / "pigeon")
    exr = out / "textures" / "thinfilm_lut.exr"
    lut = read_exr(exr)
    assert validate_asset(str(out)).clean and lut.metadata["film:name"] == "paper"  # before: they agree
    os.chmod(exr, 0o644)
    write_exr(dataclasses.replace(lut, metadata={**lut.metadata, "film:name": "keratin", "film:cauchyA": "1.532"}),
              exr)
    issues = {i.path: i.message for i in _errors(validate_asset(str(out)), "thinFilm")}
    assert sorted(issues) == [f"{FEATHERS}.rockdove:film:cauchyA", f"{FEATHERS}.rockdove:film:model"]
    assert "'paper' differs from the LUT file's film:name = 'keratin'" in issues[f"{FEATHERS}.rockdove:film:model"]


def test_connection_of_mismatched_types_is_reported_as_an_invalid_materialx_graph(broken):
    from pxr import Sdf

    out, edit = broken

    def fn(layer):  # a float input fed by a color3 output: each shader alone still matches its nodedef
        attr = layer.GetAttributeAtPath("/Pigeon/Looks/FeatherMaterial/StructuralMix.inputs:mix")
        attr.connectionPathList.explicitItems = [Sdf.Path("/Pigeon/Looks/FeatherMaterial/LutTexture.outputs:rgb")]

    edit(fn)
    report = validate_asset(out)
    issues = _errors(report, "material")
    assert [(i.path, i.variants) for i in issues] == [
        ("/Pigeon/Looks/FeatherMaterial.outputs:mtlx:surface", _in("shading=baked"))]
    assert "not a valid MaterialX graph" in issues[0].message and _errors(report, "mtlx") == []


def test_unresolved_mtlx_surface_is_reported_in_its_variant_only(broken):
    out, edit = broken
    def fn(layer):
        del layer.GetPrimAtPath("/Pigeon/Looks/FeatherMaterial").nameChildren["MtlxPhysicalSurface"]

    edit(fn)
    issues = _errors(validate_asset(out), "material")
    assert [(i.path, i.variants) for i in issues] == [
        ("/Pigeon/Looks/FeatherMaterial.outputs:mtlx:surface", _in("shading=physical"))]


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "rockdove.cli", "validate", *args], capture_output=True,
                          text=True, cwd=OUTSIDE, timeout=120)


def test_cli_exit_statuses_and_json(good, broken, tmp_path):
    ok = _cli(good, "--json")
    assert ok.returncode == 0, ok.stderr
    result = json.loads(ok.stdout)
    assert result["clean"] is True  # a folder: the layers and the usdz are both validated
    assert [os.path.basename(r["path"]) for r in result["reports"]] == ["pigeon.usda", "pigeon.usdz"]
    out, _ = broken
    os.remove(os.path.join(out, "textures", "feather_base.png"))
    bad = _cli(out)
    assert bad.returncode == 1
    assert "BaseColorTexture.inputs:file" in bad.stdout and "NOT CLEAN" in bad.stdout
    missing = _cli(str(tmp_path / "nowhere"))
    assert missing.returncode == 2 and "does not exist" in missing.stderr
    not_usd = tmp_path / "notes.txt"
    not_usd.write_text("hello")
    assert _cli(str(not_usd)).returncode == 2


def test_cli_reports_a_broken_usdz_beside_good_layers(good, tmp_path):
    out = tmp_path / "pigeon"
    shutil.copytree(good, out)
    with open(out / "pigeon.usdz", "r+b") as fh:  # damage the package's first stored file (the root layer)
        fh.seek(200)
        fh.write(b"#garbage#" * 8)
    result = _cli(str(out))
    assert result.returncode == 1, result.stdout + result.stderr
    assert "pigeon.usda: clean" in result.stdout
    assert "pigeon.usdz: NOT CLEAN" in result.stdout and "ERROR layer:" in result.stdout
    assert "does not parse: " in result.stdout and "1 error(s) in" in result.stderr


@pytest.fixture(scope="module")
def lutless(physical_asset):
    """The session's small physical-only build (no LUT). Read-only."""
    return str(physical_asset)


def test_lutless_asset_is_clean_but_still_checked(lutless, tmp_path):
    from pxr import Sdf

    report = validate_asset(lutless)
    assert report.clean and report.counts["thin films"] == 1, report.format()
    out = str(tmp_path / "pigeon")
    shutil.copytree(lutless, out)
    def add_lut_texture(layer):
        spec = Sdf.CreatePrimInLayer(layer, "/Pigeon/Looks/FeatherMaterial/LutTexture")
        spec.specifier, spec.typeName = Sdf.SpecifierDef, "Shader"
        Sdf.AttributeSpec(spec, "info:id", Sdf.ValueTypeNames.Token,
                          Sdf.VariabilityUniform).default = "ND_image_color3"

    counts = []

    def bad_thickness(layer):
        counts.extend(layer.GetAttributeAtPath(f"{FEATHERS}.faceVertexCounts").default)
        layer.GetAttributeAtPath(f"{FEATHERS}.primvars:thickness").default = [0.0] * 3  # wrong size and <= 0 nm

    _edit_layer(os.path.join(out, LOOKS_LAYER), add_lut_texture)
    _edit_layer(os.path.join(out, GEOMETRY_LAYER), bad_thickness)
    report = validate_asset(out)
    tf = {(i.path, i.message.split(" (")[0]) for i in _errors(report, "thinFilm")}
    assert ("/Pigeon/Looks/FeatherMaterial", "holds the baked LUT network") in tf, report.format()
    assert any("expected finite values > 0 nm" in i.message for i in _errors(report, "thinFilm"))
    assert any(i.path.endswith("primvars:thickness") for i in _errors(report, "primvar")) and len(counts)


# -- assets from elsewhere: outside paths and layers that do not parse ----------------------------------------
BASE_FILE = "/Pigeon/Looks/FeatherMaterial/BaseColorTexture.inputs:file"


def _point_texture_at(edit, path):
    edit(lambda layer: setattr(layer.GetAttributeAtPath(BASE_FILE), "default", path))


@pytest.mark.parametrize("where", ["absolute", "leaves the folder"])
def test_a_texture_outside_the_asset_is_reported_and_not_read(broken, tmp_path, monkeypatch, where):
    from rockdove.usd import validate as V

    out, edit = broken
    outside = tmp_path / "elsewhere" / "feather_base.png"  # a good PNG: only the path is wrong
    outside.parent.mkdir()
    shutil.copy(os.path.join(out, "textures", "feather_base.png"), outside)
    authored = str(outside) if where == "absolute" else os.path.relpath(outside, out)
    _point_texture_at(edit, authored)
    read = []
    real_read = V.read_texture_asset
    monkeypatch.setattr(V, "read_texture_asset", lambda p: read.append(p) or real_read(p))
    report = validate_asset(out)
    (issue,) = _errors(report, "assetPath")
    assert issue.path == BASE_FILE and repr(authored) in issue.message and "not read" in issue.message
    assert ("is absolute" if where == "absolute" else "leaves the asset's folder") in issue.message
    assert not [p for p in read if "elsewhere" in p], read  # never opened
    allowed = validate_asset(out, allow_external=True)
    assert allowed.clean, allowed.format()  # the flag reads it (a good PNG) and keeps the report as a warning
    assert [i.check for i in allowed.issues if i.check == "assetPath"] == ["assetPath"]
    assert any("elsewhere" in p for p in read)


def test_a_payload_from_elsewhere_is_not_composed(good, tmp_path):
    from pxr import Sdf

    out = tmp_path / "pigeon"
    shutil.copytree(good, out, ignore=shutil.ignore_patterns("*.usdz"))
    layer = Sdf.Layer.FindOrOpen(str(out / "pigeon.usda"))
    prim = layer.GetPrimAtPath("/Pigeon")
    prim.payloadList.ClearEdits()
    prim.payloadList.prependedItems = [Sdf.Payload(str(out / "pigeon_payload.usda"))]
    layer.Save()
    report = validate_asset(str(out))
    assert [(i.check, i.path) for i in report.errors] == [("assetPath", str(out / "pigeon.usda"))], report.format()
    assert "layer path" in report.errors[0].message and report.counts == {}  # nothing composed or checked


def test_a_layer_that_does_not_parse_is_reported_with_its_line(broken):
    out, _ = broken
    payload = os.path.join(out, LOOKS_LAYER)  # the text layer of the payload
    text = open(payload).read()
    with open(payload, "w") as fh:
        fh.write(text[: len(text) // 2])  # truncated mid-file
    line = text[: len(text) // 2].count("\n") + 1
    (issue,) = validate_asset(out).errors
    assert issue.check == "layer" and issue.path == payload
    assert f"line {line}," in issue.message and "the layer does not parse" in issue.message
    res = _cli(out)
    assert res.returncode == 1 and f"line {line}," in res.stdout and "Traceback" not in res.stderr
    verify = subprocess.run([sys.executable, "-m", "rockdove.cli", "verify", out, "--width", "32", "--height", "32"],
                            capture_output=True, text=True, cwd=OUTSIDE, timeout=120)
    assert verify.returncode == 1, verify.stderr
    assert f"{payload}: line {line}," in verify.stderr and "Traceback" not in verify.stderr


def test_verify_refuses_an_asset_that_names_files_elsewhere(broken):
    out, edit = broken
    _point_texture_at(edit, "/etc/passwd")
    verify = subprocess.run([sys.executable, "-m", "rockdove.cli", "verify", out, "--width", "32", "--height", "32"],
                            capture_output=True, text=True, cwd=OUTSIDE, timeout=120)
    assert verify.returncode == 1 and "'/etc/passwd' is absolute" in verify.stderr, verify.stderr
    assert not os.path.exists(os.path.join(out, "verify"))  # stopped before rendering anything


def test_nvidia_mesh_rule_findings_are_memoised_by_the_meshes_and_a_mesh_change_reruns_them(good, broken, tmp_path,
                                                                                           monkeypatch):
    """rockdove.usd.nvidia keeps the mesh rules' findings by a digest of the composed meshes: a second run
    reports what the memo holds (a planted finding shows it is read), a moved point misses it."""
    import json

    import usd_validation_nvidia as nv
    from pxr import Vt

    from rockdove.usd import nvidia

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    root = os.path.join(good, "pigeon.usda")
    first, _ = nvidia.run_nvidia_validator(root)
    full, _ = nvidia._findings(nv.ValidationEngine(variants=True).validate(root), root)
    assert {(i.check, i.path, i.message, i.severity) for i in first} == {(f"nvidia:{r}", w, m, s) for r, w, m, s in full}
    (memo,) = (tmp_path / "cache").rglob("usd-validation-nvidia-*/[!k]*.json")  # not its key.json
    planted = ["ManifoldChecker", "/Pigeon/Geom/Beak", "planted finding", "warning"]
    memo.write_text(json.dumps([planted]))
    second, _ = nvidia.run_nvidia_validator(root)
    assert [i.message for i in second if i.check == "nvidia:ManifoldChecker"] == ["planted finding"]

    out, edit = broken

    def move_a_point(layer):
        attr = layer.GetAttributeAtPath("/Pigeon/Geom/Beak.points")
        pts = list(attr.default)
        pts[0] = (pts[0][0] + 1e-3, pts[0][1], pts[0][2])
        attr.default = Vt.Vec3fArray(pts)

    edit(move_a_point, GEOMETRY_LAYER)
    third, _ = nvidia.run_nvidia_validator(os.path.join(out, "pigeon.usda"))
    assert "planted finding" not in [i.message for i in third]
    assert len(list((tmp_path / "cache").rglob("usd-validation-nvidia-*/[!k]*.json"))) == 2


def test_the_mesh_memo_survives_a_film_change_but_not_a_normals_change(broken):
    """The film record sits on the feather mesh (ThinFilmAPI): changing it must not invalidate the memoised
    mesh findings; the meshes' normals are read by NormalsWindingsChecker and must."""
    from pxr import Vt

    from rockdove.usd import nvidia

    out, edit = broken
    root = os.path.join(out, "pigeon.usda")
    before = nvidia.mesh_digest(root)
    edit(lambda layer: _set_film_attr(layer, 1.49))
    assert nvidia.mesh_digest(root) == before

    def flip_normals(layer):
        attr = layer.GetAttributeAtPath("/Pigeon/Geom/Beak.normals")
        attr.default = Vt.Vec3fArray([(-n[0], -n[1], -n[2]) for n in attr.default])

    edit(flip_normals, GEOMETRY_LAYER)
    assert nvidia.mesh_digest(root) != before


def _set_film_attr(layer, value):
    specs = [s for s in _all_attribute_specs(layer) if s.name.endswith("rockdove:film:cauchyA")]
    assert specs, "no film record in the looks layer"
    for spec in specs:
        spec.default = value


def _all_attribute_specs(layer):
    found = []
    layer.Traverse(layer.pseudoRoot.path, lambda path: found.append(layer.GetAttributeAtPath(path))
                   if path.IsPropertyPath() and layer.GetAttributeAtPath(path) else None)
    return found


# -- one rule for files from elsewhere, in every reader (issue 23: "Why" 2, 3, 8) -----------------------------
def _rockdove(*args, timeout=120):
    return subprocess.run([sys.executable, "-m", "rockdove.cli", *args], capture_output=True, text=True, cwd=OUTSIDE,
                          timeout=timeout)


def _readers(out, tmp_path):
    """validate, gltf and render of ``out``: each exits 1 with one line (and the report), writes nothing."""
    runs = {"validate": _rockdove("validate", out), "gltf": _rockdove("gltf", out, "--out", str(tmp_path / "o.glb")),
            "render": _rockdove("render", out, "--out", str(tmp_path / "r"), "--views", "1", "--width", "16",
                                "--height", "16")}
    for name, r in runs.items():
        assert r.returncode == 1 and "Traceback" not in r.stderr, (name, r.stderr)
    assert not (tmp_path / "o.glb").exists() and not (tmp_path / "r").exists()
    return runs


@pytest.mark.parametrize("target", ["a good PNG", "a FIFO (blocks whoever opens it)"])
def test_a_symlink_to_a_file_elsewhere_is_refused_unopened_by_every_reader(broken, tmp_path, target):
    out, _ = broken
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    link = os.path.join(out, "textures", "feather_base.png")
    if target.startswith("a FIFO"):
        os.mkfifo(elsewhere / "secret")
    else:
        shutil.copy(link, elsewhere / "secret")
    os.remove(link)
    os.symlink(elsewhere / "secret", link)
    for name, r in _readers(out, tmp_path).items():  # a FIFO opened would hang the reader past the timeout
        text = r.stdout + r.stderr
        assert f"asset path './textures/feather_base.png' is a symlink to {elsewhere / 'secret'}" in text, (name, text)


def test_a_symlinked_sublayer_elsewhere_is_not_composed(broken, tmp_path):
    out, _ = broken
    looks = os.path.join(out, LOOKS_LAYER)
    shutil.move(looks, tmp_path / "looks.usda")
    os.symlink(tmp_path / "looks.usda", looks)
    report = validate_asset(out)
    assert [i.check for i in report.errors] == ["assetPath"] and report.counts == {}, report.format()
    assert f"layer path './{LOOKS_LAYER}' is a symlink to {tmp_path / 'looks.usda'}" in report.errors[0].message


def _set_clips(out, clip):
    from pxr import Sdf

    layer = Sdf.Layer.FindOrOpen(os.path.join(out, "pigeon.usda"))
    layer.GetPrimAtPath("/Pigeon").SetInfo("clips", {"default": {"primPath": "/Pigeon", **clip}})
    layer.Save()


@pytest.mark.parametrize("key, where", [("assetPaths", "absolute"), ("assetPaths", "../"),
                                        ("manifestAssetPath", "../"), ("templateAssetPath", "../")])
def test_value_clips_elsewhere_are_refused(broken, tmp_path, key, where):
    from pxr import Gf, Sdf, Vt

    out, _ = broken
    (tmp_path / "clips").mkdir()
    for name in ("clip.usda", "clip.001.usda"):  # valid clip layers: only where they are is wrong
        (tmp_path / "clips" / name).write_text('#usda 1.0\ndef Xform "Pigeon" {}\n')
    path = str(tmp_path / "clips/clip.usda") if where == "absolute" else "../clips/clip.usda"
    clip = {"active": Vt.Vec2dArray([Gf.Vec2d(0, 0)]), "assetPaths": Sdf.AssetPathArray([Sdf.AssetPath("c.usda")])}
    if key == "templateAssetPath":
        clip = {"templateAssetPath": "../clips/clip.###.usda", "templateStartTime": 1.0, "templateEndTime": 1.0,
                "templateStride": 1.0}
    else:
        clip[key] = Sdf.AssetPathArray([Sdf.AssetPath(path)]) if key == "assetPaths" else Sdf.AssetPath(path)
    _set_clips(out, clip)
    report = validate_asset(out)
    assert any(i.check == "assetPath" and f"clips[default].{key}" in i.path and "clip" in i.message
               for i in report.errors), report.format()
    assert report.counts == {}  # nothing composed, so no clip opened


@pytest.mark.parametrize("bad", ["a clip layer that does not parse", "assetPaths that are not assets"])
def test_a_broken_clip_is_an_error_line_not_a_traceback(broken, tmp_path, bad):
    from pxr import Gf, Vt

    out, _ = broken
    if bad.startswith("a clip layer"):
        with open(os.path.join(out, "clip.usda"), "w") as fh:
            fh.write('#usda 1.0\ndef Xform "Pigeon" { float x = [\n')
        from pxr import Sdf

        _set_clips(out, {"active": Vt.Vec2dArray([Gf.Vec2d(0, 0)]),
                         "assetPaths": Sdf.AssetPathArray([Sdf.AssetPath("./clip.usda")])})
        says = "clip.usda: line 3, column 1: the layer does not parse"
    else:
        _set_clips(out, {"active": Vt.Vec2dArray([Gf.Vec2d(0, 0)]), "assetPaths": "./clip.usda"})
        says = "/Pigeon clips[default].assetPaths: './clip.usda' is not an asset[] list"
    for name, r in _readers(out, tmp_path).items():
        assert says in r.stdout + r.stderr, (name, r.stdout, r.stderr)


@pytest.mark.parametrize("layer, old", [("pigeon.usda", "@./pigeon_payload.usda@"),
                                        (LOOKS_LAYER, "@./textures/feather_base.png@")])
def test_an_asset_path_expression_is_reported_as_what_it_is(broken, tmp_path, layer, old):
    out, _ = broken
    path = os.path.join(out, layer)
    text = open(path).read()
    assert old in text
    with open(path, "w") as fh:
        fh.write(text.replace(old, '@`"/etc/passwd"`@'))
    for name, r in _readers(out, tmp_path).items():
        assert """path expression '`"/etc/passwd"`' (= '/etc/passwd') is absolute""" in r.stdout + r.stderr, name


def test_gltf_and_render_refuse_a_looks_layer_naming_etc_passwd(broken, tmp_path):
    out, _ = broken
    _point_texture_at(broken[1], "/etc/passwd")
    runs = _readers(out, tmp_path)
    assert all("asset path '/etc/passwd' is absolute" in r.stderr for n, r in runs.items() if n != "validate")
    ok = _rockdove("gltf", out, "--out", str(tmp_path / "o.glb"), "--allow-external-assets")
    assert ok.returncode == 0 and b"root:x:0" in (tmp_path / "o.glb").read_bytes()  # read only when allowed


def test_a_usdz_of_100k_files_is_one_summary(good, tmp_path):
    import zipfile

    big = tmp_path / "big.usdz"
    with zipfile.ZipFile(os.path.join(good, "pigeon.usdz")) as src, zipfile.ZipFile(big, "w") as dst:
        for info in src.infolist():
            dst.writestr(info, src.read(info))
        for i in range(100_000):
            dst.writestr(f"junk/f{i:06d}.txt", b"x")
    r = _rockdove("validate", str(big))
    assert r.returncode == 1 and len(r.stdout.splitlines()) <= 5 and len(r.stderr.splitlines()) == 1, r.stdout[:2000]
    n = len(zipfile.ZipFile(big).namelist())
    assert f"the package holds {n:,} files (first: pigeon.usda" in r.stdout and "at most 10,000" in r.stdout


def test_a_report_of_many_issues_is_summarised_per_check():
    from rockdove.usd.validate import Issue, Report

    report = Report("x.usdz", [Issue("texture", f"/P{i}", "bad") for i in range(5000)] + [Issue("mtlx", "/M", "m")])
    lines = report.format().splitlines()
    assert len(lines) == 3 + 20 + 1 + 1 and lines[-1] == "  ... and 4,980 more texture errors (not shown)"
    d = report.to_dict(per_check=10)
    assert len(d["issues"]) == 11 and d["omitted"] == {"texture errors": 4990} and d["n_errors"] == 5001


# -- never overwrite what rockdove did not write (issue 23: "Why" 4) -------------------------------------------
def test_out_folders_and_files_of_the_user_are_never_overwritten(good, tmp_path):
    mine = {}
    for folder, name in (("D", "index.html"), ("D", "sweep.json"), ("R", "contact_sheet.png"), ("V", "report.html")):
        (tmp_path / folder).mkdir(exist_ok=True)
        (tmp_path / folder / name).write_text("mine\n")
        mine[tmp_path / folder / name] = "mine\n"
    for name in ("my.glb", "L.exr", "Z/rockdove_blender.zip"):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text("mine\n")
        mine[tmp_path / name] = "mine\n"
    runs = [_rockdove("sweep", "--out", str(tmp_path / "D"), "--grid", "lut.angles=[16, 32]", "--no-verify"),
            _rockdove("render", good, "--out", str(tmp_path / "R"), "--views", "1", "--width", "16", "--height", "16"),
            _rockdove("verify", good, "--out", str(tmp_path / "V"), "--width", "16", "--height", "16"),
            _rockdove("gltf", good, "--out", str(tmp_path / "my.glb")),
            _rockdove("lut", "--out", str(tmp_path / "L.exr"), "--angles", "8", "--thicknesses", "4"),
            _rockdove("blender-addon", "--out", str(tmp_path / "Z"))]
    for r in runs:
        assert r.returncode == 2 and "rockdove did not" in r.stderr and len(r.stderr.splitlines()) == 1, r.stderr
    assert all(p.read_text() == text for p, text in mine.items())
    assert sorted(p.name for p in (tmp_path / "D").iterdir()) == ["index.html", "sweep.json"]
    for _ in range(2):  # a folder rockdove made is rockdove's: rendered into again
        r = _rockdove("render", good, "--out", str(tmp_path / "new"), "--views", "1", "--width", "16", "--height", "16")
        assert r.returncode == 0, r.stderr
    assert (tmp_path / "new/.rockdove-output.json").is_file() and (tmp_path / "new/contact_sheet.png").is_file()

    (tmp_path / "new").chmod(0o555)  # read-only: refused before rendering (as a user without root's override)
    try:
        cmd = [sys.executable, "-m", "rockdove.cli", "render", good, "--out", str(tmp_path / "new"), "--views", "1"]
        cmd = cmd if os.geteuid() else ["setpriv", "--bounding-set=-dac_override,-dac_read_search,-fowner", "--", *cmd]
        r = subprocess.run(cmd, capture_output=True, text=True, cwd=OUTSIDE, timeout=120)
        assert r.returncode == 2 and "is not writable (read-only)" in r.stderr and "Traceback" not in r.stderr, r.stderr
    finally:
        (tmp_path / "new").chmod(0o755)

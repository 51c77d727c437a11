"""The configuration: layering, the schema as the single source of defaults and docs, one-line errors."""

from __future__ import annotations

import dataclasses
import json

import jsonschema
import pytest

from rockdove import config as C
from rockdove.errors import UsageError


def test_schema_is_valid_draft_2020_12_and_documents_every_parameter():
    schema = C.load_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    for section, node in schema["properties"].items():
        assert node.get("description"), section
        for key, leaf in node.get("properties", {}).items():
            assert leaf.get("description"), f"{section}.{key} has no description"
            assert "unit" in leaf, f"{section}.{key} has no unit"
            assert "default" in leaf, f"{section}.{key} has no default"


def test_defaults_validate_and_come_from_the_schema():
    d = C.validate(C.defaults())
    assert d["lut"]["angles"] == C.load_schema()["properties"]["lut"]["properties"]["angles"]["default"]


def test_default_build_is_the_measured_preset():
    cfg = C.load_config()
    assert cfg["film"]["model"] == "keratin"
    assert cfg["thickness"]["base_nm"] == [480.0, 580.0] and cfg["thickness"]["top_nm"] == [600.0, 700.0]
    assert cfg["film"]["cauchy_b_nm2"] > 0


def test_paper_preset_is_uniform_650_nm_and_n_1_5():
    cfg = C.load_config(preset="paper")
    assert cfg["thickness"]["base_nm"] == cfg["thickness"]["top_nm"] == [650.0, 650.0]
    assert cfg["film"]["cauchy_a"] == 1.5 and cfg["film"]["cauchy_b_nm2"] == 0.0


def test_layers_later_wins(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text("[lut]\nangles = 100\nthicknesses = 7\n")
    cfg = C.load_config(preset="paper", config_file=f, overrides=["lut.angles=50"])
    assert cfg["lut"]["angles"] == 50 and cfg["lut"]["thicknesses"] == 7
    assert cfg["film"]["model"] == "paper"  # untouched keys come from the preset


@pytest.mark.parametrize("item, key, value", [
    ("lut.angles=128", "lut.angles", 128),
    ("thickness.base_nm=[500, 560]", "thickness.base_nm", [500, 560]),
    ("film.model=keratin", "film.model", "keratin"),
    ("film.model='paper'", "film.model", "paper"),
    ("usd.usdz=false", "usd.usdz", False),
    ("lut.angle_warp_gamma = 1.5", "lut.angle_warp_gamma", 1.5),
])
def test_parse_set_reads_toml_literals(item, key, value):
    assert C.parse_set(item) == (key, value)


@pytest.mark.parametrize("overrides, words", [
    (["lut.angles=1"], ["lut.angles", "1", ">= 2"]),
    (["lut.nope=1"], ["lut.nope", "unknown", "angles"]),
    (["thickness.base_nm=[600, 500]"], ["thickness.base_nm", "[600, 500]", "lo > hi"]),
    (["film.model=glass"], ["film.model", "glass", "paper"]),
    (["geometry.seed=1.5"], ["geometry.seed", "1.5", "integer"]),
])
def test_errors_name_key_value_and_what_is_allowed(overrides, words):
    with pytest.raises(UsageError) as exc:
        C.load_config(overrides=overrides)
    msg = str(exc.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg


def test_config_hash_changes_with_any_value_and_not_with_order():
    a = C.load_config()
    b = json.loads(json.dumps(a))
    b = {k: b[k] for k in reversed(list(b))}
    assert C.config_hash(a) == C.config_hash(b)
    assert C.config_hash(a) != C.config_hash(C.load_config(overrides=["geometry.seed=1"]))


def test_describe_lists_every_leaf_with_its_unit():
    rows = {r.key: dataclasses.asdict(r) for r in C.describe(C.load_config())}
    assert rows["thickness.base_nm"]["unit"] == "nm"
    assert rows["lut.angles"]["value"] == 256
    assert rows["verify.width"]["unit"] == "px"


def test_user_cache_folders_are_keyed_by_what_derives_them_and_stale_ones_are_marked_and_pruned(
        tmp_path, monkeypatch, capsys):
    """A user-cache folder is named by the digest of the code that computes its values (sources.cache_dir); once
    that code changes, ``rockdove config --paths`` marks it stale, as it does a folder an older rockdove left
    without a key.json, and ``--prune`` removes those and keeps the current one."""
    import importlib.util
    import json

    from rockdove import cli, sources

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    probe = tmp_path / "probe.py"

    def compute(body: str):
        probe.write_text(f"def compute():\n    return {body}\n")
        spec = importlib.util.spec_from_file_location("probe", probe)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module.compute

    old = sources.cache_dir("colour-science", compute("1"))
    assert (old / sources.KEY_FILE).is_file() and sources.stale(old) is None
    legacy = tmp_path / "xdg" / "rockdove" / "colour-science-0.4.7"
    legacy.mkdir()
    renders = tmp_path / "xdg" / "rockdove" / "verify"  # the verification's items: each keyed by what it reads
    renders.mkdir()
    new = sources.cache_dir("colour-science", compute("22"))
    assert new != old and sources.stale(new) is None and "probe.py changed" in sources.stale(old)
    assert cli.main(["config", "--paths", "--json"]) == 0
    rows = {r["path"]: r for r in json.loads(capsys.readouterr().out)}
    assert rows[str(legacy)]["stale"].startswith("no key.json") and rows[str(new)]["stale"] is None
    assert rows[str(renders)]["what"].startswith("renders of assets") and not rows[str(renders)]["stale"]
    assert cli.main(["config", "--paths", "--prune"]) == 0
    out = capsys.readouterr().out
    assert f"{old}  STALE: " in out and "removed" in out
    assert not old.exists() and not legacy.exists() and new.is_dir() and renders.is_dir()


def test_a_stage_reads_its_declared_config_as_attributes_and_nothing_else():
    """config.lut.angles; a list reads as a tuple; a key the stage did not declare, or one the schema lacks,
    raises naming it (the stage's cache key covers only what it declared)."""
    from rockdove.config import Config, load_config

    full = Config(load_config(preset="measured"))
    assert full.lut.angles == 256 and full.thickness.base_nm == (480.0, 580.0) and full["lut"]["angles"] == 256
    declared = Config({"lut": {"angles": 64}})
    assert declared.lut.angles == 64 and dict(declared) == {"lut": {"angles": 64}}
    with pytest.raises(AttributeError, match="'lut.method' was not declared"):
        _ = declared.lut.method
    with pytest.raises(AttributeError, match="'film' was not declared"):
        _ = declared.film
    with pytest.raises(AttributeError, match="'lut.angels' is not in the schema"):
        _ = full.lut.angels

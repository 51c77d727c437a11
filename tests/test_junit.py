"""``rockdove verify --junit FILE``: JUnit XML that validates against the schema CI tools read (the Jenkins xunit
plugin's junit-10.xsd, from pytest's sdist: tests/fetched.py), a test case per validator, view and host view."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from conftest import OUTSIDE, copy_asset
from fetched import fetch


@pytest.fixture(scope="module")
def schema():
    import xmlschema

    return xmlschema.XMLSchema(str(fetch("junit-10.xsd")))


def _verify(asset, out, junit, *extra):
    env = dict(os.environ, PYOPENGL_PLATFORM="egl")
    exe = os.path.join(os.path.dirname(sys.executable), "rockdove")
    return subprocess.run([exe, "verify", str(asset), "--out", str(out), "--width", "48", "--height", "48",
                           "--junit", str(junit), "--quiet", *extra], capture_output=True, text=True, cwd=OUTSIDE,
                          env=env, timeout=600)


@pytest.fixture(scope="module")
def runs(small_asset, tmp_path_factory):
    """A passing verification (hosts: glsl) and one whose LUT is not the
    film (the views fail): their JUnit files and reports."""
    import dataclasses

    import numpy as np

    from rockdove.lut.exr import read_exr, write_exr

    base = tmp_path_factory.mktemp("junit")
    wrong = copy_asset(small_asset, base / "wrong")
    exr = wrong / "textures" / "thinfilm_lut.exr"
    lut = read_exr(exr)
    os.chmod(exr, 0o644)
    write_exr(dataclasses.replace(lut, rgb=np.full_like(lut.rgb, 0.25)), exr)
    out = {}
    for name, asset, code in (("good", small_asset, 0), ("wrong", wrong, 1)):
        p = _verify(asset, base / f"{name}_report", base / f"{name}.xml", "--hosts", "glsl")
        assert p.returncode == code, (p.stdout[-2000:], p.stderr[-2000:])
        out[name] = (base / f"{name}.xml", json.loads((base / f"{name}_report" / "report.json").read_text()))
    return out


def _cases(path):
    root = ET.parse(path).getroot()
    return root, {(s.get("name"), c.get("name")): c for s in root for c in s.iter("testcase")}


def test_a_passing_verification_is_valid_junit_with_a_case_per_validator_view_and_host(runs, schema):
    path, report = runs["good"]
    schema.validate(str(path))
    root, cases = _cases(path)
    suites = {s.get("name") for s in root}
    assert {"rockdove.validation", "rockdove.glsl", "rockdove.host.glsl"} <= suites
    views = [m["view"] for m in report["views"]]
    assert {("rockdove.glsl", v) for v in views} <= set(cases)
    assert {("rockdove.host.glsl", v) for v in views} <= set(cases)
    validators = ("usdValidation", "mtlx", "texture", "thinFilm", "nvidia")
    assert {("rockdove.validation", v) for v in validators} <= set(cases)
    assert root.get("failures") == "0" and root.get("errors") == "0"
    assert int(root.get("tests")) == len(cases)
    m = next(m for m in report["views"] if m["n_pixels"])
    assert f"dE2000 median {m['de_median']:.3f}" in cases[("rockdove.glsl", m["view"])].find("system-out").text


def test_failed_views_are_failures_with_their_numbers(runs, schema):
    path, report = runs["wrong"]
    schema.validate(str(path))
    root, cases = _cases(path)
    failed = {k: c.find("failure") for k, c in cases.items() if c.find("failure") is not None}
    assert int(root.get("failures")) == len(failed) > 0
    bad = [m for m in report["views"] if not m["passed"]]
    assert bad
    for m in bad:
        f = failed[("rockdove.glsl", m["view"])]
        assert f.text == "\n".join(m["failures"]) and " dE2000 " in f.text, f.text  # e.g. "p95 dE2000 25.612 > 2.0"
    host = failed[("rockdove.host.glsl", "all views")]
    assert host.get("message").startswith("host glsl: ") and " dE2000 " in host.get("message")


def test_skipped_and_failed_hosts_and_validator_errors(runs, schema, tmp_path):
    """A host that is not available is <skipped> with its reason, one that raised is an <error>, a validator's
    errors are its <failure> (warnings stay in system-out); the schema still holds."""
    from rockdove.verify.junit import write_junit
    from rockdove.verify.results import Report

    _, report = runs["good"]
    report = dict(report, hosts=[*report["hosts"], {"name": "blender", "skipped": True, "reason": "no bpy"},
                                 {"name": "web", "variant": "physical", "lobe": "view_angle", "passed": False,
                                  "error": "chromium exited with status 1 (start)"}])
    issue = {"check": "texture", "path": "/Pigeon/Looks/X.inputs:file", "message": "asset does not resolve",
             "severity": "error", "variants": []}
    details = dict(report["validation"]["details"], issues=[issue])
    report["validation"] = dict(report["validation"], passed=False, details=details)
    path = write_junit(Report.from_json(report), tmp_path / "j.xml")
    schema.validate(path)
    root, cases = _cases(path)
    assert cases[("rockdove.host.blender", "all views")].find("skipped").get("message").endswith("no bpy")
    assert "status 1" in cases[("rockdove.host.web", "all views")].find("error").get("message")
    tex = cases[("rockdove.validation", "texture")].find("failure")
    assert tex.get("message") == "1 error(s)" and "does not resolve" in tex.text
    assert root.get("errors") == "1" and root.get("failures") == "1"


def test_the_schema_rejects_what_ci_tools_would_not_read(runs, schema, tmp_path):
    """The schema really checks: a testsuite without its counts, or a time with a unit, does not validate."""
    import re

    import xmlschema

    text = runs["good"][0].read_text()
    unit = re.sub(r'(<testsuite [^>]*time=")([0-9.]+)"', r'\g<1>\g<2>s"', text, count=1)
    for broken in (text.replace(' tests="', ' count="', 2), unit):
        (tmp_path / "b.xml").write_text(broken)
        with pytest.raises(xmlschema.XMLSchemaValidationError):
            schema.validate(str(tmp_path / "b.xml"))


def test_anatomy_and_motion_measures_are_cases_and_their_failures_fail(runs, schema, tmp_path):
    """Every anatomy measure is a case of ``rockdove.anatomy``; a ``--motion`` run's limited measures are cases of
    ``rockdove.motion``, failed by the measure that broke its limit (a CI tool saw them pass)."""
    import dataclasses

    from rockdove.verify.junit import junit_xml
    from rockdove.verify.results import MotionCheck, Report

    path, data = runs["good"]
    root, cases = _cases(path)
    names = [m["name"] for m in data["anatomy"]["measures"]]
    assert len(names) >= 24 and {("rockdove.anatomy", n) for n in names} <= set(cases)
    assert "rockdove.motion" not in {s.get("name") for s in root}
    anatomy = Report.from_json(data).anatomy
    anatomy = dataclasses.replace(anatomy, measures=(dataclasses.replace(anatomy.measures[0], passed=False),
                                                     *anatomy.measures[1:]))
    motion = MotionCheck("walk", 121, {"card_stretch": 0.02, "hold_fraction": 0.5, "head_cycles": 10, "steps": 10},
                         {"card_stretch": 0.01, "hold_fraction": [0.4, 0.8]},
                         ("motion walk: card_stretch = 0.02, allowed 0.01",))
    report = dataclasses.replace(Report.from_json(data), anatomy=anatomy, motion=motion)
    (tmp_path / "j.xml").write_bytes(junit_xml(report))
    schema.validate(str(tmp_path / "j.xml"))
    root, cases = _cases(tmp_path / "j.xml")
    failed = {k for k, c in cases.items() if c.find("failure") is not None}
    assert failed == {("rockdove.anatomy", names[0]), ("rockdove.motion", "card_stretch")}, failed
    assert ("rockdove.motion", "hold_fraction") in cases and root.get("failures") == "2"


def test_the_text_summary_prints_a_report_read_back_whose_numbers_are_nan(runs, capsys):
    """``rockdove verify``'s text summary of a report.json where a NaN was written as null: "nan", not a TypeError."""
    from rockdove.commands.verify import _print
    from rockdove.verify.results import Report

    data = json.loads(json.dumps(runs["good"][1]))
    view = data["views"][0]
    view.update(n_pixels=0, de_median=None, de_p95=None, de_max=None)
    data["boundary"]["per_view"] = {"sweep_090": {**next(iter(data["boundary"]["per_view"].values())),
                                                  "rms_px": None, "length_px": None, "rms_fraction": None}}
    data["hosts"][0].update(n_pixels=0, median_dE=None, p95_dE=None, hue_agreement=None)
    measure = data["anatomy"]["measures"][0]
    measure["value"] = None
    _print(Report.from_json(data))
    out = capsys.readouterr().out
    assert f"{view['view']:>16}:       0 px  dE2000 median nan  p95 nan  max nan" in out
    assert "RMS nan px (nan of its length)" in out
    assert "dE2000 median nan  p95 nan" in out.split("host glsl")[1] and "hue agreement nan" in out
    assert f"{measure['name']:>22}:      nan " in out

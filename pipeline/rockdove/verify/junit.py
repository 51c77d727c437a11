"""The verification as JUnit XML (``rockdove verify --junit FILE``), so Jenkins, GitLab and GitHub show it as tests.

The format is the one those tools read: the Jenkins xunit plugin's ``junit-10.xsd`` (Apache Ant's JUnit report,
as Maven Surefire writes it; the file the tests validate against is taken from pytest's sdist, which validates its
own ``--junitxml`` output with it). One ``<testsuites>``, one ``<testsuite>`` per kind of check:

- ``rockdove.validation``: a test case per validator (``usdValidation``, ``mtlx``, ``texture``, ...); its errors
  are the ``<failure>``, its warnings go to ``<system-out>``;
- ``rockdove.glsl``: a test case per view (our GLSL against the exact reference), the light sweep's hues;
- ``rockdove.host.NAME``: per host a test case per view and one for the host's own verdict over all its views
  (``all views``; a failed exact host also fails each view whose numbers miss the dE goals); a host not
  available here is ``<skipped>`` with its reason, a host that raised is an ``<error>``.

Every failure message carries its numbers (``median dE2000 4.210 > 3.2``) and every test case its metrics in
``<system-out>``. Times are seconds with three decimals (the schema's ``SUREFIRE_TIME``).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET

#: Test case per validator: the Issue ``check`` (or its prefix before ``:``) -> the name shown.
VALIDATORS = {"layer": "dependencies", "assetPath": "dependencies", "open": "dependencies",
              "usdValidation": "usdValidation", "mtlx": "mtlx", "texture": "texture", "primvar": "primvar",
              "thinFilm": "thinFilm", "material": "material", "nvidia": "nvidia"}
#: What each validator counts (the validation report's ``counts``), shown in its ``<system-out>``.
COUNTED = {"mtlx": ("mtlx shaders",), "texture": ("assets",), "primvar": ("primvars",), "thinFilm": ("thin films",),
           "material": ("materials",), "nvidia": ("nvidia ND_* ids left to mtlx",),
           "usdValidation": ("variant combinations",)}


def _num(v) -> str:
    return "nan" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.3f}"


def _time(seconds) -> str:
    return f"{max(float(seconds or 0.0), 0.0):.3f}"


class _Suite:
    def __init__(self, root: ET.Element, name: str, seconds=0.0):
        self.el = ET.SubElement(root, "testsuite", name=name, time=_time(seconds))
        self.counts = {"tests": 0, "failures": 0, "errors": 0, "skipped": 0}

    def case(self, name: str, classname: str, *, failures=(), message=None, error=None, skipped=None, out=""):
        tc = ET.SubElement(self.el, "testcase", name=name, classname=classname, time=_time(0.0))
        self.counts["tests"] += 1
        if skipped is not None:
            ET.SubElement(tc, "skipped", message=skipped)
            self.counts["skipped"] += 1
        elif error is not None:
            ET.SubElement(tc, "error", message=error, type="error").text = error
            self.counts["errors"] += 1
        elif failures:
            more = f" (and {len(failures) - 1} more)" if len(failures) > 1 else ""
            message = message or failures[0] + more
            ET.SubElement(tc, "failure", message=message, type="VerificationFailed").text = "\n".join(failures)
            self.counts["failures"] += 1
        if out:
            ET.SubElement(tc, "system-out").text = out

    def close(self):
        for k, v in self.counts.items():
            self.el.set(k, str(v))
        return self.counts


def _validation(root, report) -> dict:
    v = report["validation"]
    suite = _Suite(root, "rockdove.validation", report["timings_s"].get("validation", 0.0))
    cls = "rockdove.validation"
    details = v.get("details") or {}
    by = {}
    for issue in details.get("issues", []):
        name = VALIDATORS.get(issue["check"].split(":")[0], issue["check"].split(":")[0])
        by.setdefault(name, []).append(issue)
    if v.get("error"):
        suite.case("validator", cls, error=v["error"])
    counts = details.get("counts", {})
    for name in dict.fromkeys([*VALIDATORS.values(), *by]):
        issues = by.get(name, [])
        line = [f"{i['severity'].upper()} {i['check']}: {i['path']}: {i['message']}" for i in issues]
        errors = [ln for ln, i in zip(line, issues) if i["severity"] == "error"]
        checked = ", ".join(f"{k} {counts[k]}" for k in COUNTED.get(name, ()) if k in counts)
        suite.case(name, cls, failures=errors, message=f"{len(errors)} error(s)",
                   out="\n".join([f"checked: {checked}" if checked else "", *line]).strip())
    return suite.close()


def _views(root, report) -> dict:
    g = report["goals"]
    suite = _Suite(root, "rockdove.glsl", report["timings_s"].get("compare", 0.0))
    for m in report["views"]:
        suite.case(m["view"], "rockdove.glsl", failures=list(m.get("failures", [])) if not m["passed"] else [],
                   out=f"{m['n_pixels']} px, dE2000 median {_num(m['de_median'])} (goal {g['median_dE']}), "
                       f"p95 {_num(m['de_p95'])} (goal {g['p95_dE']}), max {_num(m['de_max'])}, "
                       f"black {m['n_black']} of {m['n_lit']} lit")
    h = report["hue_sweep"]
    chromatic = h["green"] + h["purple"] + h["other"]
    hue_fail = [f for f in report["failures"] if f.startswith("hue:")]
    suite.case("light sweep hues", "rockdove.glsl", failures=hue_fail,
               out=f"green {h['green']}, purple {h['purple']}, grey {h['grey']}, other {h['other']} "
                   f"(need >= {g['min_hue_fraction']:.0%} of {chromatic} chromatic px each)")
    return suite.close()


def _host(root, h, goals) -> dict:
    from .host_check import EXACT_VARIANTS

    name = h["name"]
    cls = f"rockdove.host.{name}"
    suite = _Suite(root, cls)
    if h.get("skipped") or h.get("error"):
        suite.case("all views", cls, skipped=f"host {name} not available: {h['reason']}" if h.get("skipped") else None,
                   error=None if h.get("skipped") else f"host {name} failed: {h['error']}")
        return suite.close()
    # the host is judged over all its views (rockdove.verify.host_check): a view fails only within a failed
    # exact host, where its own numbers miss the goals (a view with no feather pixels never does)
    blame = h.get("variant") in EXACT_VARIANTS and not h["passed"]
    for view, m in (h.get("per_view") or {}).items():
        fail = [f"{view}: {k[:-3]} dE2000 {_num(m[k])} > {goals[k]}" for k in ("median_dE", "p95_dE")
                if blame and m["n_pixels"] and not m[k] <= goals[k]]
        suite.case(view, cls, failures=fail, out=f"{m['n_pixels']} px, dE2000 median {_num(m['median_dE'])}, "
                                                 f"p95 {_num(m['p95_dE'])} ({h['variant']}, {h['lobe']} lobe)")
    suite.case("all views", cls, failures=[f"host {name}: {f}" for f in h.get("failures", [])] if not h["passed"]
               else [], out=f"{h['n_pixels']} px, dE2000 median {_num(h['median_dE'])}, p95 {_num(h['p95_dE'])}, "
                            f"green {h['green_px']}, purple {h['purple_px']}, hue agreement "
                            f"{_num(h['hue_agreement'])} ({h['variant']}, {h['lobe']} lobe)")
    return suite.close()


def junit_xml(report: dict) -> bytes:
    """The JUnit XML document (UTF-8 bytes) of a verification report (:func:`rockdove.verify.run.verify_asset`)."""
    asset = os.path.abspath(report["asset"])
    root = ET.Element("testsuites", name=f"rockdove verify {os.path.basename(os.path.dirname(asset))}",
                      time=_time(report["timings_s"].get("total", 0.0)))
    totals = [_validation(root, report), _views(root, report)]
    totals += [_host(root, h, report["goals"]) for h in report.get("hosts", [])]
    for k in ("tests", "failures", "errors"):
        root.set(k, str(sum(t[k] for t in totals)))
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True) + b"\n"


def write_junit(report: dict, path) -> str:
    """Write :func:`junit_xml` of ``report`` to ``path`` (replaced atomically); return the path."""
    path = os.fspath(path)
    tmp = f"{path}.tmp-{os.getpid()}"
    with open(tmp, "wb") as f:
        f.write(junit_xml(report))
    os.replace(tmp, path)
    return path

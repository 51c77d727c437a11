"""The verification as JUnit XML (``rockdove verify --junit FILE``), so Jenkins, GitLab and GitHub show it as tests.

The format is the Jenkins xunit plugin's ``junit-10.xsd`` (Ant's JUnit report, as Maven Surefire writes it; the
tests validate against the copy in pytest's sdist). One ``<testsuite>`` per kind of check: ``rockdove.validation``,
a case per validator (errors are the ``<failure>``, warnings go to ``<system-out>``); ``rockdove.glsl``, a case per
view and one for the light sweep's hues; ``rockdove.host.NAME``, a case per view and ``all views``, the host's own
verdict (a failed exact host also fails each view whose numbers miss the goals; an unavailable host is
``<skipped>`` with its reason, one that raised an ``<error>``). Failure messages carry their numbers (``median
dE2000 4.210 > 3.2``), every case its metrics in ``<system-out>``; times are seconds, three decimals.
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
    """A ``<testsuite>`` whose cases are of the class named as the suite."""

    def __init__(self, root: ET.Element, name: str, seconds=0.0):
        self.name = name
        self.el = ET.SubElement(root, "testsuite", name=name, time=_time(seconds))

    def case(self, name: str, *, failures=(), message=None, error=None, skipped=None, out=""):
        tc = ET.SubElement(self.el, "testcase", name=name, classname=self.name, time=_time(0.0))
        if skipped is not None:
            ET.SubElement(tc, "skipped", message=skipped)
        elif error is not None:
            ET.SubElement(tc, "error", message=error, type="error").text = error
        elif failures:
            more = f" (and {len(failures) - 1} more)" if len(failures) > 1 else ""
            ET.SubElement(tc, "failure", message=message or failures[0] + more,
                          type="VerificationFailed").text = "\n".join(failures)
        if out:
            ET.SubElement(tc, "system-out").text = out

    def close(self) -> dict:
        cases = self.el.findall("testcase")
        counts = {"tests": len(cases), **{key: sum(c.find(tag) is not None for c in cases) for key, tag in
                                          (("failures", "failure"), ("errors", "error"), ("skipped", "skipped"))}}
        for k, v in counts.items():
            self.el.set(k, str(v))
        return counts


def _validation(root, report) -> dict:
    v = report["validation"]
    suite = _Suite(root, "rockdove.validation", report["timings_s"].get("validation", 0.0))
    details = v.get("details") or {}
    by = {}
    for issue in details.get("issues", []):
        name = VALIDATORS.get(issue["check"].split(":")[0], issue["check"].split(":")[0])
        by.setdefault(name, []).append(issue)
    if v.get("error"):
        suite.case("validator", error=v["error"])
    counts = details.get("counts", {})
    for name in dict.fromkeys([*VALIDATORS.values(), *by]):
        issues = by.get(name, [])
        line = [f"{i['severity'].upper()} {i['check']}: {i['path']}: {i['message']}" for i in issues]
        errors = [ln for ln, i in zip(line, issues) if i["severity"] == "error"]
        checked = ", ".join(f"{k} {counts[k]}" for k in COUNTED.get(name, ()) if k in counts)
        suite.case(name, failures=errors, message=f"{len(errors)} error(s)",
                   out="\n".join([f"checked: {checked}" if checked else "", *line]).strip())
    return suite.close()


def _views(root, report) -> dict:
    g = report["goals"]
    suite = _Suite(root, "rockdove.glsl", report["timings_s"].get("compare", 0.0))
    for m in report["views"]:
        suite.case(m["view"], failures=list(m.get("failures", [])) if not m["passed"] else [],
                   out=f"{m['n_pixels']} px, dE2000 median {_num(m['de_median'])} (goal {g['median_dE']}), "
                       f"p95 {_num(m['de_p95'])} (goal {g['p95_dE']}), max {_num(m['de_max'])}, "
                       f"black {m['n_black']} of {m['n_lit']} lit")
    h = report["hue_sweep"]
    chromatic = h["green"] + h["purple"] + h["other"]
    hue_fail = [f for f in report["failures"] if f.startswith("hue:")]
    suite.case("light sweep hues", failures=hue_fail,
               out=f"green {h['green']}, purple {h['purple']}, grey {h['grey']}, other {h['other']} "
                   f"(need >= {g['min_hue_fraction']:.0%} of {chromatic} chromatic px each)")
    return suite.close()


def _host(root, h, goals) -> dict:
    from .host_check import EXACT_VARIANTS

    name = h["name"]
    suite = _Suite(root, f"rockdove.host.{name}")
    if h.get("skipped") or h.get("error"):
        suite.case("all views", skipped=f"host {name} not available: {h['reason']}" if h.get("skipped") else None,
                   error=None if h.get("skipped") else f"host {name} failed: {h['error']}")
        return suite.close()
    # the host is judged over all its views (rockdove.verify.host_check): a view fails only within a failed
    # exact host, where its own numbers miss the goals (a view with no feather pixels never does)
    blame = h.get("variant") in EXACT_VARIANTS and not h["passed"]
    for view, m in (h.get("per_view") or {}).items():
        fail = [f"{view}: {k[:-3]} dE2000 {_num(m[k])} > {goals[k]}" for k in ("median_dE", "p95_dE")
                if blame and m["n_pixels"] and not m[k] <= goals[k]]
        suite.case(view, failures=fail, out=f"{m['n_pixels']} px, dE2000 median {_num(m['median_dE'])}, "
                                            f"p95 {_num(m['p95_dE'])} ({h['variant']}, {h['lobe']} lobe)")
    suite.case("all views", failures=[f"host {name}: {f}" for f in h.get("failures", [])] if not h["passed"]
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

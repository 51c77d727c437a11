"""The verification as JUnit XML (``rockdove verify --junit FILE``), so Jenkins, GitLab and GitHub show it as tests.

The format is the Jenkins xunit plugin's ``junit-10.xsd`` (Ant's JUnit report, as Maven Surefire writes it). One
``<testsuite>`` per kind of check: ``rockdove.validation`` (a case per validator, warnings in ``<system-out>``),
``rockdove.glsl`` (a case per view and one for the light sweep's hues), ``rockdove.host.NAME`` (a case per view and
``all views``, the host's own verdict; an unavailable host is ``<skipped>``, one that raised an ``<error>``),
``rockdove.anatomy`` (a case per measure) and, with ``--motion``, ``rockdove.motion`` (a case per limited measure).
Failure messages carry their numbers, every case its metrics in ``<system-out>``; times in seconds."""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET

from ..resources import write_atomic
from .results import Anatomy, Goals, HostResult, MotionCheck, Report

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


def _validation(root, report: Report) -> dict:
    v = report.validation
    suite = _Suite(root, "rockdove.validation", report.timings_s.get("validation", 0.0))
    by: dict[str, list] = {}
    for issue in v.issues:
        name = issue.check.split(":")[0]
        by.setdefault(VALIDATORS.get(name, name), []).append(issue)
    if v.error:
        suite.case("validator", error=v.error)
    counts = (v.details or {}).get("counts", {})
    for name in dict.fromkeys([*VALIDATORS.values(), *by]):
        issues = by.get(name, [])
        line = [f"{i.severity.upper()} {i.check}: {i.path}: {i.message}" for i in issues]
        errors = [ln for ln, i in zip(line, issues) if i.severity == "error"]
        checked = ", ".join(f"{k} {counts[k]}" for k in COUNTED.get(name, ()) if k in counts)
        suite.case(name, failures=errors, message=f"{len(errors)} error(s)",
                   out="\n".join([f"checked: {checked}" if checked else "", *line]).strip())
    return suite.close()


def _views(root, report: Report) -> dict:
    g = report.goals
    suite = _Suite(root, "rockdove.glsl", report.timings_s.get("compare", 0.0))
    for m in report.views:
        suite.case(m.view, failures=list(m.failures) if not m.passed else [],
                   out=f"{m.n_pixels} px, dE2000 median {_num(m.de_median)} (goal {g.median_dE}), "
                       f"p95 {_num(m.de_p95)} (goal {g.p95_dE}), max {_num(m.de_max)}, "
                       f"black {m.n_black} of {m.n_lit} lit")
    h = report.hue_sweep
    suite.case("light sweep hues", failures=[f for f in report.failures if f.startswith("hue:")],
               out=f"green {h.green}, purple {h.purple}, grey {h.grey}, other {h.other} "
                   f"(need >= {g.min_hue_fraction:.0%} of {h.chromatic} chromatic px each)")
    return suite.close()


def _host(root, h: HostResult, goals: Goals) -> dict:
    from .host_check import EXACT_VARIANTS

    suite = _Suite(root, f"rockdove.host.{h.name}")
    if h.metrics is None:
        suite.case("all views", skipped=f"host {h.name} not available: {h.reason}" if h.status == "skipped" else None,
                   error=None if h.status == "skipped" else f"host {h.name} failed: {h.reason}")
        return suite.close()
    # the host is judged over all its views (rockdove.verify.host_check): a view fails only within a failed
    # exact host, where its own numbers miss the goals (a view with no feather pixels never does)
    m, lobe = h.metrics, f"({h.variant}, {h.lobe} lobe)"
    blame = h.variant in EXACT_VARIANTS and not h.passed
    for view, v in m.per_view.items():
        fail = [f"{view}: {name} dE2000 {_num(value)} > {goal}" for name, value, goal in
                (("median", v.median_dE, goals.median_dE), ("p95", v.p95_dE, goals.p95_dE))
                if blame and v.n_pixels and not value <= goal]
        suite.case(view, failures=fail, out=f"{v.n_pixels} px, dE2000 median {_num(v.median_dE)}, "
                                            f"p95 {_num(v.p95_dE)} {lobe}")
    suite.case("all views", failures=[f"host {h.name}: {f}" for f in h.failures] if not h.passed else [],
               out=f"{m.n_pixels} px, dE2000 median {_num(m.median_dE)}, p95 {_num(m.p95_dE)}, green {m.green_px}, "
                   f"purple {m.purple_px}, hue agreement {_num(m.hue_agreement)} {lobe}")
    return suite.close()


def _anatomy(root, anatomy: Anatomy) -> dict:
    suite = _Suite(root, "rockdove.anatomy")
    for m in anatomy.measures:
        line = f"{m.name} = {_num(m.value)} {m.unit}".rstrip() + f", range [{m.low}, {m.high}]"
        suite.case(m.name, failures=[] if m.passed else [f"anatomy: {line} ({m.what})"], out=line)
    if not anatomy.measures and anatomy.failures:  # the bird's parts could not be measured
        suite.case("measures", failures=list(anatomy.failures))
    return suite.close()


def _motion(root, motion: MotionCheck) -> dict:
    """A case per limited measure of :func:`rockdove.verify.motion.measure_motion`, failed by its failure line."""
    suite = _Suite(root, "rockdove.motion")
    name, failures, measures = motion.motion, motion.failures, motion.measures
    for key, limit in motion.limits.items():
        if key in measures:
            mine = [f for f in failures if f.startswith(f"motion {name}: {key} = ")]
            suite.case(key, failures=mine, out=f"{key} = {measures[key]:.4g}, allowed {limit} "
                                               f"({motion.frames} time codes of {name})")
    rest = [f for f in failures if not any(f.startswith(f"motion {name}: {k} = ") for k in motion.limits)]
    if "head_cycles" in measures or rest:
        suite.case("head cycles per step", failures=rest, out=f"{measures.get('head_cycles')} head "
                                                               f"cycles, {measures.get('steps')} steps")
    return suite.close()


def junit_xml(report: Report) -> bytes:
    """The JUnit XML document (UTF-8 bytes) of a verification report."""
    asset = os.path.abspath(report.asset)
    root = ET.Element("testsuites", name=f"rockdove verify {os.path.basename(os.path.dirname(asset))}",
                      time=_time(report.timings_s.get("total", 0.0)))
    totals = [_validation(root, report), _views(root, report)]
    totals += [_host(root, h, report.goals) for h in report.hosts]
    totals += [_anatomy(root, report.anatomy)] + ([_motion(root, report.motion)] if report.motion else [])
    for k in ("tests", "failures", "errors"):
        root.set(k, str(sum(t[k] for t in totals)))
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True) + b"\n"


def write_junit(report: Report, path) -> str:
    """Write :func:`junit_xml` of ``report`` to ``path`` (replaced atomically); return the path."""
    return write_atomic(path, junit_xml(report))

"""NVIDIA's asset validator (PyPI ``usd-validation-nvidia``) over a written asset, as :class:`Issue` s.

The validator runs USD's ComplianceChecker rules plus NVIDIA's own (unused mesh topology, ASCII layers
holding large arrays, manifold meshes, indexed primvars...) over every variant of the asset. Its severities
map to ours: ``ERROR`` (the rule itself broke) and ``FAILURE`` (the asset breaks the rule) are errors,
``WARNING`` is a warning, ``INFO`` is dropped.

usd-core ships no MaterialX Sdr plugin, so ``UsdShadeShaderSdrCompliance`` fails every ``ND_*`` shader id
("not found in sdrRegistry"). Those findings, and only those, are dropped: :func:`pipeline.usd.validate.
check_mtlx_shaders` checks the same ids, inputs and outputs against MaterialX's own node definitions.
"""

from __future__ import annotations

import re

#: NVIDIA's rule for shader ids and the message it gives an id its Sdr registry lacks.
SDR_RULE = "UsdShadeShaderSdrCompliance"
_MISSING_ND = re.compile(r"shaderId '(ND_[A-Za-z0-9_]+)' .*not found in sdrRegistry")

_SEVERITY = {"ERROR": "error", "FAILURE": "error", "WARNING": "warning"}



def run_nvidia_validator(root_layer: str) -> tuple[list, int]:
    """Validate ``root_layer`` (a file path: layer or usdz) with every default rule, over all variants.

    Returns
    -------
    (issues, number of findings dropped as ND_* ids usd-core's Sdr registry cannot know)
        ``issues``: :class:`pipeline.usd.issues.Issue` with check ``nvidia:<Rule>``; a finding repeated in
        several variants is listed once.
    """
    import usd_validation_nvidia as nv

    from .issues import Issue

    results = nv.ValidationEngine(variants=True).validate(root_layer)
    issues, seen, dropped = [], set(), 0
    for found in results.issues():
        severity = _SEVERITY.get(found.severity.name)
        if severity is None:
            continue
        rule = found.rule.__name__ if found.rule is not None else "engine"
        message = " ".join(str(found.message).split())
        if rule == SDR_RULE and _MISSING_ND.search(message):
            dropped += 1
            continue
        where = str(found.at.path) if found.at is not None and hasattr(found.at, "path") else (
            found.at.as_str() if found.at is not None else root_layer)
        key = (rule, where, message, severity)
        if key in seen:
            continue
        seen.add(key)
        issues.append(Issue(f"nvidia:{rule}", where, message, severity))
    return issues, dropped

"""NVIDIA's asset validator (PyPI ``usd-validation-nvidia``) over every variant, as :class:`Issue` s; its Sdr rule on
``ND_*`` ids is dropped (usd-core has no MaterialX Sdr plugin: :mod:`rockdove.usd.validate` checks those). Its mesh
rules (:data:`MESH_RULES`: ~90% of its time, ManifoldChecker alone 4.3 of 5.8 s) read only geometry, so their
findings are cached by :func:`mesh_digest` and revalidating after a film change runs only the other rules."""

from __future__ import annotations

import json
import re
from urllib.parse import urlparse

import numpy as np
from pxr import Usd, UsdGeom

from ..digest import Digest
from ..resources import write_cached
from ..sources import cache_dir
from .issues import Issue
from .stage import variant_combinations

#: NVIDIA's rule for shader ids and the message it gives an id its Sdr registry lacks.
SDR_RULE = "UsdShadeShaderSdrCompliance"
_MISSING_ND = re.compile(r"shaderId '(ND_[A-Za-z0-9_]+)' .*not found in sdrRegistry")

_SEVERITY = {"ERROR": "error", "FAILURE": "error", "WARNING": "warning"}

#: NVIDIA's rules that read only the meshes' own attributes (points, topology, normals): memoised by mesh_digest.
MESH_RULES = ("ManifoldChecker", "ZeroAreaFaceChecker", "WeldChecker", "NormalsWindingsChecker",
              "ValidateTopologyChecker")


def mesh_digest(root_layer: str) -> str | None:
    """sha256 of what the :data:`MESH_RULES` read in each variant; None with time samples (never memoised)."""
    stage = Usd.Stage.Open(root_layer, Usd.Stage.LoadAll)
    read = set(UsdGeom.Mesh.GetSchemaAttributeNames(True)) | {"primvars:normals", "primvars:normals:indices"}
    d = Digest()
    for combo in variant_combinations(stage):
        with Usd.EditContext(stage, stage.GetSessionLayer()):
            for name, value in combo.items():
                stage.GetDefaultPrim().GetVariantSet(name).SetVariantSelection(value)
        d.add("variants", combo)
        for prim in stage.Traverse():
            if not prim.IsA(UsdGeom.Mesh):
                continue
            d.add("prim", str(prim.GetPath()))
            for attr in prim.GetAttributes():
                if attr.GetName() not in read:
                    continue
                if attr.GetNumTimeSamples():
                    return None
                value = attr.Get()
                meta = (attr.GetName(), str(attr.GetTypeName()), attr.GetMetadata("interpolation"),
                        attr.GetMetadata("elementSize"))
                try:
                    arr = np.ascontiguousarray(value)
                except (TypeError, ValueError):
                    arr = None
                # numbers: their bytes and shape; tokens, strings, None: their text (an object array's bytes
                # would be its pointers)
                d.add(repr(meta), arr if arr is not None and arr.dtype.kind in "biuf" else repr(value))
    return d.hexdigest()


def _asset(root_layer: str):
    """What the engine is given: the path, or the stage where the engine's ``urlparse`` would cut the path (a
    ``#``, ``?`` or ``;`` in a folder name makes it "not a readable USD file")."""
    return root_layer if urlparse(root_layer).path == root_layer else Usd.Stage.Open(root_layer, Usd.Stage.LoadAll)


def _findings(results, root_layer: str) -> tuple[list, int]:
    """(rule, where, message, severity) of each finding we keep, in order, and the ND_* findings dropped."""
    kept, dropped = [], 0
    for found in results.issues():
        if (severity := _SEVERITY.get(found.severity.name)) is None:
            continue
        rule = found.rule.__name__ if found.rule is not None else "engine"
        message = " ".join(str(found.message).split())
        if rule == SDR_RULE and _MISSING_ND.search(message):
            dropped += 1
            continue
        where = str(found.at.path) if found.at is not None and hasattr(found.at, "path") else (
            found.at.as_str() if found.at is not None else root_layer)
        kept.append((rule, where, message, severity))
    return kept, dropped


def _mesh_findings(nv, rules: list, root_layer: str) -> list:
    """The findings of ``rules`` (the MESH_RULES) on ``root_layer``, from the memo when its meshes were seen."""
    digest = mesh_digest(root_layer)
    path = None
    if digest is not None:
        names = ",".join(sorted(r.__name__ for r in rules))
        key = Digest().add("rules", names).add("meshes", digest).hexdigest()
        path = cache_dir("usd-validation-nvidia", _mesh_findings) / f"{key}.json"
        try:
            return [tuple(f) for f in json.loads(path.read_text())]
        except (OSError, ValueError):
            pass  # not seen yet, or a torn file: run the rules
    engine = nv.ValidationEngine(init_rules=False, variants=True)
    for rule in rules:
        engine.enable_rule(rule)
    findings, _ = _findings(engine.validate(_asset(root_layer)), root_layer)
    if path is not None:
        write_cached(path, json.dumps(findings).encode())
    return findings


def run_nvidia_validator(root_layer: str) -> tuple[list, int]:
    """Every default rule in all variants: (issues ``nvidia:<Rule>``, each once, number of ND_* findings dropped)."""
    import usd_validation_nvidia as nv

    engine = nv.ValidationEngine(variants=True)
    mesh_rules = [r for r in engine.rules if r.__name__ in MESH_RULES]
    for rule in mesh_rules:
        engine.disable_rule(rule)
    findings, dropped = _findings(engine.validate(_asset(root_layer)), root_layer)
    findings += _mesh_findings(nv, mesh_rules, root_layer)
    unique = dict.fromkeys(tuple(f) for f in findings)  # in order, once
    return [Issue(f"nvidia:{rule}", where, message, severity) for rule, where, message, severity in unique], dropped

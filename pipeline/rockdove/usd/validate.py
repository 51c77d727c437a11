"""Validate a written asset: USD's validation framework plus rockdove's own checks. :func:`validate_asset` scans
the layers without composing them (:mod:`.dependencies`), runs the numbered checks below in every combination of
variants (``UsdValidation``'s ``MissingShaderIdInRegistry`` dropped for ``ND_*`` ids: usd-core has no MaterialX
Sdr plugin), then NVIDIA's validator once over all. An :class:`Issue` found in several variants is reported once."""

from __future__ import annotations

import io
import os
import re
import tempfile

import numpy as np
from pxr import Ar, Sdf, Usd, UsdGeom, UsdShade, UsdValidation

from .dependencies import blocking, scan_dependencies
from .issues import Issue, Report, only_errors  # noqa: F401 (re-exported)
from .layout import resolve_root_layer
from .material import _SDF_TYPES, load_mtlx_libraries, usd_to_mtlx_document
from .nvidia import run_nvidia_validator
from .schema import register
from .shader_values import bound_primvars, material_of, problem
from .skel import check_skins
from .stage import variant_combinations

# Sdf value type name -> MaterialX type: the inverse of the authoring table (material._SDF_TYPES); token (outputs
# of surface shaders / materials) has no single MaterialX type
_MX_TYPES = {sdf.lower(): mx for mx, sdf in _SDF_TYPES.items() if sdf != "Token"} | {"token": None}


# -- 1. UsdValidation -------------------------------------------------------------------------------------
def _validators():
    reg = UsdValidation.ValidationRegistry()
    names = sorted(m.name for m in reg.GetAllValidatorMetadata())
    return reg.GetOrLoadValidatorsByName(names)


def run_usd_validation(stage, validators=None) -> list:
    """Check 1 over ``stage``."""
    context = UsdValidation.ValidationContext(validators or _validators())
    issues = []
    for err in context.Validate(stage):
        if err.GetType() == UsdValidation.ValidationErrorType.None_:
            continue
        sites = [s.GetProperty().GetPath() if s.IsProperty() else s.GetPrim().GetPath() if s.IsPrim() else
                 s.GetLayer().identifier if s.GetLayer() else "" for s in err.GetSites()]
        if err.GetName() == "MissingShaderIdInRegistry":  # usd-core has no MaterialX Sdr plugin
            prims = [stage.GetPrimAtPath(str(p).split(".")[0]) for p in sites]
            ids = [UsdShade.Shader(p).GetShaderId() if p and p.IsA(UsdShade.Shader) else None for p in prims]
            if ids and all(i and i.startswith("ND_") for i in ids):
                continue  # checked against MaterialX's own node definitions instead
        validator = err.GetValidator().GetMetadata().name if err.GetValidator() else "usdValidation"
        severity = "error" if err.GetType() == UsdValidation.ValidationErrorType.Error else "warning"
        issues.append(Issue(f"usdValidation:{validator}:{err.GetName()}", ", ".join(str(s) for s in sites) or "/",
                            err.GetMessage(), severity))
    return issues


# -- 2. MaterialX node definitions --------------------------------------------------------------------------
#: The check of a value a shader generator would paste into the code it writes (a host refuses such an asset).
CODE_CHECK = "mtlx:code"


def check_mtlx_shaders(stage, library=None) -> tuple[list, int]:
    """Check 2: (issues, number of ND_ shaders checked)."""
    library = library or load_mtlx_libraries()
    issues, n, bound = [], 0, bound_primvars(stage)
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if not prim.IsA(UsdShade.Shader):
            continue
        shader = UsdShade.Shader(prim)
        sid = shader.GetShaderId() or ""
        nodedef = library.getNodeDef(sid)
        for inp in shader.GetInputs():  # values a generator would paste into code (rockdove.usd.shader_values)
            mx = nodedef.getActiveInput(inp.GetBaseName()) if nodedef else None
            reader = sid.startswith("UsdPrimvarReader") and inp.GetBaseName() == "varname"
            why = (mx is not None or reader) and not inp.HasConnectedSource() and problem(
                inp.GetBaseName(), "string" if reader else mx.getType(), mx.getAttribute("enum") if mx else "",
                inp.Get(), inp.GetAttr().GetColorSpace(), library, bound.get(material_of(prim)))
            if why:
                issues.append(Issue(CODE_CHECK, str(inp.GetAttr().GetPath()), f"{why}: a shader generator would paste "
                                    "it into the code it writes"))
        if not sid.startswith("ND_"):
            continue
        n += 1
        if nodedef is None:
            issues.append(Issue("mtlx", f"{prim.GetPath()}.info:id",
                                f"info:id {sid!r} is not a MaterialX node definition (stdlib/pbrlib/bxdf)"))
            continue
        for port, kind in [(i, "input") for i in shader.GetInputs()] + [(o, "output") for o in shader.GetOutputs()]:
            name, typ = port.GetBaseName(), port.GetTypeName()
            mx = nodedef.getActiveInput(name) if kind == "input" else nodedef.getActiveOutput(name)
            got = _MX_TYPES.get(str(typ), str(typ))
            where, want = str(port.GetAttr().GetPath()), mx.getType() if mx is not None else None
            if mx is None:
                known = f" (inputs: {sorted(i.getName() for i in nodedef.getActiveInputs())})" * (kind == "input")
                issues.append(Issue("mtlx", where, f"{kind} {name!r} is not declared by {sid}{known}"))
            elif kind == "input" and got != want and not (got is None and _SDF_TYPES.get(want) == "Token"):
                # a token input carries a closure (BSDF, EDF, surfaceshader): any of the token-typed MaterialX types
                issues.append(Issue("mtlx", where, f"input {name!r} has type {typ} ({got}), {sid} expects {want}"))
            elif kind == "output" and got is not None and got != want:
                issues.append(Issue("mtlx", where, f"output {name!r} has type {typ}, {sid} gives {want}"))
    return issues, n


# -- 3. textures --------------------------------------------------------------------------------------------
def read_texture_asset(resolved: str):
    """Decode a resolved texture (a file or a usdz member): a PIL image for PNG, a ThinFilmLUT for EXR."""
    from PIL import Image

    from rockdove.lut.exr import read_exr

    if (asset := Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved))) is None:
        raise OSError(f"cannot open {resolved!r}")
    data = bytes(asset.GetBuffer())
    name = resolved.rstrip("]").lower()
    if name.endswith(".exr"):
        with tempfile.TemporaryDirectory() as tmp:
            p = os.path.join(tmp, "lut.exr")
            with open(p, "wb") as fh:
                fh.write(data)
            return read_exr(p)
    img = Image.open(io.BytesIO(data))
    img.load()
    return img


def check_textures(stage, decoded: dict | None = None, skip=frozenset()) -> tuple[list, int, dict]:
    """Check 3: (issues, assets checked, ``decoded`` filled in place: each file read once); ``skip``: never read."""
    issues, n = [], 0
    decoded = {} if decoded is None else decoded
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        for attr in prim.GetAttributes():
            if attr.GetTypeName() != Sdf.ValueTypeNames.Asset:
                continue
            value = attr.Get()
            if value is None or not value.path:
                continue
            n += 1
            if value.path in skip:
                continue
            if not value.resolvedPath:
                issues.append(Issue("texture", str(attr.GetPath()), f"asset {value.path!r} does not resolve "
                                    "(missing file); expected an existing texture next to the layer"))
                continue
            if value.resolvedPath in decoded:
                continue
            try:
                decoded[value.resolvedPath] = read_texture_asset(value.resolvedPath)
            except Exception as exc:  # any decoder failure is the finding
                why = re.sub(r" ?<[^<>]* at 0x[0-9a-fA-F]+>", "", str(exc)) or type(exc).__name__
                issues.append(Issue("texture", str(attr.GetPath()),
                                    f"asset {value.path!r} ({value.resolvedPath}) does not read: {why}"))
    return issues, n, decoded


# -- 4. primvar sizes ---------------------------------------------------------------------------------------
def check_primvars(stage) -> tuple[list, int]:
    """Check 4: (issues, number of primvars checked)."""
    issues, n = [], 0
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        mesh = UsdGeom.Mesh(prim)
        points = mesh.GetPointsAttr().Get() or []
        counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get() or [], np.int64)
        indices = np.asarray(mesh.GetFaceVertexIndicesAttr().Get() or [], np.int64)
        expected = {"vertex": len(points), "varying": len(points), "faceVarying": int(counts.sum()),
                    "uniform": len(counts), "constant": 1}
        path = prim.GetPath()
        if int(counts.sum()) != len(indices):
            issues.append(Issue("primvar", f"{path}.faceVertexIndices", f"{len(indices)} indices, but "
                                f"faceVertexCounts sum to {int(counts.sum())}"))
        if len(indices) and (indices.min() < 0 or indices.max() >= len(points)):
            issues.append(Issue("primvar", f"{path}.faceVertexIndices",
                                f"indices span [{indices.min()}, {indices.max()}], expected [0, {len(points)})"))
        if (normals := mesh.GetNormalsAttr().Get()) is not None:
            interp = mesh.GetNormalsInterpolation()
            if len(normals) != expected.get(interp, -1):
                issues.append(Issue("primvar", f"{path}.normals", f"{len(normals)} normals with interpolation "
                                    f"{interp!r}, expected {expected.get(interp)}"))
        for pv in UsdGeom.PrimvarsAPI(prim).GetPrimvars():
            if (value := pv.Get()) is None:
                continue
            n += 1
            interp = pv.GetInterpolation()
            size = expected.get(interp)
            elems = len(value) // max(pv.GetElementSize(), 1) if not isinstance(value, str) and hasattr(
                value, "__len__") else 1
            if pv.IsIndexed():
                idx = np.asarray(pv.GetIndices(), np.int64)
                if len(idx) and (idx.min() < 0 or idx.max() >= elems):
                    issues.append(Issue("primvar", str(pv.GetAttr().GetPath()),
                                        f"indices span [{idx.min()}, {idx.max()}], expected [0, {elems})"))
                elems = len(idx)
            if size is not None and elems != size:
                issues.append(Issue("primvar", str(pv.GetAttr().GetPath()),
                                    f"{elems} values with interpolation {interp!r}, expected {size} "
                                    f"({len(points)} points, {len(counts)} faces, {int(counts.sum())} corners)"))
    return issues, n


# -- 5. thin film / LUT domain: rockdove.usd.validate_film
from .validate_film import LUT_NETWORK_SHADERS, check_thin_film  # noqa: E402, F401 (part of this module's API)


# -- 6. surface sources -------------------------------------------------------------------------------------
def check_materials(stage, library=None) -> tuple[list, int]:
    """Check 6 (the network rebuilt by :func:`rockdove.usd.material.usd_to_mtlx_document`)."""
    library = library or load_mtlx_libraries()
    issues, n = [], 0
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if not prim.IsA(UsdShade.Material):
            continue
        n += 1
        mat = UsdShade.Material(prim)
        contexts = [("", "outputs:surface")]
        if prim.HasAttribute("outputs:mtlx:surface"):
            contexts.append(("mtlx", "outputs:mtlx:surface"))
        for ctx, attr in contexts:
            shader, _, _ = mat.ComputeSurfaceSource(ctx)
            if not shader:
                issues.append(Issue("material", f"{prim.GetPath()}.{attr}",
                                    f"ComputeSurfaceSource({ctx!r}) does not resolve to a shader"))
            elif ctx == "mtlx" and not (shader.GetShaderId() or "").startswith("ND_"):
                issues.append(Issue("material", f"{prim.GetPath()}.{attr}",
                                    f"mtlx surface {shader.GetPath()} has id {shader.GetShaderId()!r}, "
                                    "expected a MaterialX ND_* surface shader"))
            elif ctx == "mtlx":
                try:
                    ok, why = usd_to_mtlx_document(shader, library).validate()
                except ValueError:
                    continue  # the id/input itself is reported by check_mtlx_shaders
                if not ok:
                    issues.append(Issue("material", f"{prim.GetPath()}.{attr}",
                                        f"the network upstream of {shader.GetPath()} is not a valid MaterialX "
                                        f"graph: {why.strip()}"))
    return issues, n


# -- driver -------------------------------------------------------------------------------------------------
def validate_asset(path, allow_external: bool = False) -> Report:
    """The :class:`Report` of the asset at ``path``. A layer that does not parse or lies outside ends it before USD
    composes; paths outside are never read, nor NVIDIA's validator run, unless ``allow_external``."""
    root = resolve_root_layer(path)
    register()
    report = Report(path=root)
    deps = scan_dependencies(root, allow_external)
    report.issues += deps.issues
    if blocking(deps):
        return report  # composing would read a broken layer or a layer or clip from elsewhere
    skip = frozenset() if allow_external else frozenset(deps.external)
    try:
        stage = Usd.Stage.Open(root, Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException for unparsable layers and damaged packages
        why = " ".join(str(exc).split())
        report.issues.append(Issue("open", root, f"USD could not open the layer: {why}"))
        return report
    library = load_mtlx_libraries()
    validators = _validators()
    found: dict[tuple, list] = {}
    decoded_textures = {}  # resolved path -> decoded texture: the variants share their files, read each once
    combos = variant_combinations(stage)
    counts = {}
    for combo in combos:
        label = ", ".join(f"{k}={v}" for k, v in combo.items())
        if label:
            report.variants.append(label)
        with Usd.EditContext(stage, stage.GetSessionLayer()):
            for name, value in combo.items():
                stage.GetDefaultPrim().GetVariantSet(name).SetVariantSelection(value)
        issues = run_usd_validation(stage, validators)
        mx_issues, counts["mtlx shaders"] = check_mtlx_shaders(stage, library)
        tex_issues, counts["assets"], decoded = check_textures(stage, decoded_textures, skip)
        pv_issues, counts["primvars"] = check_primvars(stage)
        tf_issues, counts["thin films"] = check_thin_film(stage, decoded)
        mat_issues, counts["materials"] = check_materials(stage, library)
        for issue in issues + mx_issues + tex_issues + pv_issues + tf_issues + mat_issues + check_skins(stage):
            found.setdefault((issue.check, issue.path, issue.message, issue.severity), []).append(label)
    counts["variant combinations"] = len(combos)
    if skip:
        nv_issues = [Issue("nvidia", root, "NVIDIA's validator was not run: it would read the files outside the "
                           "asset (allow them with --allow-external-assets)", "warning")]
    else:
        nv_issues, counts["nvidia ND_* ids left to mtlx"] = run_nvidia_validator(root)
    for issue in nv_issues:  # the NVIDIA validator walks the variants itself
        found.setdefault((issue.check, issue.path, issue.message, issue.severity), []).extend(report.variants or [""])
    report.counts = counts
    for (check, where, message, severity), labels in found.items():
        variants = () if len(labels) == len(combos) else tuple(label for label in labels if label)
        report.issues.append(Issue(check, where, message, severity, variants))
    report.issues.sort(key=lambda i: (i.severity != "error", i.check, i.path))
    return report

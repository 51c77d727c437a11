"""The files an asset refers to, found without composing it (``Sdf`` only). An asset must be relocatable: every
path it authors relative and inside the root layer's folder (or ``.usdz``), symlinks resolved; paths outside are
never read unless ``allow_external``. :func:`require_inside` gates the commands that read an asset."""

from __future__ import annotations

import os
import posixpath
import re
from dataclasses import dataclass, field

from pxr import Ar, Sdf, Tf

from ..digest import Digest
from ..errors import UsageError, VerificationFailed
from .budget import face_over_budget, image_over_budget, over_budget
from .issues import Issue, only_errors
from .layout import resolve_root_layer

#: ``file:line:column: message`` as USD's text parser reports a syntax error.
_PARSE_ERROR = re.compile(r"(?P<file>[^\s']+?):(?P<line>\d+):(?P<col>\d+): (?P<msg>[^\n]*)")
#: A URI scheme (``https:``, ``omniverse:``) or a drive letter (``C:``): not a relative path.
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")


@dataclass
class Dependencies:
    """What :func:`scan_dependencies` found: ``issues`` and the ``external`` paths."""

    issues: list = field(default_factory=list)
    external: set = field(default_factory=set)
    read: set = field(default_factory=set)  # the files inside the asset its composition reads (layers, textures)


def _outside(anchored: str, root_dir: str, root_package: str | None) -> str | None:
    """Why an anchored asset path is outside the asset (folder, or package for a usdz root), else None."""
    where = "package" if root_package else "folder"
    if Ar.IsPackageRelativePath(anchored):
        outer, inner = Ar.SplitPackageRelativePathOuter(anchored)
        inner = posixpath.normpath(inner.replace("\\", "/"))
        if inner == ".." or inner.startswith("../") or inner.startswith("/"):
            return f"leaves the asset's package ({anchored})"
        anchored = outer
        if root_package is not None:
            return None if os.path.normpath(outer) == root_package else f"leaves the asset's package ({anchored})"
    path = os.path.normpath(anchored)
    if os.path.commonpath([path, root_dir]) != root_dir:
        return f"leaves the asset's {where} ({anchored})"
    real, real_root = os.path.realpath(path), os.path.realpath(root_dir)
    if os.path.commonpath([real, real_root]) != real_root:
        return f"is a symlink to {real}, outside the asset's {where}"
    return None


def _authored_paths(layer, issues: list) -> list[tuple[str, str, str]]:
    """(where, authored path, kind) of every value clip path (``#`` as ``0``) and asset-valued attribute value in
    ``layer``; a malformed ``clips`` value is an issue."""
    found = []

    def visit(path):
        if path.IsPropertyPath():
            spec = layer.GetPropertyAtPath(path)
            if path.name == "faceVertexCounts" and isinstance(spec, Sdf.AttributeSpec):
                values = [spec.default] + [layer.QueryTimeSample(path, t) for t in layer.ListTimeSamplesForPath(path)]
                if why := next(filter(None, map(face_over_budget, values)), None):
                    issues.append(Issue("budget", str(path), why))
            if isinstance(spec, Sdf.AttributeSpec) and spec.typeName in (Sdf.ValueTypeNames.Asset,
                                                                         Sdf.ValueTypeNames.AssetArray):
                values = [spec.default] if spec.HasDefaultValue() else []
                values += [layer.QueryTimeSample(path, t) for t in layer.ListTimeSamplesForPath(path)]
                for v in values:
                    for a in (v if isinstance(v, (list, tuple)) or hasattr(v, "__len__") and not isinstance(v, str)
                              else [v]):
                        if getattr(a, "path", None):
                            found.append((str(path), a.path, "asset"))
        if not path.IsPrimPath():
            return
        spec = layer.GetPrimAtPath(path)
        if spec is None or not spec.HasInfo("clips"):
            return
        where = f"{path} clips"
        clips = spec.GetInfo("clips")
        if not isinstance(clips, dict):
            issues.append(Issue("clip", where, f"is a {type(clips).__name__}, expected a dictionary of clip sets"))
            return
        for name, clip in clips.items():
            if not isinstance(clip, dict):
                issues.append(Issue("clip", f"{where}[{name}]", f"is a {type(clip).__name__}, expected a dictionary"))
                continue
            paths = clip.get("assetPaths", [])
            if isinstance(paths, str) or not all(isinstance(a, Sdf.AssetPath) for a in (
                    paths if hasattr(paths, "__iter__") else [paths])):
                issues.append(Issue("clip", f"{where}[{name}].assetPaths", f"{paths!r} is not an asset[] list"))
                paths = []
            found.extend((f"{where}[{name}].assetPaths", a.path, "clip") for a in paths if a.path)
            manifest = clip.get("manifestAssetPath")
            if manifest is not None and not isinstance(manifest, Sdf.AssetPath):
                issues.append(Issue("clip", f"{where}[{name}].manifestAssetPath", f"{manifest!r} is not an asset"))
            elif manifest is not None and manifest.path:
                found.append((f"{where}[{name}].manifestAssetPath", manifest.path, "clip"))
            template = clip.get("templateAssetPath")
            if template is not None and not isinstance(template, str):
                issues.append(Issue("clip", f"{where}[{name}].templateAssetPath", f"{template!r} is not a string"))
            elif template:
                found.append((f"{where}[{name}].templateAssetPath", template.replace("#", "0"), "clip template"))

    layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    return found


def _evaluate(authored: str, variables: dict) -> tuple[str | None, str]:
    """An authored asset path, with an asset-path expression (`` `"..."` ``) evaluated: (path or None, prefix)."""
    if not Sdf.VariableExpression.IsExpression(authored):
        return authored, f"path {authored!r}"
    result = Sdf.VariableExpression(authored).Evaluate(variables)
    value = result.value if isinstance(result.value, str) and not result.errors else None
    return value, f"path expression {authored!r}" + (f" (= {value!r})" if value is not None else "")


def _open_layer(identifier: str, issues: list):
    """Open one layer; a parse error becomes a ``layer`` issue naming the file and line."""
    try:
        layer = Sdf.Layer.FindOrOpen(identifier)
    except Tf.ErrorException as exc:
        text = " ".join(str(exc).split())
        if m := _PARSE_ERROR.search(str(exc)):
            msg = re.sub(r"pxrInternal_[A-Za-z0-9_]+::", "", m["msg"]).strip()
            issues.append(Issue("layer", m["file"], f"line {m['line']}, column {m['col']}: the layer does not "
                                f"parse: {msg}"))
        else:
            issues.append(Issue("layer", identifier, f"USD cannot read the layer: {text}"))
        return None
    if layer is None:
        issues.append(Issue("layer", identifier, "the layer does not exist or is not a USD layer"))
    return layer


def scan_dependencies(root_layer: str, allow_external: bool = False) -> Dependencies:
    """Walk ``root_layer`` (a layer or ``.usdz``) and the layers it composes without composing them."""
    root = os.path.abspath(os.fspath(root_layer))
    root_dir = os.path.dirname(root)
    root_package = root if root.lower().endswith(".usdz") else None
    severity = "warning" if allow_external else "error"
    allowed = " (read because external assets are allowed)" if allow_external else " (not read)"
    out = Dependencies()
    if root_package and _package_too_big(root, out.issues):
        return out
    queue, seen, variables = [root], {root}, None
    while queue:
        identifier = queue.pop(0)
        if why := over_budget(identifier):
            out.issues.append(Issue("budget", identifier, f"the layer {why}: not opened"))
            continue
        if (layer := _open_layer(identifier, out.issues)) is None:
            continue
        out.read.add(identifier)
        variables = dict(layer.expressionVariables) if variables is None else variables  # the root layer's
        where = layer.identifier if layer.identifier != root else os.fspath(root_layer)
        found = [(where, p, "layer") for p in layer.GetCompositionAssetDependencies()]
        found += _authored_paths(layer, out.issues)
        for spec_path, authored, kind in found:
            value, what = _evaluate(authored, variables)
            if value is None:
                out.external.add(authored)
                out.issues.append(Issue("assetPath", spec_path, f"{kind} {what} does not evaluate (not read)"))
                continue
            anchored = Sdf.ComputeAssetPathRelativeToLayer(layer, value) if value else value
            if anchored and not os.path.isabs(anchored) and not Ar.IsPackageRelativePath(anchored):
                # a search-path form ("c.usda") of a file that is not there: judged as relative to the layer
                anchored = os.path.join(os.path.dirname(layer.realPath or root), anchored)
            why = None
            if os.path.isabs(value) or _SCHEME.match(value) or value.startswith("\\\\"):
                why = "is absolute: an asset must be relocatable, its paths relative to the layer"
            elif value:
                why = _outside(anchored, root_dir, root_package)
            if why:
                out.external.update((authored, value))  # USD gives an expression's value to readers
                out.issues.append(Issue("assetPath", spec_path, f"{kind} {what} {why}{allowed}", severity))
                if not allow_external:
                    continue
            if kind == "asset" and anchored and not why:
                out.read.add(anchored)
            big = image_over_budget(anchored) if kind == "asset" and anchored else None
            if big:
                out.issues.append(Issue("budget", spec_path, f"{kind} {what} {big}: not read"))
            if kind in ("layer", "clip") and anchored and anchored not in seen:
                seen.add(anchored)
                queue.append(anchored)
    return out


def asset_digest(root_layer) -> str:
    """sha256 of every file the asset's composition reads, by relative path: moved or rebuilt the same, same digest."""
    root = os.path.abspath(os.fspath(root_layer))
    files = {Ar.SplitPackageRelativePathOuter(p)[0] if Ar.IsPackageRelativePath(p) else p
             for p in scan_dependencies(root).read}
    d = Digest()
    for f in sorted(f for f in files if os.path.isfile(f)):
        d.file(os.path.relpath(f, os.path.dirname(root)), f)
    return d.hexdigest()


#: Most files a ``.usdz`` may hold: more is refused before any validator lists each one.
MAX_PACKAGE_FILES = 10000


def _package_too_big(path: str, issues: list) -> bool:
    """A usdz with more than :data:`MAX_PACKAGE_FILES` files is one issue (count and the first few names)."""
    zf = Sdf.ZipFile.Open(path)
    names = list(zf.GetFileNames()) if zf else []
    if len(names) <= MAX_PACKAGE_FILES:
        return False
    issues.append(Issue("layer", path, f"the package holds {len(names):,} files (first: {', '.join(names[:3])}, ...); "
                        f"a rockdove asset holds at most {MAX_PACKAGE_FILES:,}: not opened"))
    return True


def blocking(deps: Dependencies) -> list:
    """The errors that must stop a reader before USD composes: broken layers and layers or clips from elsewhere."""
    return [i for i in only_errors(deps.issues) if i.check in ("layer", "clip") or not i.message.startswith("asset ")]


def require_inside(asset, allow_external: bool = False) -> str:
    """The root layer of ``asset`` once :func:`scan_dependencies` found nothing wrong, else VerificationFailed."""
    try:
        root = resolve_root_layer(asset)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if errors := only_errors(scan_dependencies(root, allow_external).issues):
        more = f"; and {len(errors) - 5} more" if len(errors) > 5 else ""
        hint = " (--allow-external-assets reads files from elsewhere)" if any(
            i.check == "assetPath" for i in errors) else ""
        raise VerificationFailed("; ".join(f"{i.path}: {i.message}" for i in errors[:5]) + more + hint)
    return root


"""The files an asset refers to, found without composing it: layers that do not parse, and asset paths that
point outside the asset.

``rockdove validate`` and ``rockdove verify`` run on assets other people edited, in CI. An asset must be
relocatable, so every asset path it authors (sublayers, references, payloads, asset-valued attributes such as
texture files) must be relative and stay inside the asset: inside the root layer's folder, or inside the
package for a ``.usdz``. :func:`scan_dependencies` walks the layer graph statically with ``Sdf`` (no stage is
composed, no texture is read) and reports

- ``assetPath`` issues: absolute paths (``/etc/passwd``, ``C:/x``, ``https://...``) and paths that leave the
  asset's folder (``../../x.png``). The layers such a path names are not opened, and :func:`external_paths`
  lists the authored paths so callers never read them, unless ``allow_external`` (then they are warnings);
- ``layer`` issues: a layer that does not parse, with its file, line and USD's message, or a composed layer
  that does not exist.
"""

from __future__ import annotations

import os
import posixpath
import re
from dataclasses import dataclass, field

from .issues import Issue, only_errors

#: ``file:line:column: message`` as USD's text parser reports a syntax error.
_PARSE_ERROR = re.compile(r"(?P<file>[^\s']+?):(?P<line>\d+):(?P<col>\d+): (?P<msg>[^\n]*)")
#: A URI scheme (``https:``, ``omniverse:``) or a drive letter (``C:``): not a relative path.
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")


@dataclass
class Dependencies:
    """What :func:`scan_dependencies` found.

    Attributes
    ----------
    issues : list of rockdove.usd.issues.Issue
    layers : list of str
        Identifiers of the layers that were opened (the root first).
    external : set of str
        Authored asset paths that are absolute or leave the asset (never read unless allowed).
    """

    issues: list = field(default_factory=list)
    layers: list = field(default_factory=list)
    external: set = field(default_factory=set)

    @property
    def errors(self) -> list:
        return only_errors(self.issues)


def _outside(anchored: str, root_dir: str, root_package: str | None) -> bool:
    """True when an anchored asset path is outside the asset (folder, or package for a usdz root)."""
    from pxr import Ar

    if Ar.IsPackageRelativePath(anchored):
        outer, inner = Ar.SplitPackageRelativePathOuter(anchored)
        inner = posixpath.normpath(inner.replace("\\", "/"))
        if inner == ".." or inner.startswith("../") or inner.startswith("/"):
            return True
        anchored = outer
        if root_package is not None:
            return os.path.normpath(outer) != root_package
    path = os.path.normpath(anchored)
    return os.path.commonpath([path, root_dir]) != root_dir


def _asset_values(layer) -> list[tuple[str, str]]:
    """(spec path, authored asset path) of every asset-valued attribute default and time sample in ``layer``."""
    from pxr import Sdf

    found = []

    def visit(path):
        if not path.IsPropertyPath():
            return
        spec = layer.GetPropertyAtPath(path)
        if not isinstance(spec, Sdf.AttributeSpec) or spec.typeName not in (Sdf.ValueTypeNames.Asset,
                                                                            Sdf.ValueTypeNames.AssetArray):
            return
        values = [spec.default] if spec.HasDefaultValue() else []
        values += [layer.QueryTimeSample(path, t) for t in layer.ListTimeSamplesForPath(path)]
        for v in values:
            for a in (v if isinstance(v, (list, tuple)) or hasattr(v, "__len__") and not isinstance(v, str)
                      else [v]):
                p = getattr(a, "path", None)
                if p:
                    found.append((str(path), p))

    layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    return found


def _open_layer(identifier: str, issues: list):
    """Open one layer; a parse error becomes a ``layer`` issue naming the file and line."""
    from pxr import Sdf, Tf

    try:
        layer = Sdf.Layer.FindOrOpen(identifier)
    except Tf.ErrorException as exc:
        text = " ".join(str(exc).split())
        m = _PARSE_ERROR.search(str(exc))
        if m:
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
    """Walk ``root_layer`` and the layers it composes (sublayers, references, payloads) without composing.

    Parameters
    ----------
    root_layer : str
        Path of the asset's root layer (``.usda``/``.usdc``/``.usd``) or its ``.usdz``.
    allow_external : bool
        Also open layers outside the asset and report such paths as warnings instead of errors.

    Returns
    -------
    Dependencies
    """
    from pxr import Sdf

    root = os.path.abspath(os.fspath(root_layer))
    root_dir = os.path.dirname(root)
    root_package = root if root.lower().endswith(".usdz") else None
    severity = "warning" if allow_external else "error"
    allowed = " (read because external assets are allowed)" if allow_external else " (not read)"
    out = Dependencies()
    queue, seen = [root], {root}
    while queue:
        identifier = queue.pop(0)
        layer = _open_layer(identifier, out.issues)
        if layer is None:
            continue
        out.layers.append(layer.identifier)
        where = layer.identifier if layer.identifier != root else os.fspath(root_layer)
        composed = [(where, p) for p in layer.GetCompositionAssetDependencies()]
        for spec_path, authored in composed + _asset_values(layer):
            is_layer = (spec_path, authored) in composed
            anchored = Sdf.ComputeAssetPathRelativeToLayer(layer, authored)
            why = None
            if os.path.isabs(authored) or _SCHEME.match(authored) or authored.startswith("\\\\"):
                why = "is absolute: an asset must be relocatable, its paths relative to the layer"
            elif _outside(anchored, root_dir, root_package):
                why = f"leaves the asset's {'package' if root_package else 'folder'} ({anchored})"
            if why:
                out.external.add(authored)
                kind = "layer" if is_layer else "asset"
                out.issues.append(Issue("assetPath", spec_path, f"{kind} path {authored!r} {why}{allowed}",
                                        severity))
                if not allow_external:
                    continue
            if is_layer and anchored not in seen:
                seen.add(anchored)
                queue.append(anchored)
    return out


def external_paths(root_layer: str, allow_external: bool = False) -> set:
    """The authored asset paths of ``root_layer``'s asset that must not be read (empty when allowed)."""
    return set() if allow_external else scan_dependencies(root_layer).external

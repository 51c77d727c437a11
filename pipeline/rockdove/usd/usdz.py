"""``DIR/pigeon.usdz``, by ``UsdUtils.CreateNewUsdzPackage``; usd-core's zip writer stores file times, so every file
gets ``SOURCE_DATE_EPOCH`` when set (reproducible builds) else 1980-01-01: byte-identical packages. Also
``DIR/pigeon_ar.usdz`` for AR Quick Look: one flattened ``.usdc``, only UsdPreviewSurface networks (OpenUSD's ARKit
checker, v23.11, allows no ``ND_*`` shader), the variant selections baked, no LUT (an EXR no AR viewer reads)."""

from __future__ import annotations

import os
import shutil
import tempfile

from ..errors import UsageError
from ..resources import atomic_path

USDZ_NAME = "pigeon.usdz"
AR_USDZ_NAME = "pigeon_ar.usdz"
#: Shader ids of UsdPreviewSurface networks (the ids ARKit's rules of v23.11 allow); every other shader is dropped.
PREVIEW_SHADER_IDS = ("UsdPreviewSurface", "UsdUVTexture", "UsdTransform2d", "UsdPrimvarReader_")
#: The motion AR Quick Look plays on open (it plays a package's time range in a loop): ``idle``, in place. The walk's
#: root motion would carry the bird 0.4 m from where the user placed it in 2 s and snap it back at every loop.
AR_MOTION = "idle"
#: 1980-01-01T00:00:00Z, the earliest time a zip (DOS) timestamp can hold.
ZIP_EPOCH = 315532800


def _root(out_dir: str, root_layer: str) -> tuple[str, str]:
    """(absolute out_dir, its root layer); registers the schema first. FileNotFoundError without the layer."""
    from .schema import register

    register()
    out_dir = os.path.abspath(out_dir)
    root = os.path.join(out_dir, root_layer)
    if not os.path.isfile(root):
        raise FileNotFoundError(f"out_dir: no root layer {root!r} to package")
    return out_dir, root


def _stamp(folder: str) -> None:
    """Give every file below ``folder`` but packages and scratch folders the fixed time."""
    value = os.environ.get("SOURCE_DATE_EPOCH")
    try:
        stamp = ZIP_EPOCH if value is None else max(int(value), ZIP_EPOCH)
    except ValueError:
        raise UsageError(f"SOURCE_DATE_EPOCH must be an integer (seconds), got {value!r}") from None
    for parent, dirs, files in os.walk(folder):
        dirs[:] = [d for d in dirs if not d.startswith(".usdz-")]
        for name in files:
            if not name.endswith(".usdz"):
                os.utime(os.path.join(parent, name), (stamp, stamp))


def ar_layer(root: str, motion: str | None = AR_MOTION):
    """The asset at ``root`` flattened into one anonymous layer with ``motion`` selected, without non-preview shaders,
    material outputs but surface and displacement, ``rockdove:lut:file``, and ``SkelAnimation``s no skeleton plays."""
    from pxr import Usd

    stage = Usd.Stage.Open(root, Usd.Stage.LoadAll)
    prim = stage.GetDefaultPrim()
    if motion is not None and prim and prim.GetVariantSets().HasVariantSet("motion"):  # an asset without a rig: none
        motions = prim.GetVariantSet("motion")
        if motion not in motions.GetVariantNames():
            raise UsageError(f"motion={motion!r}; {root} has the motions {list(motions.GetVariantNames())}")
        with Usd.EditContext(stage, stage.GetSessionLayer()):
            motions.SetVariantSelection(motion)
    layer = stage.Flatten(addSourceFileComment=False)
    played = {t for p in stage.Traverse() if p.GetTypeName() == "Skeleton"
              for t in p.GetRelationship("skel:animationSource").GetTargets()}
    dropped = []

    def walk(spec):
        for child in list(spec.nameChildren):
            ident = child.attributes.get("info:id")
            ident = ident.default if ident is not None else None
            if (child.typeName == "Shader" and not str(ident or "").startswith(PREVIEW_SHADER_IDS)
                    or child.typeName == "SkelAnimation" and child.path not in played):
                dropped.append(child.path)
            else:
                walk(child)
        for prop in list(spec.properties):
            extra_output = spec.typeName == "Material" and prop.name.startswith("outputs:") and prop.name not in (
                "outputs:surface", "outputs:displacement")
            if extra_output or prop.name == "rockdove:lut:file":
                spec.RemoveProperty(prop)

    walk(layer.pseudoRoot)
    for path in dropped:
        parent = layer.GetPrimAtPath(path.GetParentPath())
        del parent.nameChildren[path.name]
    return layer


def write_ar_usdz(out_dir: str, root_layer: str = "pigeon.usda", motion: str | None = AR_MOTION) -> str:
    """Write ``out_dir/pigeon_ar.usdz`` (:func:`ar_layer` and its textures, by ``CreateNewARKitUsdzPackage``)."""
    from pxr import Sdf, UsdUtils

    out_dir, root = _root(out_dir, root_layer)
    with tempfile.TemporaryDirectory(prefix=".usdz-", dir=out_dir) as scratch:
        layer = ar_layer(root, motion)
        used = []

        def localise(path: str) -> str:  # Flatten anchors asset paths: copy what lies in the asset into scratch
            rel = os.path.relpath(path, out_dir) if os.path.isabs(path) else None
            if rel is None or rel.startswith(os.pardir):
                return path
            if rel == root_layer:  # assetInfo's identifier: the package's own layer now
                return "./pigeon_ar.usdc"
            if rel.lower().endswith((".png", ".jpg", ".jpeg")):
                used.append(rel)
            return "./" + rel.replace(os.sep, "/")  # no build machine's path in the package

        UsdUtils.ModifyAssetPaths(layer, localise)
        for rel in used:
            os.makedirs(os.path.join(scratch, os.path.dirname(rel)), exist_ok=True)
            shutil.copyfile(os.path.join(out_dir, rel), os.path.join(scratch, rel))
        flat = os.path.join(scratch, "pigeon_ar.usdc")
        layer.Export(flat)
        _stamp(scratch)
        target = os.path.join(out_dir, AR_USDZ_NAME)
        with atomic_path(target) as package:
            if not UsdUtils.CreateNewARKitUsdzPackage(Sdf.AssetPath(flat), package):
                raise RuntimeError(f"UsdUtils.CreateNewARKitUsdzPackage failed for {root!r}")
    return target


def write_usdz(out_dir: str, root_layer: str = "pigeon.usda", *, in_place: bool = False) -> str:
    """``out_dir/pigeon.usdz`` from a stamped copy, or ``in_place`` from ``out_dir`` (the build's: already a copy)."""
    from pxr import Sdf, UsdUtils

    out_dir, root = _root(out_dir, root_layer)
    target = os.path.join(out_dir, USDZ_NAME)
    with tempfile.TemporaryDirectory(prefix=".usdz-", dir=out_dir) as scratch:
        src = out_dir
        if not in_place:
            src = os.path.join(scratch, "asset")
            shutil.copytree(out_dir, src, ignore=lambda d, names: [n for n in names if n.endswith(".usdz")
                                                                   or n.startswith(".usdz-")])
        _stamp(src)
        with atomic_path(target) as package:
            if not UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(os.path.join(src, root_layer)), package):
                raise RuntimeError(f"UsdUtils.CreateNewUsdzPackage failed for {root!r}")
    return target

"""USD reading helpers of :mod:`rockdove.render.scene`: flattened primvars, the bound material's textures and
constant colour, asset paths made absolute."""

from __future__ import annotations

import os

import numpy as np

from ..errors import UsageError
from ..usd.material import OPACITY_THRESHOLD

#: Shader prim names of the materials (docs/design.md, "USD asset").
BASE_COLOR_SHADER = "BaseColorTexture"
MASK_SHADER = "MaskTexture"
NORMAL_SHADER = "NormalTexture"
#: Shader inputs that may hold a constant base colour for untextured parts (UsdPreviewSurface, MaterialX).
CONSTANT_COLOUR_INPUTS = ("diffuseColor", "base_color", "baseColor")


def asset_abs_path(attr, value) -> str | None:
    """Absolute path of an asset-valued attribute (resolved by Ar, else anchored to the authoring layer)."""
    if value is None:
        return None
    resolved = getattr(value, "resolvedPath", "") or ""
    raw = getattr(value, "path", str(value))
    if not raw:
        return None
    if resolved:
        return os.path.abspath(resolved)
    for spec in attr.GetPropertyStack():
        if spec.HasDefaultValue() or spec.default is not None:
            return os.path.abspath(spec.layer.ComputeAbsolutePath(raw))
    return os.path.abspath(raw)


def primvar_array(values, interp: str, n_points: int, face_vertex_counts, name: str, prim_path: str):
    """Flattened primvar ``values`` and their interpolation: 'vertex' or 'faceVarying' (constant, uniform expanded)."""
    a = np.asarray(values)
    n_faces = len(face_vertex_counts)
    if interp == "constant":
        return np.repeat(a.reshape(1, *a.shape[1:]) if a.ndim else a[None], n_points, axis=0), "vertex"
    if interp == "uniform":
        if len(a) != n_faces:
            raise UsageError(f"{prim_path}: primvar {name} is uniform with {len(a)} values for {n_faces} faces")
        return np.repeat(a, face_vertex_counts, axis=0), "faceVarying"
    if interp in ("vertex", "varying"):
        if len(a) != n_points:
            raise UsageError(f"{prim_path}: primvar {name} has {len(a)} values for {n_points} points")
        return a, "vertex"
    if interp == "faceVarying":
        if len(a) != int(np.sum(face_vertex_counts)):
            raise UsageError(f"{prim_path}: faceVarying primvar {name} has {len(a)} values")
        return a, "faceVarying"
    raise UsageError(f"{prim_path}: primvar {name} has unsupported interpolation {interp!r}")


def material_info(prim, stage):
    """(material kind, base texture, srgb?, mask texture, constant colour, opacity threshold, normal map)."""
    from pxr import Usd, UsdShade

    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    if not mat:
        return None, None, True, None, None, OPACITY_THRESHOLD, None
    name = mat.GetPrim().GetName()
    kind = name[: -len("Material")].lower() if name.endswith("Material") and len(name) > 8 else name.lower()
    base = mask = colour_const = normal = None
    srgb, threshold = True, OPACITY_THRESHOLD
    for p in Usd.PrimRange(mat.GetPrim()):
        if not p.IsA(UsdShade.Shader):
            continue
        sh = UsdShade.Shader(p)
        if p.GetName() in (BASE_COLOR_SHADER, MASK_SHADER, NORMAL_SHADER):
            inp = sh.GetInput("file")
            if not inp:
                raise UsageError(f"{p.GetPath()}: texture shader has no inputs:file")
            path = asset_abs_path(inp.GetAttr(), inp.Get())
            if path is None:
                raise UsageError(f"{p.GetPath()}: inputs:file is empty")
            if not os.path.isfile(path):
                raise UsageError(f"{p.GetPath()}: texture {path!r} does not exist")
            if p.GetName() == BASE_COLOR_SHADER:
                base = path
                cs = sh.GetInput("sourceColorSpace")
                cs_val = cs.Get() if cs else None
                if cs_val is None:  # MaterialX: colorspace metadata on the file input
                    cs_val = inp.GetAttr().GetColorSpace() or "sRGB"
                srgb = str(cs_val).lower() not in ("raw", "lin_rec709", "linear")
            elif p.GetName() == MASK_SHADER:
                mask = path
            else:
                normal = path
        for key in CONSTANT_COLOUR_INPUTS:
            inp = sh.GetInput(key)
            if inp and colour_const is None and not inp.HasConnectedSource():
                v = inp.Get()
                if v is not None:
                    colour_const = np.asarray(v, dtype=np.float32).reshape(3)
        thr = sh.GetInput("opacityThreshold")
        if thr and thr.Get() is not None and float(thr.Get()) > 0:
            threshold = float(thr.Get())
    return kind, base, srgb, mask, colour_const, threshold, normal

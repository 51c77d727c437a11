"""A small synthetic asset in the layout of docs/design.md ("USD asset", "Textures"), for tests and benchmarks.

It is written with pxr exactly as the real asset is laid out (interface layer ``pigeon.usda`` with a payload
``pigeon_payload.usda`` and a ``shading`` variant set, ``/Pigeon/Geom/{Body, NeckFeathers}``,
``/Pigeon/Looks/{BodyMaterial, FeatherMaterial}`` with ``BaseColorTexture``/``MaskTexture`` UsdUVTexture
shaders, ``RockDoveThinFilmAPI`` applied with :func:`pipeline.usd.schema.apply_thin_film`, PNG textures and a
LUT EXR), so the renderers can be tested without the full build. It is *not* the bird: a UV sphere and a ring
of square feather cards with a thickness gradient from the card base (``thickness_range_nm[0]``) to its tip.
"""

from __future__ import annotations

import os

import numpy as np

from ..films import PAPER_FILM_INDEX

#: Layout of the synthetic asset, metres.
BODY_RADIUS_M = 0.1
BODY_CENTRE_M = (0.0, 0.15, 0.0)
NECK_CENTRE_M = (0.0, 0.28, 0.0)
NECK_RING_RADIUS_M = 0.05
CARD_SIZE_M = 0.045
#: The measured thickness span (Yoshioka 2007); the film is the paper film (pipeline.films.PAPER_FILM_INDEX).
THICKNESS_RANGE_NM = (480.0, 700.0)


def gradient_lut(n_thickness: int = 16, n_angle: int = 32, thickness_range_nm=THICKNESS_RANGE_NM, gamma=1.0):
    """A LUT with a known gradient: R = node x (angle axis), G = node y (thickness axis), B = 0.25."""
    from pipeline.lut import ThinFilmLUT

    x = np.linspace(0.0, 1.0, n_angle)
    y = np.linspace(0.0, 1.0, n_thickness)
    rgb = np.zeros((n_thickness, n_angle, 3), np.float32)
    rgb[..., 0] = x[None, :]
    rgb[..., 1] = y[:, None]
    rgb[..., 2] = 0.25
    return ThinFilmLUT(rgb, tuple(thickness_range_nm), gamma, metadata={"method": "synthetic gradient"})


def _uv_sphere(radius, n_lon=24, n_lat=12):
    """Quads (and triangles at the poles) of a UV sphere; vertices split at the seam. Returns arrays."""
    lon = np.linspace(0, 2 * np.pi, n_lon + 1)
    lat = np.linspace(-np.pi / 2, np.pi / 2, n_lat + 1)
    lo, la = np.meshgrid(lon, lat)
    nrm = np.stack([np.cos(la) * np.sin(lo), np.sin(la), np.cos(la) * np.cos(lo)], axis=-1).reshape(-1, 3)
    st = np.stack([lo / (2 * np.pi), (la + np.pi / 2) / np.pi], axis=-1).reshape(-1, 2)
    idx = np.arange((n_lat + 1) * (n_lon + 1)).reshape(n_lat + 1, n_lon + 1)
    a, b = idx[:-1, :-1], idx[:-1, 1:]
    c, d = idx[1:, 1:], idx[1:, :-1]
    quads = np.stack([a, b, c, d], axis=-1).reshape(-1, 4)  # counter-clockwise seen from outside
    return (nrm * radius).astype(np.float32), nrm.astype(np.float32), st.astype(np.float32), quads


def _cards(n_cards):
    """Square cards on a ring around the neck, each facing outward; thickness from base to tip."""
    pts, nrms, sts, thick, quads, neck_s = [], [], [], [], [], []
    lo, hi = THICKNESS_RANGE_NM
    for k in range(n_cards):
        phi = 2 * np.pi * k / n_cards
        out = np.array([np.sin(phi), 0.0, np.cos(phi)])
        tangent = np.array([np.cos(phi), 0.0, -np.sin(phi)])
        up = np.array([0.0, 1.0, 0.0])
        c = np.asarray(NECK_CENTRE_M) + NECK_RING_RADIUS_M * out
        h = CARD_SIZE_M / 2
        corners = [c - h * tangent - h * up, c + h * tangent - h * up, c + h * tangent + h * up, c - h * tangent + h * up]
        # counter-clockwise seen from `out`: tangent x up = out
        pts += corners
        nrms += [out] * 4
        sts += [(0, 0), (1, 0), (1, 1), (0, 1)]
        thick += [lo, lo, hi, hi]
        neck_s += [k / max(n_cards - 1, 1)] * 4
        quads.append(np.arange(4) + 4 * k)
    return (
        np.asarray(pts, np.float32),
        np.asarray(nrms, np.float32),
        np.asarray(sts, np.float32),
        np.asarray(thick, np.float32),
        np.asarray(neck_s, np.float32),
        np.asarray(quads),
    )


def _feather_textures(size=64):
    """Base RGBA (brownish grey, alpha = an ellipse), mask (1 on the upper, tip half, a soft ramp)."""
    yy, xx = np.mgrid[0:size, 0:size]
    u = (xx + 0.5) / size
    t = 1 - (yy + 0.5) / size  # image row 0 is the top, t = 1
    inside = ((u - 0.5) / 0.42) ** 2 + ((t - 0.5) / 0.48) ** 2 <= 1.0
    base = np.zeros((size, size, 4), np.uint8)
    base[..., 0], base[..., 1], base[..., 2] = 110, 100, 105
    base[..., 3] = np.where(inside, 255, 0)
    mask = (np.clip((t - 0.35) / 0.2, 0, 1) * 255).astype(np.uint8)
    return base, mask


def write_synthetic_asset(out_dir, lut=None, n_cards: int = 6) -> str:
    """Write the synthetic asset into ``out_dir`` and return the root layer path (``out_dir/pigeon.usda``).

    Parameters
    ----------
    out_dir : path
        Folder to write (created).
    lut : ThinFilmLUT, optional
        The LUT written to ``textures/thinfilm_lut.exr``; default :func:`gradient_lut`.
    n_cards : int
        Number of feather cards on the neck ring.
    """
    from PIL import Image
    from pxr import Gf, Kind, Sdf, Usd, UsdGeom, UsdShade, Vt

    from ..lut.exr import write_exr
    from ..usd.schema import apply_thin_film
    from .scene import register_schema

    register_schema()  # before the first stage of the process (USD builds its schema registry once)
    if lut is None:
        lut = gradient_lut()
    out_dir = os.path.abspath(os.fspath(out_dir))
    tex_dir = os.path.join(out_dir, "textures")
    os.makedirs(tex_dir, exist_ok=True)
    write_exr(lut, os.path.join(tex_dir, "thinfilm_lut.exr"))
    base, mask = _feather_textures()
    Image.fromarray(base, "RGBA").save(os.path.join(tex_dir, "feather_base.png"))
    Image.fromarray(mask, "L").save(os.path.join(tex_dir, "feather_mask.png"))
    yy, xx = np.mgrid[0:32, 0:64]
    body = np.stack([90 + 40 * (xx % 16 < 8), 95 + 0 * xx, 110 + 30 * (yy % 8 < 4)], axis=-1).astype(np.uint8)
    Image.fromarray(body, "RGB").save(os.path.join(tex_dir, "body_base.png"))

    # -- payload: contents ----------------------------------------------------------------------------------
    payload_path = os.path.join(out_dir, "pigeon_payload.usda")
    st = Usd.Stage.CreateNew(payload_path)
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(st, 1.0)
    root = UsdGeom.Xform.Define(st, "/Pigeon")
    st.SetDefaultPrim(root.GetPrim())
    UsdGeom.Scope.Define(st, "/Pigeon/Geom")
    UsdGeom.Scope.Define(st, "/Pigeon/Looks")

    def material(name, tex_inputs):
        mat = UsdShade.Material.Define(st, f"/Pigeon/Looks/{name}")
        surf = UsdShade.Shader.Define(st, f"/Pigeon/Looks/{name}/Surface")
        surf.CreateIdAttr("UsdPreviewSurface")
        reader = UsdShade.Shader.Define(st, f"/Pigeon/Looks/{name}/StReader")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
        for shader_name, file, cs in tex_inputs:
            tex = UsdShade.Shader.Define(st, f"/Pigeon/Looks/{name}/{shader_name}")
            tex.CreateIdAttr("UsdUVTexture")
            tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(f"./textures/{file}"))
            tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(cs)
            tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
            if shader_name == "BaseColorTexture":
                rgb = tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
                surf.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(rgb)
                if file.startswith("feather"):
                    a = tex.CreateOutput("a", Sdf.ValueTypeNames.Float)
                    surf.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(a)
                    surf.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
        mat.CreateSurfaceOutput().ConnectToSource(surf.ConnectableAPI(), "surface")
        return mat

    body_mat = material("BodyMaterial", [("BaseColorTexture", "body_base.png", "sRGB")])
    feather_mat = material(
        "FeatherMaterial", [("BaseColorTexture", "feather_base.png", "sRGB"), ("MaskTexture", "feather_mask.png", "raw")]
    )

    def mesh(name, pts, nrm, stc, faces, mat, colour):
        m = UsdGeom.Mesh.Define(st, f"/Pigeon/Geom/{name}")
        m.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
        m.CreateFaceVertexCountsAttr(Vt.IntArray([len(f) for f in faces]))
        m.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for f in faces for i in f]))
        m.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(nrm))
        m.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        pv = UsdGeom.PrimvarsAPI(m)
        pv.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
            Vt.Vec2fArray.FromNumpy(stc)
        )
        pv.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant).Set(
            Vt.Vec3fArray([Gf.Vec3f(*colour)])
        )
        m.CreateExtentAttr(UsdGeom.Mesh.ComputeExtent(m.GetPointsAttr().Get()))
        UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(mat)
        return m

    spts, snrm, sst, squads = _uv_sphere(BODY_RADIUS_M)
    faces = [q for q in squads]  # keep quads (degenerate at poles, which triangulation tolerates)
    body = mesh("Body", spts, snrm, sst, faces, body_mat, (0.3, 0.3, 0.35))
    body.AddTranslateOp().Set(Gf.Vec3d(*BODY_CENTRE_M))  # exercises world transforms
    cpts, cnrm, cst, thick, neck_s, cquads = _cards(n_cards)
    feathers = mesh("NeckFeathers", cpts, cnrm, cst, list(cquads), feather_mat, (0.4, 0.38, 0.4))
    feathers.CreateDoubleSidedAttr(True)
    pv = UsdGeom.PrimvarsAPI(feathers)
    pv.CreatePrimvar("thickness", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex).Set(
        Vt.FloatArray.FromNumpy(thick)
    )
    pv.CreatePrimvar("neckS", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex).Set(
        Vt.FloatArray.FromNumpy(neck_s)
    )
    apply_thin_film(feathers.GetPrim(), model="paper", cauchy_a=PAPER_FILM_INDEX, cauchy_b_nm2=0.0,
                    incident_index=1.0, substrate_index=1.0, lut_file="./textures/thinfilm_lut.exr",
                    lut_colour_space=lut.colour_space, angle_warp_gamma=lut.angle_warp_gamma,
                    thickness_range_nm=lut.thickness_range_nm)
    st.GetRootLayer().Save()

    # -- interface layer --------------------------------------------------------------------------------------
    root_path = os.path.join(out_dir, "pigeon.usda")
    st = Usd.Stage.CreateNew(root_path)
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(st, 1.0)
    prim = UsdGeom.Xform.Define(st, "/Pigeon").GetPrim()
    st.SetDefaultPrim(prim)
    Usd.ModelAPI(prim).SetKind(Kind.Tokens.component)
    prim.GetPayloads().AddPayload("./pigeon_payload.usda")
    vs = prim.GetVariantSets().AddVariantSet("shading")
    for v in ("baked", "physical"):
        vs.AddVariant(v)
        vs.SetVariantSelection(v)
        with vs.GetVariantEditContext():
            prim.CreateAttribute("rockdove:shadingMode", Sdf.ValueTypeNames.Token, custom=True).Set(v)
    vs.SetVariantSelection("baked")
    st.GetRootLayer().Save()
    return root_path

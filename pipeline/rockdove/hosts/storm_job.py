"""Storm's side of :mod:`rockdove.hosts.storm`, run as ``python storm_job.py job.json`` by the Python that has bpy
(its bundled USD has imaging; usd-core has none); of rockdove, :mod:`.jobs` alone. Each view, recorded by
``FrameRecorder`` into ``<view>.exr``, may carry a ``time`` and ``only`` the meshes it draws (storm_motion's)."""

import ctypes
import os
import sys

import jobs  # the sibling module (this file is run by path: its folder is sys.path[0])


def bundled_usd_first() -> str:
    """Put bpy's bundled site-packages (pxr with imaging) first on sys.path, HdMtlx at its MaterialX libraries."""
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        raise RuntimeError("bpy is not installed in this Python")
    root = os.path.dirname(spec.origin)
    ver = f"python{sys.version_info.major}.{sys.version_info.minor}"
    for version in sorted(os.listdir(root)):
        site = os.path.join(root, version, "python", "lib", ver, "site-packages")
        if os.path.isdir(os.path.join(site, "pxr", "UsdImagingGL")):
            sys.path.insert(0, site)
            os.environ.setdefault("PXR_MTLX_STDLIB_SEARCH_PATHS", os.path.join(root, "lib", "materialx", "libraries"))
            return root
    raise RuntimeError(f"bpy at {root} bundles no pxr with imaging (pxr.UsdImagingGL)")


def egl_context(width: int = 1024, height: int = 1024):
    """Make an EGL surfaceless OpenGL compatibility context current (Storm's GL posts "invalid enum" in a core one)."""
    egl = ctypes.CDLL("libEGL.so.1")
    vp, ip = ctypes.c_void_p, ctypes.POINTER(ctypes.c_int)
    for fn, restype, argtypes in (("eglGetProcAddress", vp, [ctypes.c_char_p]), ("eglInitialize", None, [vp, ip, ip]),
                                  ("eglCreateContext", vp, [vp] * 3 + [ip]), ("eglMakeCurrent", None, [vp] * 4),
                                  ("eglChooseConfig", None, [vp, ip, ctypes.POINTER(vp), ctypes.c_int, ip]),
                                  ("eglCreatePbufferSurface", vp, [vp, vp, ip])):
        if restype is not None:
            getattr(egl, fn).restype = restype
        getattr(egl, fn).argtypes = argtypes
    get_display = ctypes.CFUNCTYPE(vp, ctypes.c_uint, vp, vp)(egl.eglGetProcAddress(b"eglGetPlatformDisplayEXT"))
    dpy = get_display(0x31DD, None, None)  # EGL_PLATFORM_SURFACELESS_MESA
    major, minor = ctypes.c_int(), ctypes.c_int()
    if not dpy or not egl.eglInitialize(dpy, ctypes.byref(major), ctypes.byref(minor)):
        raise RuntimeError("EGL: no surfaceless display (Mesa's libEGL with EGL_MESA_platform_surfaceless)")
    attrs = (ctypes.c_int * 5)(0x3033, 0x0001, 0x3040, 0x0008, 0x3038)  # PBUFFER_BIT surface, OPENGL_BIT
    cfg, n = vp(), ctypes.c_int()
    if not egl.eglChooseConfig(dpy, attrs, ctypes.byref(cfg), 1, ctypes.byref(n)) or n.value < 1:
        raise RuntimeError("EGL: no OpenGL config")
    egl.eglBindAPI(0x30A2)  # EGL_OPENGL_API
    ctx_attrs = (ctypes.c_int * 7)(0x3098, 4, 0x30FB, 5, 0x30FD, 0x2, 0x3038)  # 4.5, COMPATIBILITY profile
    ctx = egl.eglCreateContext(dpy, cfg, None, ctx_attrs)
    # a pbuffer, so that the default framebuffer is complete (Storm's present step draws into it)
    surf = egl.eglCreatePbufferSurface(dpy, cfg, (ctypes.c_int * 5)(0x3057, width, 0x3056, height, 0x3038))
    if not ctx or not surf or not egl.eglMakeCurrent(dpy, surf, surf, ctx):
        raise RuntimeError("EGL: cannot make an OpenGL 4.5 compatibility context current")
    return egl, dpy, ctx, surf


def _black(surface) -> None:
    """A UsdPreviewSurface that reflects nothing: diffuse 0, ior 1 (Fresnel F0 = 0)."""
    from pxr import Gf, Sdf, UsdShade

    shader = UsdShade.Shader(surface)
    diffuse = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
    diffuse.GetAttr().SetConnections([])
    diffuse.Set(Gf.Vec3f(0.0, 0.0, 0.0))
    shader.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)


def _session(stage, job: jobs.StormJob):
    """The session layer's opinions: variant, lobe overrides, dome light, cameras. Returns camera paths."""
    from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

    stage.SetEditTarget(stage.GetSessionLayer())
    root = stage.GetDefaultPrim()
    if job.variant in ("baked", "physical"):
        root.GetVariantSet("shading").SetVariantSelection(job.variant)
    if job.motion:  # Storm skins the meshes itself (UsdSkel's ExtComputations) at each view's time
        root.GetVariantSet("motion").SetVariantSelection(job.motion)
    for prim in stage.Traverse():  # the rest pose as authored: Hydra replaces a skinned mesh's normals by its own
        if prim.GetTypeName() == "Skeleton" and not job.motion:
            prim.SetActive(False)
    for prim in stage.Traverse():
        if not prim.IsA(UsdShade.Material) or job.as_authored:  # as authored: what a usdview user sees
            continue
        out = UsdShade.Material(prim).GetSurfaceOutput("mtlx")
        if not out.GetAttr().IsValid() or not out.HasConnectedSource():
            _black(prim.GetChild("PreviewSurface"))  # other parts: black, they only occlude (the lobe)
        elif job.variant == "preview":
            out.GetAttr().SetConnections([])  # a Storm without MaterialX: the UsdPreviewSurface network
        for name, value in job.overrides.get(prim.GetName(), {}).items():
            shader, inp = name.split(".")
            attr = prim.GetChild(shader).GetAttribute(f"inputs:{inp}")
            if attr.IsValid():
                attr.SetConnections([])
                attr.Set(Gf.Vec3f(*value) if isinstance(value, list) else value)
    dome = UsdLux.DomeLight.Define(stage, "/RockdoveStorm/Environment")  # white.png: white in every colour space
    dome.CreateTextureFileAttr(Sdf.AssetPath(os.path.join(job.out_dir, "white.png")))
    dome.CreateIntensityAttr(float(job.environment_radiance))
    dome.CreateExposureAttr(0.0)
    cams = []
    for view in job.views:
        cam = UsdGeom.Camera.Define(stage, f"/RockdoveStorm/Cam_{view.name}")
        vert = 2.0 * 50.0 * __import__("math").tan(float(view.yfov_rad) / 2.0)
        cam.CreateFocalLengthAttr(50.0)
        cam.CreateVerticalApertureAttr(vert)
        cam.CreateHorizontalApertureAttr(vert * view.width / view.height)
        cam.CreateClippingRangeAttr(Gf.Vec2f(1e-3, 1e3))
        cam.AddTransformOp().Set(Gf.Matrix4d(*[float(x) for row in view.camera_to_world for x in row]).GetTranspose())
        cams.append(cam)
    return cams


def run(job: jobs.StormJob) -> None:
    bundled_usd_first()
    keep = egl_context(max(v.width for v in job.views), max(v.height for v in job.views))  # noqa: F841 (lives on)
    from pxr import Usd, UsdAppUtils, UsdGeom

    if (stage := Usd.Stage.Open(job.asset)) is None:
        raise RuntimeError(f"{job.asset}: not a USD stage")
    cams = _session(stage, job)
    rec = UsdAppUtils.FrameRecorder("HdStormRendererPlugin", True)
    rec.SetColorCorrectionMode("disabled")
    rec.SetCameraLightEnabled(False)
    rec.SetDomeLightVisibility(False)
    rec.SetComplexity(1.0)
    meshes = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    for view, cam in zip(job.views, cams):
        rec.SetImageWidth(int(view.width))
        path = os.path.join(job.out_dir, f"{view.name}.exr")
        for prim in meshes:  # a view of some meshes (prim names), the others invisible
            hidden = view.only is not None and prim.GetName() not in view.only
            visibility = UsdGeom.Tokens.invisible if hidden else UsdGeom.Tokens.inherited
            UsdGeom.Imageable(prim).GetVisibilityAttr().Set(visibility)
        time = Usd.TimeCode(view.time) if view.time is not None else Usd.TimeCode.Default()
        if not rec.Record(stage, cam, time, path):
            raise RuntimeError(f"Storm: FrameRecorder.Record failed for view {view.name!r}")
        print(f"storm: {view.name} -> {path}", flush=True)


def main() -> int:
    try:
        run(jobs.StormJob.read(sys.argv[1]))
    except Exception as exc:  # one line for the host's HostError; the log keeps the rest
        print(f"storm: {type(exc).__name__}: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

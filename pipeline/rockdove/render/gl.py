"""Offscreen OpenGL renders of a :class:`~rockdove.render.scene.RenderScene` with rockdove's GLSL shaders.

pyrender (EGL, Mesa llvmpipe, headless) draws every part with ``materials/glsl/thinfilm.vert`` / ``.frag`` (the
paper's method, docs/design.md "Conventions"); ``texcoord_0`` = USD ``st``, ``texcoord_1`` = (thickness_nm, neckS).
Textures and framebuffer are rockdove's own float ones (pyrender's would quantise to 8 bits): three ``GL_RGBA32F``
attachments (radiance + coverage; part id, view depth, cos_theta, thickness; N.L, mask, st) read back as floats.
No multisampling by default: every pixel is the shading at its centre, which the verifier compares with the CPU
reference; pictures ask for multisampling with alpha-to-coverage (:meth:`GLRenderer.render`). Parts are drawn in
scene order (pyrender's own order comes from a set: pixels where two parts tie in depth differed between processes)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import resources
from ..errors import UsageError
from .scene import RenderScene, ScenePart
from .texture import read_texture
from .views import View

#: Angle definitions the shader accepts (``u_angle_mode``): the paper's light/view half-angle, and the
#: view-only ``|N . V|`` of the MaterialX baked network (docs/design.md "Conventions").
ANGLE_MODES = {"physical": 0, "materialx_baked": 1}
#: Texture units: base colour, mask, LUT.
UNIT_BASE, UNIT_MASK, UNIT_LUT = 0, 1, 2


@dataclass(eq=False)
class RenderResult:
    """One rendered view; images are (H, W[, C]) float32 with row 0 at the top, 0 on the background."""

    view: View
    radiance_rgb: np.ndarray  # linear lin_rec709, unclipped
    alpha: np.ndarray  # coverage: 1 where a surface was drawn (feather fragments with alpha < 0.5 are discarded)
    part_id: np.ndarray  # int16, index + 1 into part_names
    depth_m: np.ndarray  # distance along the camera's viewing axis
    cos_theta: np.ndarray  # the LUT's angle input (0 off the feathers)
    thickness_nm: np.ndarray  # interpolated film thickness (0 off the feathers)
    n_dot_l: np.ndarray  # max(dot(N, L), 0) with the two-sided normal
    mask: np.ndarray  # structural-colour mask (0 off the feathers)
    st: np.ndarray  # (H, W, 2) interpolated texture coordinates
    part_names: tuple = ()
    seconds: float = 0.0  # wall time of the render and read-back


def _program_cache():
    """A pyrender ShaderProgramCache whose every program is the thin-film one, with pyrender's defines."""
    from pyrender.shader_program import ShaderProgramCache

    class ThinFilmProgramCache(ShaderProgramCache):
        def get_program(self, vertex_shader, fragment_shader, geometry_shader=None, defines=None):
            return super().get_program("thinfilm.vert", "thinfilm.frag", None, defines)

    return ThinFilmProgramCache(shader_dir=str(resources.path("materials/glsl")))


def offscreen_renderer(width: int, height: int):
    """A pyrender ``OffscreenRenderer`` whose ``delete()`` ends its own EGL context and no other, and gives the thread
    back the context it had. pyrender 0.1.45's calls ``eglTerminate`` on the display, of which EGL keeps one per
    process: that broke every renderer still open (``eglMakeCurrent``: EGL_BAD_DISPLAY, 12296), e.g. the next step's
    of a verification while the GL views' thread closed its own; and one the garbage collector deletes (a renderer
    not closed) may run in the middle of another's draw, which then drew in no context."""
    import ctypes

    from rockdove._compat import import_pyrender

    offscreen = import_pyrender().OffscreenRenderer(width, height)
    platform, pyrender_delete = offscreen._platform, offscreen.delete
    if not hasattr(platform, "_egl_context"):  # OSMesa (PYOPENGL_PLATFORM=osmesa) shares no display
        return offscreen
    address = lambda p: ctypes.cast(p, ctypes.c_void_p).value  # noqa: E731
    mine = address(platform._egl_context)

    def delete_context() -> None:
        from OpenGL.EGL import EGL_NO_CONTEXT, EGL_NO_SURFACE, eglDestroyContext, eglMakeCurrent

        if platform._egl_context is not None:
            eglMakeCurrent(platform._egl_display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT)
            eglDestroyContext(platform._egl_display, platform._egl_context)
            platform._egl_context = None

    def delete() -> None:
        from OpenGL.EGL import EGL_NO_SURFACE, eglGetCurrentContext, eglGetCurrentDisplay, eglMakeCurrent

        display, context = eglGetCurrentDisplay(), eglGetCurrentContext()
        pyrender_delete()
        if address(context) not in (None, mine):
            eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)

    platform.delete_context, offscreen.delete = delete_context, delete
    return offscreen


def upload_float_texture(image: np.ndarray, mipmaps: bool = False) -> int:
    """Upload an image, (H, W[, 1-4]) (uint8 as c / 255) with row 0 = t = 0 (bottom), as a GL float texture (linear,
    clamped; trilinear over a mip chain with ``mipmaps``)."""
    from OpenGL import GL

    data = np.asarray(image, np.float32) / (255.0 if image.dtype == np.uint8 else 1.0)
    data = np.ascontiguousarray(data.reshape(*data.shape[:2], -1))
    internal, fmt = {1: (GL.GL_R32F, GL.GL_RED), 2: (GL.GL_RG32F, GL.GL_RG), 3: (GL.GL_RGB32F, GL.GL_RGB),
                     4: (GL.GL_RGBA32F, GL.GL_RGBA)}[data.shape[2]]
    tex = GL.glGenTextures(1)
    GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
    GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 1)
    GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, internal, data.shape[1], data.shape[0], 0, fmt, GL.GL_FLOAT, data)
    GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 4)
    if mipmaps:
        GL.glGenerateMipmap(GL.GL_TEXTURE_2D)
    for p, v in ((GL.GL_TEXTURE_MIN_FILTER, GL.GL_LINEAR_MIPMAP_LINEAR if mipmaps else GL.GL_LINEAR),
                 (GL.GL_TEXTURE_MAG_FILTER, GL.GL_LINEAR),
                 (GL.GL_TEXTURE_WRAP_S, GL.GL_CLAMP_TO_EDGE), (GL.GL_TEXTURE_WRAP_T, GL.GL_CLAMP_TO_EDGE)):
        GL.glTexParameteri(GL.GL_TEXTURE_2D, p, v)
    GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
    return int(tex)


def _framebuffer(width, height, samples) -> tuple[int, list[int]]:
    """A framebuffer of three ``GL_RGBA32F`` colour attachments and a float depth buffer, ``samples`` per pixel."""
    from OpenGL import GL

    def storage(fmt):
        rb = GL.glGenRenderbuffers(1)
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, rb)
        if samples > 1:
            GL.glRenderbufferStorageMultisample(GL.GL_RENDERBUFFER, samples, fmt, width, height)
        else:
            GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, fmt, width, height)
        return int(rb)

    fbo = GL.glGenFramebuffers(1)
    GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fbo)
    rbs = [storage(GL.GL_RGBA32F) for _ in range(3)] + [storage(GL.GL_DEPTH_COMPONENT32F)]
    for k, rb in enumerate(rbs):
        at = GL.GL_DEPTH_ATTACHMENT if k == 3 else GL.GL_COLOR_ATTACHMENT0 + k
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, at, GL.GL_RENDERBUFFER, rb)
    GL.glDrawBuffers(3, [GL.GL_COLOR_ATTACHMENT0 + k for k in range(3)])
    status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
    GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
    if status != GL.GL_FRAMEBUFFER_COMPLETE:
        raise RuntimeError(f"float framebuffer ({samples} samples) incomplete (status {status:#x})")
    return int(fbo), rbs


@dataclass
class _PartGL:
    index: int
    part: ScenePart
    base_tex: int | None = None
    mask_tex: int | None = None


class GLRenderer:
    """pyrender offscreen renderer of one scene, reused across views (each sets its own size). ``lut`` overrides the
    scene's; ``angle_mode``: ``"physical"`` (``cos_theta = dot(L, H)``) or ``"materialx_baked"`` (``|dot(N, V)|``).
    Use as a context manager or call :meth:`delete` (a pyrender scene must not be bound to two live renderers)."""

    def __init__(self, scene: RenderScene, lut=None, angle_mode: str = "physical", width: int = 512, height: int = 512,
                 mipmaps: bool = False):
        if angle_mode not in ANGLE_MODES:
            raise UsageError(f"angle_mode={angle_mode!r} is not allowed; use one of {sorted(ANGLE_MODES)}")
        if not isinstance(scene, RenderScene):
            raise UsageError(f"scene must be a RenderScene, got {type(scene).__name__}")
        from rockdove._compat import import_pyrender

        pyrender = import_pyrender()
        self.scene = scene
        self.angle_mode, self.mipmaps = angle_mode, mipmaps
        self.lut = lut if lut is not None else (scene.load_lut() if scene.film is not None else None)
        self._fbo = self._fbo_size = self._view = self._resolve = None
        self._buffers = 3
        self._fbos: dict[tuple, tuple] = {}
        self._deleted = False

        self._pr_scene = pyrender.Scene(bg_color=np.zeros(4), ambient_light=np.zeros(3))
        self._parts: list[_PartGL] = []
        self._by_primitive: dict[int, _PartGL] = {}
        nodes = []
        for i, part in enumerate(scene.parts):
            film = np.zeros((len(part.positions_m), 2), np.float32)
            if part.thickness_nm is not None:
                film[:, 0] = part.thickness_nm
            if part.neck_s is not None:
                film[:, 1] = part.neck_s
            material = pyrender.MetallicRoughnessMaterial(doubleSided=True, name=part.name)
            prim = pyrender.Primitive(positions=part.positions_m, normals=part.normals, texcoord_0=part.st,
                                      texcoord_1=film, indices=part.triangles, material=material)
            self._parts.append(_PartGL(i, part))
            self._by_primitive[id(prim)] = self._parts[-1]
            nodes.append(self._pr_scene.add(pyrender.Mesh([prim], name=part.name)))
        self._camera = pyrender.PerspectiveCamera(yfov=0.6, znear=0.01, zfar=10.0)
        self._camera_node = self._pr_scene.add(self._camera, pose=np.eye(4))

        self._offscreen = offscreen_renderer(width, height)
        self._offscreen._platform.make_current()
        inner = self._offscreen._renderer
        inner._program_cache = _program_cache()
        original_draw = inner._bind_and_draw_primitive

        def bind_and_draw(primitive, pose, program, flags):  # per-part uniforms and textures, then pyrender's draw
            self._bind_part(self._by_primitive[id(primitive)], program)
            return original_draw(primitive, pose, program, flags)

        inner._bind_and_draw_primitive = bind_and_draw
        inner._configure_forward_pass_viewport = self._configure_viewport
        inner._sorted_mesh_nodes = lambda _scene: nodes
        self._upload_textures()

    def _upload_textures(self):
        cache: dict[tuple, int] = {}
        for pg in self._parts:
            p = pg.part
            if p.base_colour_texture:
                key = (p.base_colour_texture, p.base_colour_srgb)
                if key not in cache:
                    img = read_texture(p.base_colour_texture, srgb=p.base_colour_srgb)
                    rgba = np.ones(img.shape[:2] + (4,), np.float32)
                    rgba[..., :3] = img[..., :3] if img.shape[2] >= 3 else img[..., :1]
                    if img.shape[2] in (2, 4):
                        rgba[..., 3] = img[..., -1]
                    cache[key] = upload_float_texture(rgba[::-1], self.mipmaps)
                pg.base_tex = cache[key]
            if p.mask_texture:
                key = (p.mask_texture, "mask")
                if key not in cache:
                    cache[key] = upload_float_texture(read_texture(p.mask_texture, srgb=False)[::-1, :, :1],
                                                       self.mipmaps)
                pg.mask_tex = cache[key]
        self._textures = list(cache.values())
        self._lut_tex = None
        if self.lut is not None:  # row 0 of the table (thinnest) is t = 0: uploaded as is
            self._lut_tex = upload_float_texture(self.lut.rgb)
            self._textures.append(self._lut_tex)

    def _ensure_fbo(self, width, height, samples=1):
        """Make the framebuffers of this size current (kept for the renderer's life: pictures alternate sizes)."""
        self._fbo_size = key = (width, height, samples)
        if key not in self._fbos:
            fbo, rbs = _framebuffer(width, height, samples)
            resolve = None
            if samples > 1:  # drawn multisampled, resolved (each buffer's mean over the pixel's samples) to read
                resolve, more = _framebuffer(width, height, 1)
                rbs += more
            self._fbos[key] = (fbo, resolve, rbs)
        self._fbo, self._resolve, _ = self._fbos[key]

    def _configure_viewport(self, flags):
        """Replaces pyrender's forward-pass set-up: draw into the float framebuffer."""
        from OpenGL import GL

        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, self._fbo)
        GL.glDrawBuffers(3, [GL.GL_COLOR_ATTACHMENT0 + k if k < self._buffers else GL.GL_NONE for k in range(3)])
        GL.glViewport(0, 0, *self._fbo_size[:2])
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthMask(GL.GL_TRUE)
        GL.glDepthFunc(GL.GL_LESS)
        GL.glDepthRange(0.0, 1.0)
        for cap in (GL.GL_MULTISAMPLE, GL.GL_SAMPLE_ALPHA_TO_COVERAGE, GL.GL_SAMPLE_ALPHA_TO_ONE):
            (GL.glEnable if self._resolve else GL.glDisable)(cap)

    def _bind_part(self, pg: _PartGL, program):
        from OpenGL import GL

        view, p, set_ = self._view, pg.part, program.set_uniform
        set_("u_kind", 1 if (p.is_feather and self._lut_tex is not None) else 0)
        set_("u_two_sided", 1 if (p.is_feather or p.double_sided) else 0)
        set_("u_angle_mode", ANGLE_MODES[self.angle_mode])
        set_("u_part_id", float(pg.index + 1))
        set_("u_eye_m", view.eye_m.astype(np.float32))
        set_("u_light_dir", view.light_direction.astype(np.float32))
        set_("u_light_rgb", view.light_rgb.astype(np.float32))
        set_("u_base_colour", np.asarray(p.base_colour, np.float32))
        set_("u_alpha_threshold", float(p.opacity_threshold))
        set_("u_alpha_to_coverage", 1 if self._resolve else 0)
        set_("u_has_base_tex", 1 if pg.base_tex is not None else 0)
        set_("u_has_mask_tex", 1 if pg.mask_tex is not None else 0)
        for unit, tex, name in ((UNIT_BASE, pg.base_tex, "u_base_tex"), (UNIT_MASK, pg.mask_tex, "u_mask_tex"),
                                (UNIT_LUT, self._lut_tex, "u_lut")):
            GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
            GL.glBindTexture(GL.GL_TEXTURE_2D, tex or 0)
            set_(name, unit)
        if self.lut is not None:
            set_("u_lut_size", np.array([self.lut.n_angle, self.lut.n_thickness], np.float32))
            set_("u_lut_gamma", float(self.lut.angle_warp_gamma))
            set_("u_lut_range_nm", np.asarray(self.lut.thickness_range_nm, np.float32))
        # pyrender binds its own (absent) material textures from unit 0 on; keep its counter past ours
        self._offscreen._renderer._texture_alloc_idx = UNIT_LUT + 1

    def _clip_planes(self, view: View):
        b = self.scene.bounds_m
        centre, radius = b.mean(axis=0), 0.5 * float(np.linalg.norm(b[1] - b[0])) + 1e-6
        d = float(np.dot(centre - view.eye_m, -view.camera_to_world[:3, 2]))
        zfar = max(d + 1.5 * radius, 1e-3)
        return max(d - 1.5 * radius, zfar * 1e-4), zfar

    def render(self, view: View, samples: int = 1) -> RenderResult:
        """Render one view into float buffers and read them back. ``samples`` > 1 (at most ``GL_MAX_SAMPLES``, 4 on
        llvmpipe): multisampled, card cut-outs by alpha-to-coverage, every buffer the mean of the pixel's samples
        (pictures, not the verification: part ids and depths at edges are blends)."""
        t0 = time.perf_counter()
        (rad, aux, inputs), c = self._draw(view, samples, 3), np.ascontiguousarray
        return RenderResult(view, c(rad[..., :3]), c(rad[..., 3]), np.rint(aux[..., 0]).astype(np.int16),
                            c(aux[..., 1]), c(aux[..., 2]), c(aux[..., 3]), c(inputs[..., 0]), c(inputs[..., 1]),
                            c(inputs[..., 2:4]), tuple(p.name for p in self.scene.parts), time.perf_counter() - t0)

    def render_radiance(self, view: View, samples: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`render`'s radiance (H, W, 3) and coverage (H, W) alone (a picture's frame: the other buffers are
        neither resolved nor read back)."""
        rad = self._draw(view, samples, 1)[0]
        return np.ascontiguousarray(rad[..., :3]), np.ascontiguousarray(rad[..., 3])

    def _draw(self, view: View, samples: int, buffers: int) -> list:
        """Draw ``view`` and read back the first ``buffers`` attachments, (H, W, 4) float32 each, row 0 at the top."""
        from OpenGL import GL
        from pyrender.constants import RenderFlags

        if self._deleted:
            raise UsageError("this GLRenderer was deleted; create a new one")
        w, h = view.width, view.height
        self._offscreen._platform.make_current()
        inner = self._offscreen._renderer
        self._offscreen.viewport_width = inner.viewport_width = w
        self._offscreen.viewport_height = inner.viewport_height = h
        self._ensure_fbo(w, h, int(samples))
        self._camera.yfov = view.yfov_rad
        self._camera.aspectRatio = w / h
        self._camera.znear, self._camera.zfar = self._clip_planes(view)
        self._pr_scene.set_pose(self._camera_node, view.camera_to_world)
        self._view, self._buffers = view, buffers  # only those drawn (each costs memory traffic, per sample)
        inner.render(self._pr_scene, RenderFlags.NONE)
        read = self._resolve or self._fbo
        for k in range(buffers) if self._resolve else ():
            GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self._fbo)
            GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, read)
            GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0 + k)
            GL.glDrawBuffer(GL.GL_COLOR_ATTACHMENT0 + k)
            GL.glBlitFramebuffer(0, 0, w, h, 0, 0, w, h, GL.GL_COLOR_BUFFER_BIT, GL.GL_NEAREST)
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, read)
        bufs = []
        for k in range(buffers):
            GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0 + k)
            raw = GL.glReadPixels(0, 0, w, h, GL.GL_RGBA, GL.GL_FLOAT)
            a = np.frombuffer(raw, np.float32) if isinstance(raw, bytes) else np.asarray(raw, np.float32)
            bufs.append(a.reshape(h, w, 4)[::-1])
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, 0)
        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, 0)
        return bufs

    def delete(self):
        """Free the GL resources and the offscreen context."""
        if self._deleted:
            return
        from OpenGL import GL

        try:
            self._offscreen._platform.make_current()
            for fbo, resolve, rbs in self._fbos.values():
                GL.glDeleteFramebuffers(2 if resolve else 1, [fbo, resolve][:2 if resolve else 1])
                GL.glDeleteRenderbuffers(len(rbs), rbs)
            self._fbos.clear()
            if self._textures:
                GL.glDeleteTextures(np.asarray(self._textures, dtype=np.uint32))
        finally:
            self._offscreen.delete()
            self._deleted = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.delete()


def render_views(scene: RenderScene, views, angle_mode: str = "physical", lut=None) -> list[RenderResult]:
    """Render ``views`` of ``scene`` with one :class:`GLRenderer` (created here, deleted at the end), in order."""
    views = list(views)
    if not views:
        raise UsageError("views must contain at least one View, got none")
    with GLRenderer(scene, lut=lut, angle_mode=angle_mode, width=views[0].width, height=views[0].height) as r:
        return [r.render(v) for v in views]

"""Offscreen OpenGL renders of a :class:`~rockdove.render.scene.RenderScene` with rockdove's GLSL shaders.

pyrender (EGL, Mesa llvmpipe, headless) draws the meshes; rockdove supplies

- the shaders ``materials/glsl/thinfilm.vert`` / ``thinfilm.frag`` (the paper's method, docs/design.md
  "Conventions"), through a :class:`pyrender.shader_program.ShaderProgramCache` subclass assigned to
  ``renderer._renderer._program_cache``; every program pyrender asks for is this one;
- per-vertex data in pyrender's buffers: position (location 0), normal, ``texcoord_0`` = USD ``st`` and
  **``texcoord_1`` = (thickness_nm, neckS)** (zeros for parts without a film); pyrender numbers the
  locations of the buffers present (position 0, normal 1, texcoord_0 2, texcoord_1 3 here, no tangents)
  and substitutes them for the ``*_LOC`` names in the shader;
- its own float textures: pyrender's ``Texture`` would quantise to 8 bits, so the LUT is uploaded as
  ``GL_RGB32F`` and the base/mask images (decoded to linear on the CPU) as ``GL_RGBA32F``/``GL_R32F``, linear
  filtering, clamp-to-edge, bound to texture units 0-2 before each draw (pyrender's
  ``_bind_and_draw_primitive`` is wrapped on the renderer instance to set the per-part uniforms);
- its own framebuffer: three ``GL_RGBA32F`` colour attachments (radiance + coverage; part id, view depth,
  cos_theta, thickness; N.L, mask, st) and a 32-bit float depth buffer, read back with ``glReadPixels``
  ``GL_FLOAT``. No multisampling: every pixel is the shading at its centre, which the verifier compares
  with the CPU reference. pyrender's ``_configure_forward_pass_viewport`` is overridden on the instance to
  bind this framebuffer.

One :class:`pyrender.OffscreenRenderer` is created per :class:`GLRenderer` and reused for every view;
:meth:`GLRenderer.delete` (or leaving the ``with`` block) frees it. Display images use the sRGB OETF of the
clipped linear value (:mod:`rockdove.render.images`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import resources
from .scene import RenderScene, ScenePart
from .texture import read_texture
from .views import View

VERTEX_SHADER = "thinfilm.vert"
FRAGMENT_SHADER = "thinfilm.frag"
#: Angle definitions the shader accepts (``u_angle_mode``): the paper's light/view half-angle, and the
#: view-only ``|N . V|`` of the MaterialX baked network (docs/design.md "Conventions").
ANGLE_MODES = {"physical": 0, "materialx_baked": 1}
#: Texture units: base colour, mask, LUT.
UNIT_BASE, UNIT_MASK, UNIT_LUT = 0, 1, 2


@dataclass(eq=False)
class RenderResult:
    """One rendered view; all images are (H, W[, C]) with row 0 at the top.

    Attributes
    ----------
    view : View
    radiance_rgb : ndarray, (H, W, 3) float32
        Linear lin_rec709 radiance (unclipped); 0 on the background.
    alpha : ndarray, (H, W) float32
        Coverage: 1 where a surface was drawn (feather fragments with alpha < 0.5 are discarded), else 0.
    part_id : ndarray, (H, W) int16
        ``index + 1`` into ``part_names``; 0 = background.
    depth_m : ndarray, (H, W) float32
        Distance along the camera's viewing axis, metres; 0 on the background.
    cos_theta : ndarray, (H, W) float32
        The film's angle input of the LUT at the pixel (0 off the feathers).
    thickness_nm : ndarray, (H, W) float32
        Interpolated film thickness (0 off the feathers).
    n_dot_l : ndarray, (H, W) float32
        ``max(dot(N, L), 0)`` with the two-sided normal.
    mask : ndarray, (H, W) float32
        Structural-colour mask (0 off the feathers).
    st : ndarray, (H, W, 2) float32
        Interpolated texture coordinates.
    part_names : tuple of str
    seconds : float
        Wall time of the render and read-back.
    """

    view: View
    radiance_rgb: np.ndarray
    alpha: np.ndarray
    part_id: np.ndarray
    depth_m: np.ndarray
    cos_theta: np.ndarray
    thickness_nm: np.ndarray
    n_dot_l: np.ndarray
    mask: np.ndarray
    st: np.ndarray
    part_names: tuple = ()
    seconds: float = 0.0
    angle_mode: str = "physical"

    def part_mask(self, name: str) -> np.ndarray:
        """Boolean (H, W): pixels of the part with this USD prim name (e.g. ``"NeckFeathers"``)."""
        if name not in self.part_names:
            raise ValueError(f"name={name!r} is not a part; parts are {list(self.part_names)}")
        ids = [i + 1 for i, n in enumerate(self.part_names) if n == name]
        return np.isin(self.part_id, ids)

    def preview8(self) -> np.ndarray:
        """Display image, (H, W, 4) uint8 RGBA: sRGB OETF of the clipped radiance; alpha = coverage."""
        from ..spectral import linear_to_srgb8

        rgb8 = linear_to_srgb8(self.radiance_rgb)
        a = (np.clip(self.alpha, 0, 1) * 255 + 0.5).astype(np.uint8)
        return np.dstack([rgb8, a])


def _shader_program_cache_class():
    """A ShaderProgramCache that answers every request with rockdove's thin-film program (built lazily so
    pyrender/OpenGL are imported only when rendering)."""
    from pyrender.shader_program import ShaderProgramCache

    class ThinFilmProgramCache(ShaderProgramCache):
        """Every program pyrender asks for is ``thinfilm.vert`` + ``thinfilm.frag`` from ``materials/glsl``,
        with pyrender's defines (attribute locations). rockdove renders only the forward pass."""

        def __init__(self):
            super().__init__(shader_dir=str(resources.path("materials/glsl")))

        def get_program(self, vertex_shader, fragment_shader, geometry_shader=None, defines=None):
            defines = dict(defines or {})
            missing = [d for d in ("NORMAL_LOC", "TEXCOORD_0_LOC", "TEXCOORD_1_LOC") if d not in defines]
            if missing:
                raise ValueError(f"primitive lacks the vertex buffers {missing} the thin-film shader needs")
            return super().get_program(VERTEX_SHADER, FRAGMENT_SHADER, None, defines)

    return ThinFilmProgramCache


def _upload_float_texture(image: np.ndarray, internal: str) -> int:
    """Upload a float image, (H, W, C) with row 0 = t = 0 (bottom), as an OpenGL float texture.

    ``internal``: ``"RGB32F"``, ``"RGBA32F"`` or ``"R32F"``. GL_LINEAR, CLAMP_TO_EDGE, no mipmaps.
    """
    from OpenGL import GL

    fmt = {"RGB32F": (GL.GL_RGB32F, GL.GL_RGB, 3), "RGBA32F": (GL.GL_RGBA32F, GL.GL_RGBA, 4),
           "R32F": (GL.GL_R32F, GL.GL_RED, 1)}[internal]
    data = np.ascontiguousarray(image, dtype=np.float32)
    if data.ndim == 2:
        data = data[:, :, None]
    if data.shape[2] != fmt[2]:
        raise ValueError(f"image has {data.shape[2]} channels, {internal} needs {fmt[2]}")
    h, w = data.shape[:2]
    tex = GL.glGenTextures(1)
    GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
    GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 1)
    GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, fmt[0], w, h, 0, fmt[1], GL.GL_FLOAT, data)
    GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 4)
    for p, v in ((GL.GL_TEXTURE_MIN_FILTER, GL.GL_LINEAR), (GL.GL_TEXTURE_MAG_FILTER, GL.GL_LINEAR),
                 (GL.GL_TEXTURE_WRAP_S, GL.GL_CLAMP_TO_EDGE), (GL.GL_TEXTURE_WRAP_T, GL.GL_CLAMP_TO_EDGE)):
        GL.glTexParameteri(GL.GL_TEXTURE_2D, p, v)
    GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
    return int(tex)


@dataclass
class _PartGL:
    index: int
    part: ScenePart
    base_tex: int | None = None
    mask_tex: int | None = None


class GLRenderer:
    """pyrender offscreen renderer of one scene, reused across views.

    Parameters
    ----------
    scene : RenderScene
        The asset read back from USD.
    lut : ThinFilmLUT, optional
        Default: read from ``scene.film.lut_file``.
    angle_mode : str
        ``"physical"`` (``cos_theta = dot(L, H)``, default) or ``"materialx_baked"`` (``|dot(N, V)|``).
    width, height : int
        Initial viewport; each view may set its own size.

    Use as a context manager, or call :meth:`delete` when done (a pyrender scene must not be bound to two
    live renderers).
    """

    def __init__(self, scene: RenderScene, lut=None, angle_mode: str = "physical", width: int = 512, height: int = 512):
        if angle_mode not in ANGLE_MODES:
            raise ValueError(f"angle_mode={angle_mode!r} is not allowed; use one of {sorted(ANGLE_MODES)}")
        if not isinstance(scene, RenderScene):
            raise ValueError(f"scene must be a RenderScene, got {type(scene).__name__}")
        from rockdove._compat import import_pyrender

        pyrender = import_pyrender()
        self.scene = scene
        self.angle_mode = angle_mode
        self.lut = lut if lut is not None else (scene.load_lut() if scene.film is not None else None)
        self.n_renders = 0
        self._fbo = None
        self._fbo_size = None
        self._view = None
        self._deleted = False

        self._pr_scene = pyrender.Scene(bg_color=np.zeros(4), ambient_light=np.zeros(3))
        self._parts: list[_PartGL] = []
        self._by_primitive: dict[int, _PartGL] = {}
        for i, part in enumerate(scene.parts):
            n_v = len(part.positions_m)
            film = np.zeros((n_v, 2), np.float32)
            if part.thickness_nm is not None:
                film[:, 0] = part.thickness_nm
            if part.neck_s is not None:
                film[:, 1] = part.neck_s
            material = pyrender.MetallicRoughnessMaterial(doubleSided=True, name=part.name)
            prim = pyrender.Primitive(
                positions=part.positions_m, normals=part.normals, texcoord_0=part.st, texcoord_1=film,
                indices=part.triangles, material=material,
            )
            pg = _PartGL(i, part)
            self._parts.append(pg)
            self._by_primitive[id(prim)] = pg
            self._pr_scene.add(pyrender.Mesh([prim], name=part.name))
        self._camera = pyrender.PerspectiveCamera(yfov=0.6, znear=0.01, zfar=10.0)
        self._camera_node = self._pr_scene.add(self._camera, pose=np.eye(4))

        self._offscreen = pyrender.OffscreenRenderer(width, height)
        self._offscreen._platform.make_current()
        inner = self._offscreen._renderer
        inner._program_cache = _shader_program_cache_class()()
        # per-primitive uniforms and textures, then pyrender's own draw
        original_draw = inner._bind_and_draw_primitive

        def bind_and_draw(primitive, pose, program, flags):
            self._bind_part(self._by_primitive[id(primitive)], program)
            return original_draw(primitive, pose, program, flags)

        inner._bind_and_draw_primitive = bind_and_draw
        inner._configure_forward_pass_viewport = self._configure_viewport
        self._upload_textures()

    # -- resources ----------------------------------------------------------------------------------------
    def _upload_textures(self):
        cache: dict[tuple, int] = {}
        for pg in self._parts:
            p = pg.part
            if p.base_colour_texture:
                key = (p.base_colour_texture, p.base_colour_srgb)
                if key not in cache:
                    img = read_texture(p.base_colour_texture, srgb=p.base_colour_srgb)
                    rgba = np.ones(img.shape[:2] + (4,), np.float32)
                    c = img.shape[2]
                    if c >= 3:
                        rgba[..., :3] = img[..., :3]
                    else:
                        rgba[..., :3] = img[..., :1]
                    if c in (2, 4):
                        rgba[..., 3] = img[..., -1]
                    cache[key] = _upload_float_texture(rgba[::-1], "RGBA32F")
                pg.base_tex = cache[key]
            if p.mask_texture:
                key = (p.mask_texture, "mask")
                if key not in cache:
                    img = read_texture(p.mask_texture, srgb=False)
                    cache[key] = _upload_float_texture(img[::-1, :, :1], "R32F")
                pg.mask_tex = cache[key]
        self._textures = list(cache.values())
        self._lut_tex = None
        if self.lut is not None:
            # row 0 of the table (thinnest) is t = 0: uploaded as is
            self._lut_tex = _upload_float_texture(self.lut.rgb, "RGB32F")
            self._textures.append(self._lut_tex)

    def _ensure_fbo(self, width, height):
        from OpenGL import GL

        if self._fbo is not None and self._fbo_size == (width, height):
            return
        self._delete_fbo()
        fbo = GL.glGenFramebuffers(1)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fbo)
        colour = GL.glGenRenderbuffers(3)
        for k, rb in enumerate(colour):
            GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, rb)
            GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_RGBA32F, width, height)
            GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0 + k, GL.GL_RENDERBUFFER, rb)
        depth = GL.glGenRenderbuffers(1)
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, depth)
        GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_DEPTH_COMPONENT32F, width, height)
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT, GL.GL_RENDERBUFFER, depth)
        GL.glDrawBuffers(3, [GL.GL_COLOR_ATTACHMENT0 + k for k in range(3)])
        status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
        if status != GL.GL_FRAMEBUFFER_COMPLETE:
            raise RuntimeError(f"float framebuffer incomplete (status {status:#x})")
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        self._fbo, self._rbs, self._fbo_size = int(fbo), [int(c) for c in colour] + [int(depth)], (width, height)

    def _delete_fbo(self):
        from OpenGL import GL

        if self._fbo is not None:
            GL.glDeleteFramebuffers(1, [self._fbo])
            GL.glDeleteRenderbuffers(len(self._rbs), self._rbs)
            self._fbo = None

    def _configure_viewport(self, flags):
        """Replaces pyrender's forward-pass set-up: draw into the float framebuffer."""
        from OpenGL import GL

        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, self._fbo)
        GL.glDrawBuffers(3, [GL.GL_COLOR_ATTACHMENT0 + k for k in range(3)])
        GL.glViewport(0, 0, *self._fbo_size)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthMask(GL.GL_TRUE)
        GL.glDepthFunc(GL.GL_LESS)
        GL.glDepthRange(0.0, 1.0)
        GL.glDisable(GL.GL_MULTISAMPLE)

    def _bind_part(self, pg: _PartGL, program):
        from OpenGL import GL

        view = self._view
        p = pg.part
        set_ = program.set_uniform
        set_("u_kind", 1 if (p.is_feather and self._lut_tex is not None) else 0)
        set_("u_angle_mode", ANGLE_MODES[self.angle_mode])
        set_("u_part_id", float(pg.index + 1))
        set_("u_eye_m", view.eye_m.astype(np.float32))
        set_("u_light_dir", view.light_direction.astype(np.float32))
        set_("u_light_rgb", view.light_rgb.astype(np.float32))
        set_("u_base_colour", np.asarray(p.base_colour, np.float32))
        set_("u_alpha_threshold", float(p.opacity_threshold))
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

    # -- rendering ----------------------------------------------------------------------------------------
    def _clip_planes(self, view: View):
        b = self.scene.bounds_m
        centre, radius = b.mean(axis=0), 0.5 * float(np.linalg.norm(b[1] - b[0])) + 1e-6
        forward = -view.camera_to_world[:3, 2]
        d = float(np.dot(centre - view.eye_m, forward))
        zfar = max(d + 1.5 * radius, 1e-3)
        znear = max(d - 1.5 * radius, zfar * 1e-4)
        return znear, zfar

    def render(self, view: View) -> RenderResult:
        """Render one view into float buffers and read them back."""
        from OpenGL import GL

        if self._deleted:
            raise ValueError("this GLRenderer was deleted; create a new one")
        if not isinstance(view, View):
            raise ValueError(f"view must be a View, got {type(view).__name__}")
        t0 = time.perf_counter()
        w, h = view.width, view.height
        self._offscreen._platform.make_current()
        inner = self._offscreen._renderer
        self._offscreen.viewport_width = inner.viewport_width = w
        self._offscreen.viewport_height = inner.viewport_height = h
        self._ensure_fbo(w, h)
        self._camera.yfov = view.yfov_rad
        self._camera.aspectRatio = w / h
        self._camera.znear, self._camera.zfar = self._clip_planes(view)
        self._pr_scene.set_pose(self._camera_node, view.camera_to_world)
        self._view = view
        from pyrender.constants import RenderFlags

        inner.render(self._pr_scene, RenderFlags.NONE)
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self._fbo)
        bufs = []
        for k in range(3):
            GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0 + k)
            raw = GL.glReadPixels(0, 0, w, h, GL.GL_RGBA, GL.GL_FLOAT)
            a = np.frombuffer(raw, np.float32) if isinstance(raw, bytes) else np.asarray(raw, np.float32)
            bufs.append(a.reshape(h, w, 4)[::-1])
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, 0)
        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, 0)
        self.n_renders += 1
        rad, aux, inputs = bufs
        return RenderResult(
            view=view,
            radiance_rgb=np.ascontiguousarray(rad[..., :3]),
            alpha=np.ascontiguousarray(rad[..., 3]),
            part_id=np.rint(aux[..., 0]).astype(np.int16),
            depth_m=np.ascontiguousarray(aux[..., 1]),
            cos_theta=np.ascontiguousarray(aux[..., 2]),
            thickness_nm=np.ascontiguousarray(aux[..., 3]),
            n_dot_l=np.ascontiguousarray(inputs[..., 0]),
            mask=np.ascontiguousarray(inputs[..., 1]),
            st=np.ascontiguousarray(inputs[..., 2:4]),
            part_names=tuple(p.name for p in self.scene.parts),
            seconds=time.perf_counter() - t0,
            angle_mode=self.angle_mode,
        )

    def delete(self):
        """Free the GL resources and the offscreen context."""
        if self._deleted:
            return
        from OpenGL import GL

        try:
            self._offscreen._platform.make_current()
            self._delete_fbo()
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
    """Render ``views`` of ``scene`` with one offscreen renderer (created here, deleted at the end).

    Parameters
    ----------
    scene : RenderScene
    views : sequence of View
    angle_mode : str
        ``"physical"`` or ``"materialx_baked"``; see :data:`ANGLE_MODES`.
    lut : ThinFilmLUT, optional
        Override the LUT read from the asset.

    Returns
    -------
    list of RenderResult, in the order of ``views``.
    """
    views = list(views)
    if not views:
        raise ValueError("views must contain at least one View, got none")
    with GLRenderer(scene, lut=lut, angle_mode=angle_mode, width=views[0].width, height=views[0].height) as r:
        return [r.render(v) for v in views]

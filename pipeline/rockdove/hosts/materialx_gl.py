"""Drawing of MaterialX's generated GLSL for :mod:`rockdove.hosts.materialx` in pyrender's EGL context, as a viewer
does around a MaterialX shader, into a float framebuffer read back as linear Rec.709."""

from __future__ import annotations

import numpy as np

from ..render.gl import offscreen_renderer, upload_float_texture
from .base import ENVIRONMENT_RADIANCE, HostError

#: Image nodes whose texture gets a mip chain and trilinear filtering, as every host does: the LUT (its angle axis
#: is minified where cos theta changes fast on screen, which the verification must see). The card atlas (base
#: colour + cut-out, mask) is sampled at the pixel centre as the reference samples it: mipmapped, its blended
#: cut-out edges count as colour error (measured, default asset, 512 px, 3 views: p95 dE2000 8.3 against 0.075).
MIPMAPPED_IMAGES = ("LutTexture",)


def _compile(vert: str, frag: str, name: str) -> int:
    from OpenGL import GL

    def check(ok, log: bytes, what: str):
        if not ok:
            lines = log.decode(errors="replace").strip().splitlines()
            raise HostError(name, f"generated shader does not {what}: {lines[0] if lines else '?'}")

    prog = GL.glCreateProgram()
    for kind, src in ((GL.GL_VERTEX_SHADER, vert), (GL.GL_FRAGMENT_SHADER, frag)):
        sh = GL.glCreateShader(kind)
        GL.glShaderSource(sh, src)
        GL.glCompileShader(sh)
        check(GL.glGetShaderiv(sh, GL.GL_COMPILE_STATUS), GL.glGetShaderInfoLog(sh), "compile")
        GL.glAttachShader(prog, sh)
    GL.glLinkProgram(prog)
    check(GL.glGetProgramiv(prog, GL.GL_LINK_STATUS), GL.glGetProgramInfoLog(prog), "link")
    return prog


_OCCLUDER_VERT = """#version 400
uniform mat4 u_viewProjectionMatrix;
in vec3 i_position;
in vec2 i_texcoord_0;
out vec2 st;
void main() { st = i_texcoord_0; gl_Position = u_viewProjectionMatrix * vec4(i_position, 1.0); }
"""
# black, cut out where the base texture's alpha (unit 0; white where a part has none) is below the part's threshold,
# as the reference's ray casts skip those fragments (the plumage cards)
_OCCLUDER_FRAG = """#version 400
uniform sampler2D u_alpha;
uniform float u_threshold;
in vec2 st;
out vec4 out1;
void main() { if (texture(u_alpha, st).a < u_threshold) discard; out1 = vec4(0.0, 0.0, 0.0, 1.0); }
"""


def read_image_file(path: str) -> np.ndarray:
    """Pixels as a host loads them, top row first: uint8, or EXR float32 (the pip MaterialX has no EXR loader)."""
    if path.lower().endswith(".exr"):
        from ..lut.exr import read_exr

        return np.ascontiguousarray(read_exr(path).rgb[::-1])  # ThinFilmLUT row 0 is the bottom row
    from PIL import Image

    with Image.open(path) as im:
        if im.mode not in ("L", "LA", "RGB", "RGBA"):
            im = im.convert("RGBA")
        return np.asarray(im, dtype=np.uint8)


def _projection(view, near: float, far: float) -> np.ndarray:
    f = 1.0 / np.tan(0.5 * view.yfov_rad)
    return np.array([[f / view.aspect, 0, 0, 0], [0, f, 0, 0],
                     [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)], [0, 0, -1, 0]])


def draw(scene, networks: dict, sources: dict, views, *, name: str) -> dict:
    """View name -> float radiance, each part with a network drawn by its generated ``sources``, the others black."""
    from .._compat import import_pyrender

    import_pyrender()  # sets PYOPENGL_PLATFORM before OpenGL is imported
    from OpenGL import GL

    sizes: dict = {}  # one offscreen context per image size (the hero view is larger than the others)
    for v in views:
        sizes.setdefault((v.width, v.height), []).append(v)
    out = {}
    for (w, h), group in sizes.items():
        offscreen = offscreen_renderer(w, h)
        try:
            offscreen._platform.make_current()
            out.update(_draw_in_context(GL, scene, networks, sources, group, name, w, h))
        finally:
            offscreen.delete()
    return {v.name: out[v.name] for v in views}


def _draw_in_context(GL, scene, networks, sources, views, name, w, h) -> dict:
    env = upload_float_texture(np.full((2, 2, 3), ENVIRONMENT_RADIANCE, np.float32), mipmaps=False)
    black = upload_float_texture(np.zeros((1, 1, 4), np.float32), mipmaps=False)
    fbo = GL.glGenFramebuffers(1)
    GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fbo)
    for storage, attachment in ((GL.GL_RGBA32F, GL.GL_COLOR_ATTACHMENT0),
                                (GL.GL_DEPTH_COMPONENT32F, GL.GL_DEPTH_ATTACHMENT)):
        buffer = GL.glGenRenderbuffers(1)
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, buffer)
        GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, storage, w, h)
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, attachment, GL.GL_RENDERBUFFER, buffer)
    if GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER) != GL.GL_FRAMEBUFFER_COMPLETE:
        raise HostError(name, "float framebuffer incomplete")

    white = upload_float_texture(np.ones((1, 1, 4), np.float32), mipmaps=False)
    draws = []  # (program, vao, n_indices, textures {unit: tex}, is_material)
    for part in scene.parts:
        if (net := networks.get(part.path)) is None:
            image = read_image_file(part.base_colour_texture) if part.base_colour_texture else None
            cut = image is not None and image.ndim == 3 and image.shape[2] in (2, 4)
            prog = _compile(_OCCLUDER_VERT, _OCCLUDER_FRAG, name)
            textures = {0: upload_float_texture(image[::-1], mipmaps=False) if cut else white}
            GL.glUseProgram(prog)
            GL.glUniform1i(GL.glGetUniformLocation(prog, "u_alpha"), 0)
            GL.glUniform1f(GL.glGetUniformLocation(prog, "u_threshold"), float(part.opacity_threshold))
        else:
            prog = _compile(*sources[part.path], name)
            textures = _bind_samplers(GL, prog, net, env, black)
        draws.append((prog, _vertex_array(GL, prog, part), int(np.asarray(part.triangles).size), textures))

    lo, hi = scene.bounds_m
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    out = {}
    for view in views:
        c2w = np.asarray(view.camera_to_world, np.float64)
        eye = c2w[:3, 3]
        dist = float(np.linalg.norm(eye - centre))
        near, far = max(1e-4, (dist - radius) * 0.5), dist + 2.0 * radius
        vp = (_projection(view, near, far) @ np.linalg.inv(c2w)).astype(np.float32)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fbo)
        GL.glViewport(0, 0, w, h)
        GL.glClearColor(0.0, 0.0, 0.0, 0.0)
        GL.glClear(GL.GL_COLOR_BUFFER_BIT | GL.GL_DEPTH_BUFFER_BIT)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDisable(GL.GL_CULL_FACE)
        GL.glDisable(GL.GL_BLEND)
        for prog, vao, n, textures in draws:
            GL.glUseProgram(prog)
            for uniform, m in (("u_viewProjectionMatrix", vp), ("u_worldMatrix", np.eye(4)),
                               ("u_worldInverseTransposeMatrix", np.eye(4))):
                _uniform(GL, prog, uniform, GL.glUniformMatrix4fv, 1, GL.GL_TRUE, np.ascontiguousarray(m, np.float32))
            _uniform(GL, prog, "u_viewPosition", GL.glUniform3f, *eye.astype(np.float32))
            for unit, tex in textures.items():
                GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
                GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
            GL.glBindVertexArray(vao)
            GL.glDrawElements(GL.GL_TRIANGLES, n, GL.GL_UNSIGNED_INT, None)
        GL.glFinish()
        rgba = np.frombuffer(GL.glReadPixels(0, 0, w, h, GL.GL_RGBA, GL.GL_FLOAT), np.float32).reshape(h, w, 4)[::-1]
        out[view.name] = np.ascontiguousarray(rgba[:, :, :3])
    err = GL.glGetError()
    if err != GL.GL_NO_ERROR:
        raise HostError(name, f"OpenGL error {int(err):#x}")
    return out


def _uniform(GL, prog, uniform: str, setter, *values) -> None:
    """Set ``uniform`` where the program has it (the generator leaves out the ones it does not read)."""
    loc = GL.glGetUniformLocation(prog, uniform)
    if loc >= 0:
        setter(loc, *values)


def _bind_samplers(GL, prog, net, env: int, black: int) -> dict:
    """Texture unit -> texture for every sampler of ``net`` (:class:`.materialx.Network`); the base colour's RGB 0
    (the film lobe alone)."""
    GL.glUseProgram(prog)
    textures, unit = {}, 0
    for i in range(GL.glGetProgramiv(prog, GL.GL_ACTIVE_UNIFORMS)):
        uname, _, utype = GL.glGetActiveUniform(prog, i)
        uname = uname.decode() if isinstance(uname, bytes) else str(uname)
        if utype == GL.GL_FLOAT_MAT3:
            _document_matrix(GL, prog, uname, net.doc)
        if utype != GL.GL_SAMPLER_2D:
            continue
        if uname in ("u_envRadiance", "u_envIrradiance"):
            tex = env
        elif uname.endswith("_file") and uname[: -len("_file")] in net.files:
            node = uname[: -len("_file")]
            pixels = read_image_file(net.files[node])
            if node == "BaseColorTexture" and pixels.ndim == 3 and pixels.shape[2] == 4:
                pixels = pixels.copy()
                pixels[:, :, :3] = 0
            tex = upload_float_texture(pixels, mipmaps=node in MIPMAPPED_IMAGES)
        else:
            tex = black
        textures[unit] = tex
        GL.glUniform1i(GL.glGetUniformLocation(prog, uname), unit)
        unit += 1
    _uniform(GL, prog, "u_envRadianceMips", GL.glUniform1i, 1)
    _uniform(GL, prog, "u_numActiveLightSources", GL.glUniform1i, 0)
    _uniform(GL, prog, "u_envLightIntensity", GL.glUniform1f, 1.0)
    return textures


def _document_matrix(GL, prog, uname: str, doc) -> None:
    """Bind uniform ``<node>_<input>`` to the document's matrix33 at float precision, as MaterialX's viewer binds
    its uniforms: the generated default is printed with 6 decimals (the LUT transform's 0.005757 for 0.0057566)."""
    node_name, _, input_name = uname.rpartition("_")
    node = doc.getNode(node_name)
    inp = node.getInput(input_name) if node is not None else None
    if inp is not None:
        source = inp.getConnectedNode()
        text = (source.getInput("value") if source is not None and source.getCategory() == "constant" else inp)
        values = np.array([float(v) for v in text.getValueString().split(",")], np.float32)
        GL.glUniformMatrix3fv(GL.glGetUniformLocation(prog, uname), 1, GL.GL_FALSE, values)


def _vertex_array(GL, prog, part) -> int:
    """A VAO of the part's streams under the generated shader's attribute names."""
    pos = np.asarray(part.positions_m, np.float32)
    nrm = np.asarray(part.normals, np.float32)
    helper = np.where(np.abs(nrm[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    tangent = np.cross(nrm, helper)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
    streams = {"i_position": pos, "i_normal": nrm, "i_tangent": tangent.astype(np.float32),
               "i_geomprop_st": np.asarray(part.st, np.float32), "i_texcoord_0": np.asarray(part.st, np.float32)}
    if part.thickness_nm is not None:
        streams["i_geomprop_thickness"] = np.asarray(part.thickness_nm, np.float32)[:, None]
    vao = GL.glGenVertexArrays(1)
    GL.glBindVertexArray(vao)
    for attr, data in streams.items():
        loc = GL.glGetAttribLocation(prog, attr)
        if loc < 0:
            continue
        data = np.ascontiguousarray(data, np.float32)
        vbo = GL.glGenBuffers(1)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, vbo)
        GL.glBufferData(GL.GL_ARRAY_BUFFER, data.nbytes, data, GL.GL_STATIC_DRAW)
        GL.glEnableVertexAttribArray(loc)
        GL.glVertexAttribPointer(loc, data.shape[1] if data.ndim == 2 else 1, GL.GL_FLOAT, GL.GL_FALSE, 0, None)
    ibo = GL.glGenBuffers(1)
    idx = np.ascontiguousarray(np.asarray(part.triangles, np.uint32).reshape(-1))
    GL.glBindBuffer(GL.GL_ELEMENT_ARRAY_BUFFER, ibo)
    GL.glBufferData(GL.GL_ELEMENT_ARRAY_BUFFER, idx.nbytes, idx, GL.GL_STATIC_DRAW)
    GL.glBindVertexArray(0)
    return int(vao)

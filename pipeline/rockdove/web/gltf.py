"""Export a written rockdove USD asset to one glTF 2.0 binary file (``pigeon.glb``) with ``KHR_materials_iridescence``.

It reads the asset *as written* (:func:`rockdove.render.scene.load_scene`), as ``pigeon.usdz`` does (docs/design.md
"glTF and the web"). The thickness ramp is linear, so linear filtering returns the primvar itself, unquantised. The
default material is the preview atlas (Blender 5.0 ignores the extension); the film is the variant ``thin_film``
(measured: a base colour under it would count twice in three.js, whose diffuse is only scaled by ``1 - F``).
pygltflib builds the document (trimesh's cannot author the extension or a second UV set)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .. import resources
from ..errors import UsageError
from ..geometry.types import point_bounds
from ..png import encode_png
from ..render.scene import load_scene
from .gltf_skin import add_skin

#: The file the build writes beside ``pigeon.usda``.
GLB_NAME = "pigeon.glb"
#: Wavelength at which the film's dispersive (Cauchy) index is given to glTF's single ``iridescenceIor``, nm.
#: The same as :data:`rockdove.usd.stage.FILM_IOR_WAVELENGTH_NM` (the USD physical variant's ``thin_film_ior``).
IOR_WAVELENGTH_NM = 550.0
#: Texels of the thickness ramp texture (a power of two, so every glTF viewer samples it without resizing).
THICKNESS_RAMP_TEXELS = 256
EXTENSIONS = ("KHR_materials_iridescence", "KHR_materials_ior", "KHR_materials_variants")
#: ``KHR_materials_variants`` of the feathers: the film (``KHR_materials_iridescence``) and the preview atlas.
FILM_VARIANT, PREVIEW_VARIANT = "thin_film", "preview"

_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_FLOAT, _UNSIGNED_BYTE, _UNSIGNED_SHORT, _UNSIGNED_INT = 5126, 5121, 5123, 5125
_LINEAR, _LINEAR_MIPMAP_LINEAR, _CLAMP_TO_EDGE = 9729, 9987, 33071


def thickness_texcoords(thickness_nm, lo_nm: float, hi_nm: float, texels: int = THICKNESS_RAMP_TEXELS) -> np.ndarray:
    """(V, 2) float32 ``TEXCOORD_1`` of each vertex's thickness (nm) on the ramp: texel centres, ``v = 0.5``."""
    d = np.asarray(thickness_nm, dtype=np.float64)
    g = np.clip((d - lo_nm) / (hi_nm - lo_nm), 0.0, 1.0) if hi_nm > lo_nm else np.zeros_like(d)
    return np.stack([(0.5 + g * (texels - 1)) / texels, np.full_like(g, 0.5)], axis=1).astype(np.float32)


def thickness_ramp_png(texels: int = THICKNESS_RAMP_TEXELS) -> bytes:
    """The ramp image (``texels`` x 1, grey, ``G_i = i / (N - 1)`` in 8 bits), PNG bytes."""
    ramp = np.round(np.linspace(0.0, 255.0, texels)).astype(np.uint8)[None, :]
    return encode_png(np.repeat(ramp[..., None], 3, axis=2), level=6)


def film_ior(film) -> float:
    """The film's real index at :data:`IOR_WAVELENGTH_NM` (``KHR_materials_iridescence`` has no extinction)."""
    return float(np.real(film.model.n_film(IOR_WAVELENGTH_NM)))


class _Blob:
    """The GLB's binary chunk (buffer views appended with 4-byte alignment), its textures and materials."""

    def __init__(self, gltf):
        self.gltf, self.data, self.textures = gltf, bytearray(), {}

    def view(self, payload: bytes, target: int | None = None) -> int:
        from pygltflib import BufferView

        self.data.extend(b"\0" * (-len(self.data) % 4))
        self.gltf.bufferViews.append(BufferView(buffer=0, byteOffset=len(self.data), byteLength=len(payload),
                                                target=target))
        self.data.extend(payload)
        return len(self.gltf.bufferViews) - 1

    def accessor(self, array: np.ndarray, kind: str, target: int = _ARRAY_BUFFER, with_bounds: bool = False) -> int:
        from pygltflib import Accessor

        array = np.ascontiguousarray(array)
        component = {"float32": _FLOAT, "uint8": _UNSIGNED_BYTE, "uint16": _UNSIGNED_SHORT,
                     "uint32": _UNSIGNED_INT}[array.dtype.name]
        acc = Accessor(bufferView=self.view(array.tobytes(), target), componentType=component,
                       count=int(array.shape[0]), type=kind)
        if with_bounds:
            lo, hi = point_bounds(array)
            acc.min, acc.max = [float(v) for v in lo], [float(v) for v in hi]
        self.gltf.accessors.append(acc)
        return len(self.gltf.accessors) - 1

    def texture(self, source, name: str | None = None, sampler: int = 0) -> int:
        """The texture of a PNG file (named by its file name) or of PNG bytes, added on first use."""
        from pygltflib import Image, Texture

        name = name or os.path.basename(source)
        if name not in self.textures:
            png = source if isinstance(source, bytes) else Path(source).read_bytes()
            self.gltf.images.append(Image(name=name, bufferView=self.view(png), mimeType="image/png"))
            self.gltf.textures.append(Texture(source=len(self.gltf.images) - 1, sampler=sampler, name=name))
            self.textures[name] = len(self.gltf.textures) - 1
        return self.textures[name]

    def material(self, material) -> int:
        self.gltf.materials.append(material)
        return len(self.gltf.materials) - 1


def _png_has_alpha(path) -> bool:
    """Whether a file is a PNG with an alpha channel (IHDR colour type 4 or 6; not decoded: anything else, no)."""
    with open(path, "rb") as fh:
        head = fh.read(26)
    return head[:8] == b"\x89PNG\r\n\x1a\n" and len(head) == 26 and head[25] in (4, 6)


def _tangents(part) -> np.ndarray:
    """(V, 4) float32 glTF tangents: per vertex the area-weighted direction of increasing s, orthogonal to the
    normal; w the handedness (+1 when t increases along normal x tangent)."""
    p, n, st = (np.asarray(a, np.float64) for a in (part.positions_m, _unit(part.normals), part.st))
    tri = np.asarray(part.triangles)
    e1, e2 = p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]
    d1, d2 = st[tri[:, 1]] - st[tri[:, 0]], st[tri[:, 2]] - st[tri[:, 0]]
    sign = np.sign(d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1])[:, None]  # area-weighted: no division by the det
    t_face, b_face = sign * (e1 * d2[:, 1:] - e2 * d1[:, 1:]), sign * (e2 * d1[:, :1] - e1 * d2[:, :1])
    t, b = np.zeros_like(p), np.zeros_like(p)
    for k in range(3):
        np.add.at(t, tri[:, k], t_face)
        np.add.at(b, tri[:, k], b_face)
    t = _unit(t - np.einsum("ij,ij->i", t, n)[:, None] * n)
    w = np.where(np.einsum("ij,ij->i", np.cross(n, t), b) < 0, -1.0, 1.0)
    return np.concatenate([t, w[:, None]], axis=1).astype(np.float32)


def _unit(normals: np.ndarray) -> np.ndarray:
    n = np.asarray(normals, dtype=np.float64)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(length > 1e-12, n / np.maximum(length, 1e-30), np.array([0.0, 1.0, 0.0]))
    return n.astype(np.float32)


def _uv(st) -> np.ndarray:
    """USD ``st`` as glTF texture coordinates (image origin top-left)."""
    return np.stack([st[:, 0], 1.0 - st[:, 1]], axis=1).astype(np.float32)


def preview_material_texture(stage, prim_path: str) -> tuple[str | None, float]:
    """The bound UsdPreviewSurface's resolved ``diffuseColor`` file and ``roughness``; (None, 1) without one."""
    from pxr import UsdShade

    material = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath(prim_path)).ComputeBoundMaterial()[0]
    surface = material.ComputeSurfaceSource()[0] if material else None
    if not surface:
        return None, 1.0
    rough = surface.GetInput("roughness")
    roughness = float(rough.Get()) if rough and rough.Get() is not None else 0.5
    colour = surface.GetInput("diffuseColor")
    sources = colour.GetConnectedSources()[0] if colour else []
    if not sources:
        return None, roughness
    file = UsdShade.Shader(sources[0].source.GetPrim()).GetInput("file")
    value = file.Get() if file else None
    return (value.resolvedPath or None) if value is not None else None, roughness


def scene_to_glb(scene, version: str = "") -> bytes:
    """The GLB bytes of a RenderScene; ValueError when it records no film or a feather has no thickness."""
    import pygltflib as gl
    from pxr import Usd

    if (film := scene.film) is None:
        raise UsageError(f"asset {scene.root_layer!r} has no rockdove thin-film data: no mesh applies "
                         "RockDoveThinFilmAPI (rockdove:film:*), so there is no film to export as "
                         "KHR_materials_iridescence; build it with `rockdove build`")
    gltf = gl.GLTF2(asset=gl.Asset(version="2.0", generator=f"rockdove {version}".strip()))
    blob = _Blob(gltf)
    # sampler 1, the ramp's, is not mipmapped: averaging neighbouring texels of a ramp along u is fine, but mip
    # levels of a 1-texel-high ramp would blur it along u at a distance
    gltf.samplers = [gl.Sampler(magFilter=_LINEAR, minFilter=minify, wrapS=_CLAMP_TO_EDGE, wrapT=_CLAMP_TO_EDGE)
                     for minify in (_LINEAR_MIPMAP_LINEAR, _LINEAR)]
    lo, hi = scene.thickness_range_nm  # a LUT-less film: the feathers' thicknesses, whole nm
    stage = Usd.Stage.Open(scene.root_layer)
    for part in scene.parts:
        positions = blob.accessor(part.positions_m.astype(np.float32), "VEC3", with_bounds=True)
        attributes = gl.Attributes(POSITION=positions, NORMAL=blob.accessor(_unit(part.normals), "VEC3"))
        if part.base_colour_texture or part.mask_texture:  # untextured parts carry no UVs (nothing reads them)
            attributes.TEXCOORD_0 = blob.accessor(_uv(part.st), "VEC2")
        pbr = gl.PbrMetallicRoughness(metallicFactor=0.0, roughnessFactor=1.0)
        if part.base_colour_texture:
            pbr.baseColorTexture = gl.TextureInfo(index=blob.texture(part.base_colour_texture))
        else:
            pbr.baseColorFactor = [float(c) for c in part.base_colour] + [1.0]
        material = gl.Material(name=f"{part.name}Material", pbrMetallicRoughness=pbr, doubleSided=part.double_sided)
        if part.base_colour_texture and _png_has_alpha(part.base_colour_texture):  # cut out as the USD's threshold
            material.alphaMode, material.alphaCutoff = "MASK", float(part.opacity_threshold)
        if part.normal_texture:  # tangent space, as the USD's: OpenGL convention (+Y along t), as glTF's
            material.normalTexture = gl.NormalMaterialTexture(index=blob.texture(part.normal_texture))
            attributes.TANGENT = blob.accessor(_tangents(part), "VEC4")
        variants = {}
        if part.is_feather:
            if part.thickness_nm is None:
                raise UsageError(f"asset {scene.root_layer!r}: {part.path} records a film but no thickness primvar")
            attributes.TEXCOORD_1 = blob.accessor(thickness_texcoords(part.thickness_nm, lo, hi), "VEC2")
            pbr.roughnessFactor = 0.0
            material.alphaMode, material.alphaCutoff, material.doubleSided = "MASK", float(part.opacity_threshold), True
            iridescence = {"iridescenceFactor": 1.0, "iridescenceIor": film_ior(film),
                           "iridescenceThicknessMinimum": lo, "iridescenceThicknessMaximum": hi,
                           "iridescenceThicknessTexture": {"index": blob.texture(thickness_ramp_png(),
                                                                                 "thickness_ramp.png", sampler=1),
                                                           "texCoord": 1}}
            if part.mask_texture:
                iridescence["iridescenceTexture"] = {"index": blob.texture(part.mask_texture)}
            material.extensions = {"KHR_materials_iridescence": iridescence,
                                   "KHR_materials_ior": {"ior": float(film.model.n_substrate)}}
            material.extras = {"rockdove": {
                "filmModel": film.model.name, "cauchyA": film.model.cauchy_a, "cauchyB_nm2": film.model.cauchy_b_nm2,
                "incidentIndex": film.model.n_incident, "substrateIndex": film.model.n_substrate,
                "iridescenceIorWavelengthNm": IOR_WAVELENGTH_NM, "thicknessRangeNm": [lo, hi],
                "thicknessRampTexels": THICKNESS_RAMP_TEXELS}}
            preview, roughness = preview_material_texture(stage, part.path)
            if preview is not None and part.preview_st is not None:
                # the default material, what a consumer without KHR_materials_iridescence (or that ignores the
                # variants) shows: the USD preview's atlas, each card the colour of its own thickness
                film_index = blob.material(material)
                attributes.TEXCOORD_2 = blob.accessor(_uv(part.preview_st), "VEC2")
                atlas = gl.TextureInfo(index=blob.texture(preview), texCoord=2)
                pbr = gl.PbrMetallicRoughness(metallicFactor=0.0, baseColorTexture=atlas, roughnessFactor=roughness)
                material = gl.Material(name=f"{part.name}Preview", alphaMode="MASK", doubleSided=True,
                                       alphaCutoff=float(part.opacity_threshold), pbrMetallicRoughness=pbr)
                variants = {"KHR_materials_variants": {"mappings": [{"material": film_index, "variants": [0]},
                                                                    {"material": film_index + 1, "variants": [1]}]}}
                gltf.extensions = {"KHR_materials_variants": {"variants": [{"name": FILM_VARIANT},
                                                                           {"name": PREVIEW_VARIANT}]}}
        tris = np.asarray(part.triangles).reshape(-1)
        index_dtype = np.uint16 if len(part.positions_m) <= 65535 else np.uint32
        primitive = gl.Primitive(attributes=attributes, material=blob.material(material), extensions=variants,
                              indices=blob.accessor(tris.astype(index_dtype), "SCALAR", _ELEMENT_ARRAY_BUFFER))
        gltf.meshes.append(gl.Mesh(name=part.name, primitives=[primitive]))
        gltf.nodes.append(gl.Node(name=part.name, mesh=len(gltf.meshes) - 1))
    gltf.extensionsUsed = [e for e in EXTENSIONS if e != "KHR_materials_variants" or gltf.extensions]
    meshes = len(gltf.nodes)
    add_skin(gltf, blob, scene, stage)
    if gltf.skins:  # skinned mesh nodes are root nodes (glTF ignores their parents' transforms), beside the joints
        roots = list(range(meshes)) + [len(gltf.nodes) - 1]
    else:
        gltf.nodes.append(gl.Node(name="Pigeon", children=list(range(meshes))))
        roots = [len(gltf.nodes) - 1]
    gltf.scenes = [gl.Scene(name="Pigeon", nodes=roots)]
    gltf.scene = 0
    blob.data.extend(b"\0" * (-len(blob.data) % 4))
    gltf.buffers = [gl.Buffer(byteLength=len(blob.data))]
    gltf.set_binary_blob(bytes(blob.data))
    return b"".join(gltf.save_to_bytes())


class GlbExport(NamedTuple):
    """A GLB written: its path and size, and its film (the index at ``ior_wavelength_nm``, the substrate's)."""

    path: str
    bytes: int
    iridescence_ior: float
    ior_wavelength_nm: float
    thickness_range_nm: list[float]
    substrate_ior: float


def export_glb(asset, out_path, *, version: str = "") -> GlbExport:
    """Write a written asset as the GLB ``out_path`` (atomically). ValueError: no thin-film data."""
    scene = load_scene(asset)  # the verifier's reader; a physical-only asset (no LUT) reads too
    if scene.time is not None:  # a layer that plays a motion (pigeon_walk.usda): the skin binds the rest pose
        scene = load_scene(asset, {"motion": "rest"})
    data = scene_to_glb(scene, version=version)
    out_path = os.fspath(out_path)
    resources.write_atomic(out_path, data)
    return GlbExport(out_path, len(data), film_ior(scene.film), IOR_WAVELENGTH_NM, list(scene.thickness_range_nm),
                     scene.film.model.n_substrate)


#: Seconds the glTF-Validator may take (node start-up plus validation; a 2 MB GLB takes about 1 s).
VALIDATOR_TIMEOUT_S = 120


class GlbValidation(NamedTuple):
    """The Khronos glTF-Validator's findings: issues by severity, its own messages, extensions used, most UV sets."""

    errors: int
    warnings: int
    infos: int
    hints: int
    messages: list[dict]
    extensions_used: list[str]
    max_uvs: int


def validate_glb(path) -> GlbValidation:
    """The Khronos glTF-Validator's report on ``path``; RuntimeError (saying how to install) when it cannot run."""
    if (node := shutil.which("node")) is None:
        raise RuntimeError("glTF validation needs Node.js (`node`), which is not on PATH; apt-get install nodejs")
    script = resources.path("materials/web/gltf_validate.mjs")
    if not (script.parent / "node_modules" / "gltf-validator").is_dir():
        raise RuntimeError(f"the npm package gltf-validator is not installed in {script.parent}; run "
                           f"`npm ci --prefix {script.parent}` (make test does)")
    try:
        res = subprocess.run([node, str(script), os.path.abspath(os.fspath(path))], capture_output=True,
                             text=True, timeout=VALIDATOR_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        raise RuntimeError(f"glTF-Validator did not finish within {VALIDATOR_TIMEOUT_S} s on {path}") from None
    if res.returncode != 0:
        raise RuntimeError(f"glTF-Validator failed on {path}: {res.stderr.strip().splitlines()[-1:]}")
    report = json.loads(res.stdout)
    issues, info = report["issues"], report.get("info", {})
    return GlbValidation(issues["numErrors"], issues["numWarnings"], issues["numInfos"], issues["numHints"],
                         issues["messages"], info.get("extensionsUsed", []), info.get("maxUVs", 0))

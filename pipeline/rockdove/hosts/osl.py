"""The ``osl`` and ``osl_physical`` hosts: the asset's MaterialX networks as OSL by MaterialX's generator, compiled by
Blender's bundled OSL and rendered by Cycles with OSL on (the MaterialX path of Arnold, RenderMan, Karma CPU)."""

from __future__ import annotations

import importlib.util
import os
import shutil

from ..errors import UsageError
from ..usd.layout import resolve_root_layer
from . import bpy_runner
from .base import ENVIRONMENT_RADIANCE, HostError
from .blender import cycles_job
from .jobs import OslJob, OslShader
from .materialx import BASE_COLOUR, Network, VariantHost, feather_networks, generate

LOBE = "view_angle"
#: Cycles samples per pixel (the shading is deterministic; samples only resolve cut-out edges).
SAMPLES = 8
#: Seconds before a Cycles OSL run is given up.
TIMEOUT_S = 900
#: Cycles' working space and the EXR's. Cycles clamps a BSDF's negative weights to 0 (``kernel/closure/alloc.h``):
#: in Linear Rec.709, 11 % of the LUT's texels have a negative channel; every LUT colour lies inside ACEScg
#: (smallest channel 0.026), and Blender writes the render back in linear Rec.709, negatives kept.
WORKING_SPACE, EXR_SPACE = "ACEScg", "Linear Rec.709"


class OSLHost(VariantHost):
    """The asset's MaterialX network as MaterialX's generated OSL in Cycles (module docstring)."""

    def unavailable(self) -> str | None:
        try:
            import MaterialX.PyMaterialXGenOsl  # noqa: F401
        except ImportError as exc:
            return f"MaterialX is not installed ({exc}); pip install MaterialX"
        return bpy_runner.unavailable()

    def render(self, asset_path: str, views, out_dir: str) -> dict:
        """:meth:`Host.render` of the host's network as OSL in Cycles; HostError with the compiler's error line."""
        name, views = self.name, list(views)
        bpy_runner.bpy_python(name)
        try:
            networks = feather_networks(layer := resolve_root_layer(asset_path), self.variant)
        except (ValueError, RuntimeError, OSError) as exc:
            raise HostError(name, f"cannot read the asset's MaterialX network: {exc}") from None
        work = bpy_runner.work_folder(name, views, out_dir)
        for header in osl_headers():
            shutil.copyfile(header, os.path.join(work, os.path.basename(header)))
        shaders = {}
        try:
            for mesh, net in networks.items():
                doc, files = lobe_document(net, BASE_COLOUR[self.variant])
                code = generate_osl(doc, net.material)
                if not all(f'string {param} = ""' in code for param in files):
                    raise UsageError(f"MaterialX named the image parameters otherwise than {sorted(files)}")
                source = os.path.join(work, f"{net.material}.osl")
                with open(source, "w", encoding="utf-8") as fh:
                    fh.write(for_cycles(code))
                shaders[mesh] = OslShader(source, geomprops(net.doc), files)
        except ValueError as exc:
            raise HostError(name, f"cannot turn the asset's MaterialX network into OSL: {exc}") from None
        except Exception as exc:  # MaterialX raises its own exception types (ExceptionShaderGenError...)
            raise HostError(name, f"MaterialX OSL generation failed: {type(exc).__name__}: {exc}") from None
        job = cycles_job(OslJob, os.path.abspath(layer), bpy_runner.job_views(views), work, SAMPLES, addon=False,
                         shaders=shaders, environment_radiance=ENVIRONMENT_RADIANCE, working_space=WORKING_SPACE,
                         exr_colorspace=EXR_SPACE)
        try:
            bpy_runner.run_job(job, work, importlib.util.find_spec("rockdove.hosts.osl_job").origin, TIMEOUT_S,
                               host=name, renderer="Cycles (OSL)")
        except HostError as exc:
            raise HostError(name, _compiler_error(work) or exc.message) from None
        return bpy_runner.read_views(name, "Cycles (OSL)", views, work)


def generate_osl(doc, material_name: str) -> str:
    """OSL source of ``material_name`` (a ``surfacematerial`` of ``doc``) by MaterialX's ``OslShaderGenerator``."""
    import MaterialX.PyMaterialXGenOsl as mx_osl
    import MaterialX.PyMaterialXGenShader as mx_gen

    # fileTextureVerticalFlip (set by generate): OSL's texture() puts t = 0 at the first row, MaterialX at the bottom
    return generate(doc, material_name, mx_osl.OslShaderGenerator.create()).getSourceCode(mx_gen.PIXEL_STAGE)


#: Put after the generated source's ``#include "mx_funcs.h"``, for Cycles (the generated functions are left as
#: MaterialX wrote them). First, Cycles' ``getattribute`` fills no ``float[2]``, the type MaterialX's
#: ``mx_geompropvalue_vector2`` reads ``st`` into (measured, bpy 5.0.1: 0, where a ``vector`` gets the UV map):
#: overloads pass every other type through and read a ``float[2]`` through a ``vector``. Second, ``texture()``
#: gets ``"width", 0``, the image at the pixel centre: OpenImageIO's footprint filtering of the card atlas dimmed
#: small cards by the mask's average, an antialiased picture that a per-pixel comparison with the point-sampled
#: reference counts as error (default asset, sweep_060, 512 px: p95 dE2000 4.3 without, 0.4 with; nothing
#: measurable on the LUT), the choice :data:`rockdove.hosts.materialx_gl.MIPMAPPED_IMAGES` makes. Third, Cycles
#: drops a ``dielectric_bsdf``'s thin film but keeps a ``generalized_schlick_bsdf``'s (one pixel: a 600 nm film of
#: n 2.0 on glass 1.5 at normal incidence, 0.04 grey against the Principled BSDF's (0.056, 0.149, 0.136); OpenPBR's
#: film in air rendered black): a reflection with a film becomes that lobe with exponent -ior, which Cycles reads
#: as the real dielectric Fresnel of that ior (as its Principled BSDF does).
CYCLES_GETATTRIBUTE = """
// rockdove (hosts/osl.py CYCLES_GETATTRIBUTE): Cycles' getattribute fills no float[2]; read it through a vector.
int rd_getattribute(string name, output float value) { return getattribute(name, value); }
int rd_getattribute(string name, output int value) { return getattribute(name, value); }
int rd_getattribute(string name, output string value) { return getattribute(name, value); }
int rd_getattribute(string name, output color value) { return getattribute(name, value); }
int rd_getattribute(string name, output vector value) { return getattribute(name, value); }
int rd_getattribute(string name, output float value[2])
{
    vector v = 0;
    int found = getattribute(name, v);
    if (found) { value[0] = v[0]; value[1] = v[1]; }
    return found;
}
#define getattribute rd_getattribute
// rockdove: images at the pixel centre (no OpenImageIO footprint filtering), as the reference samples the atlas.
#define texture(...) texture(__VA_ARGS__, "width", 0.0)
// rockdove: Cycles drops a dielectric_bsdf's thin film; a reflection with a film goes through generalized_schlick.
closure color rd_dielectric_bsdf(normal N, vector U, color rt, color tt, float rx, float ry, float ior, string dist,
                                 float thickness, float film_ior)
{
    if (thickness <= 0.0 || tt != color(0))
        return dielectric_bsdf(N, U, rt, tt, rx, ry, ior, dist,
                               "thinfilm_thickness", thickness, "thinfilm_ior", film_ior);
    return generalized_schlick_bsdf(N, U, rt, color(0), rx, ry, color(pow((ior - 1) / (ior + 1), 2)), color(1), -ior,
                                    dist, "thinfilm_thickness", thickness, "thinfilm_ior", film_ior);
}
#define dielectric_bsdf(N, U, rt, tt, rx, ry, ior, dist, k1, d, k2, n) \\
    rd_dielectric_bsdf(N, U, rt, tt, rx, ry, ior, dist, d, n)
"""
_INCLUDE = '#include "mx_funcs.h"\n'


def for_cycles(source: str) -> str:
    """The generated OSL with :data:`CYCLES_GETATTRIBUTE` after its include line."""
    head, sep, body = source.partition(_INCLUDE)
    if not sep:
        raise ValueError('the generated OSL does not start with #include "mx_funcs.h"')
    return head + sep + CYCLES_GETATTRIBUTE + body


def geomprops(doc) -> list:
    """The primvar names the network reads (``geompropvalue`` nodes' ``geomprop``), in document order."""
    names = [n.getInputValue("geomprop") for n in doc.getNodes() if n.getCategory() == "geompropvalue"]
    return list(dict.fromkeys(str(n) for n in names if n))


def osl_headers() -> list:
    """MaterialX's OSL include files (``mx_funcs.h`` and what it includes), from the pip MaterialX's libraries."""
    import MaterialX as mx

    found = mx.getDefaultDataSearchPath().find("libraries/stdlib/genosl/include/mx_funcs.h").asString()
    if os.path.isfile(found):
        inc = os.path.dirname(found)
        return sorted(os.path.join(inc, f) for f in os.listdir(inc) if f.endswith(".h"))
    raise HostError("osl", "MaterialX's OSL headers (libraries/stdlib/genosl/include/mx_funcs.h) are not found")


def lobe_document(net: Network, base: str = BASE_COLOUR["baked"]):
    """The network with the ``base`` colour black (the film lobe alone), in the working space, the image files empty:
    ``(document, {shader parameter: absolute file})``, set by the job (a path is never text of the source)."""
    doc = net.doc
    node, _, name = base.partition(".")
    bg = doc.getNode(node).getInput(name) if doc.getNode(node) is not None else None
    if bg is None:
        raise ValueError(f"the network has no {base} (base colour) to turn black")
    bg.removeAttribute("nodename")
    bg.removeAttribute("output")
    bg.setValueString("0, 0, 0")
    for node_name in net.files:
        doc.getNode(node_name).getInput("file").setValueString("")
    to_working_space(doc, net.material)
    return doc, {f"{node_name}_file": os.path.abspath(path) for node_name, path in net.files.items()}


def to_working_space(doc, material_name: str) -> None:
    """Every connected colour feeding a closure, converted into ACEScg by the inverse of MaterialX's own matrix
    (Blender's agrees to 6e-7); unconnected ones are the nodedefs' greys and white, unchanged by it."""
    graph = doc.getDataLibrary().getNodeGraph("NG_acescg_to_lin_rec709_color3")
    matrix = graph.getNode("mat").getInputValue("value").getInverse()
    todo = [doc.getNode(material_name)]
    while todo:
        node = todo.pop()
        for inp in node.getInputs():
            upstream = inp.getConnectedNode()
            if upstream is not None and inp.getType() in ("surfaceshader", "BSDF", "EDF"):
                todo.append(upstream)
            elif upstream is not None and inp.getType() == "color3":
                stem = f"{node.getName()}_{inp.getName()}_acescg"
                vec = doc.addNode("convert", f"{stem}_vector", "vector3")
                vec.addInput("in", "color3").setConnectedNode(upstream)
                vec.getInput("in").setOutputString(inp.getOutputString())
                xform = doc.addNode("transformmatrix", stem, "vector3")
                xform.addInput("in", "vector3").setConnectedNode(vec)
                xform.addInput("mat", "matrix33").setValue(matrix)
                col = doc.addNode("convert", f"{stem}_color", "color3")
                col.addInput("in", "vector3").setConnectedNode(xform)
                inp.setConnectedNode(col)


def _compiler_error(work: str) -> str | None:
    """The OSL compiler's first error line in ``work/blender.log``, the shader named, or None."""
    try:
        with open(os.path.join(work, "blender.log"), encoding="utf-8", errors="replace") as fh:
            lines = fh.read().splitlines()
    except OSError:
        return None
    if not (errors := [ln.strip() for ln in lines if ".osl:" in ln and "error" in ln.lower()]):
        return None
    failed = next((ln.strip() for ln in lines if ln.startswith("OSL compile of ")), "the OSL compiler failed")
    return f"{failed}: {errors[0]} (log: {work}/blender.log)"


#: The registry's hosts, one per network (rockdove.hosts.HOSTS), each with its base colour black.
BAKED, PHYSICAL = HOSTS = (OSLHost("osl", "baked", LOBE), OSLHost("osl_physical", "physical", LOBE))

"""The Cycles side of :mod:`rockdove.hosts.osl`, run as ``PYTHON osl_job.py JOB.json`` by a Python that has bpy;
it imports nothing but the standard library, bpy and its siblings :mod:`.blender_job` and :mod:`.jobs` (this file's
folder is ``sys.path[0]``). A shader the compiler rejects prints its error lines and the job exits 1 naming it."""

from __future__ import annotations

import json
import os
import sys

import blender_job
import jobs


def compile_shaders(shaders: dict[str, jobs.OslShader]) -> None:
    """Compile each mesh path's shader into its ``oso``; exits 1 naming the first shader the compiler rejects."""
    import _cycles

    for mesh, shader in shaders.items():
        if not _cycles.osl_compile(shader.source, shader.oso) or not os.path.isfile(shader.oso):
            print(f"OSL compile of {os.path.basename(shader.source)} (for {mesh}) failed", file=sys.stderr)
            sys.exit(1)


def request_attributes(material, output, names) -> None:
    """Make Cycles export the mesh attributes ``names`` to this material's shaders: it exports one (or a UV map)
    only where its own nodes ask for it by name, not for a Script node's ``getattribute`` (0: the neck read its
    defaults). Each gets an Attribute node summed into a Displacement of scale 0 (bump mode): nodes Cycles keeps
    (an unlinked node or an AOV output is dropped, measured) and that move nothing."""
    if not names:
        return
    nodes, links = material.node_tree.nodes, material.node_tree.links
    disp = nodes.new("ShaderNodeDisplacement")
    disp.inputs["Scale"].default_value = 0.0
    links.new(disp.outputs["Displacement"], output.inputs["Displacement"])
    target = disp.inputs["Height"]
    for name in names:
        attr = nodes.new("ShaderNodeAttribute")
        attr.attribute_name = name
        add = nodes.new("ShaderNodeMath")
        add.operation = "ADD"
        links.new(add.outputs[0], target)
        links.new(attr.outputs["Fac"], add.inputs[0])
        target = add.inputs[1]
    material.displacement_method = "BUMP"


def script_material(bpy, name: str, oso: str, attributes=(), files=None):
    """A material whose surface is one Script node running ``oso`` (``files``: its texture parameters)."""
    import glob

    import cycles.osl

    # the Script node's parameter query (oslquery) lives in bpy's bundled site-packages, not on sys.path
    bundled = glob.glob(os.path.join(bpy.utils.resource_path("LOCAL"), "python", "lib", "python3*", "site-packages"))
    sys.path.extend(p for p in bundled if p not in sys.path)
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    script = nodes.new("ShaderNodeScript")
    script.mode, script.filepath = "EXTERNAL", oso
    errors = []
    cycles.osl.update_script_node(script, lambda kind, msg: errors.append(msg) if "ERROR" in kind else None)
    if errors or "out" not in script.outputs:
        raise RuntimeError(f"Script node for {oso}: {'; '.join(errors) or 'no closure output out'}")
    for param, path in (files or {}).items():  # the texture files: values, never text of the shader's source
        script.inputs[param].default_value = path
    output = nodes.new("ShaderNodeOutputMaterial")
    mat.node_tree.links.new(script.outputs["out"], output.inputs["Surface"])
    request_attributes(mat, output, attributes)
    return mat


def run(job: jobs.OslJob) -> None:
    import bpy
    import mathutils

    compile_shaders(job.shaders)
    _, _, to_blender = blender_job.import_asset(bpy, job)
    # colours stay as the shader computes them (in ACEScg), the render is written in linear Rec.709 (osl.py)
    bpy.ops.wm.set_working_color_space(working_space=job.working_space, convert_colors=False)
    black = blender_job.black_material(bpy)
    by_name = {mesh.rsplit("/", 1)[-1]: shader for mesh, shader in job.shaders.items()}
    drawn = []
    for ob in bpy.data.objects:
        ob.visible_glossy = ob.visible_diffuse = False  # the lobe sees the uniform world alone, unoccluded
        if ob.type != "MESH":
            continue
        shader = by_name.get(ob.name) or by_name.get(ob.data.name)
        material = (script_material(bpy, f"rockdove_osl_{ob.name}", shader.oso, shader.attributes, shader.files)
                    if shader else blender_job.occluder(ob.active_material, black))
        if shader:
            drawn.append(ob.name)
        ob.data.materials.clear()
        ob.data.materials.append(material)
    if missing := sorted(set(by_name) - set(drawn)):
        objects = [o.name for o in bpy.data.objects]
        raise RuntimeError(f"no imported mesh named {', '.join(missing)} (objects: {objects})")
    blender_job.white_world(bpy, job.environment_radiance)
    bpy.context.scene.cycles.shading_system = True  # OSL (CPU only)
    blender_job.render_views(bpy, mathutils, to_blender, job, job.exr_colorspace)
    with open(os.path.join(job.out_dir, "done.json"), "w", encoding="utf-8") as fh:
        json.dump({"drawn": drawn, "blender": bpy.app.version_string}, fh)


if __name__ == "__main__":
    run(jobs.OslJob.read(sys.argv[1]))

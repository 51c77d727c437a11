"""The Blender side of :mod:`rockdove.hosts.blender`: run as ``PYTHON path/to/blender_job.py JOB.json`` by a Python
that has bpy (:func:`rockdove.hosts.blender.bpy_python`); it imports nothing but the standard library and bpy.

It runs in its own process because ``bpy`` bundles its own USD (0.25.08) while rockdove uses usd-core: the
add-on's ``USDHook`` gets the import's stage as a bundled-USD object, which only bpy's own ``pxr`` Python
package can read, and ``import pxr`` in a process that also uses usd-core finds usd-core's (measured: "No
to_python converter found for C++ type ... UsdStage"). The add-on itself puts bpy's bundled ``pxr`` on
``sys.path`` when it is enabled, as it does for any user; this module imports nothing of rockdove that uses USD.

Steps (the job file, written by :func:`rockdove.hosts.blender.render`, gives every value):

1. install the add-on zip and enable ``rockdove_blender`` exactly as a user does
   (``bpy.ops.preferences.addon_install`` / ``addon_enable``; the parent points Blender's user folders
   into the job folder, so nothing is installed outside it);
2. ``bpy.ops.wm.usd_import`` of the asset: the add-on builds the thin-film material;
3. ``lobe = "as_imported"`` leaves every material as imported (what a user sees, with or without the add-on);
   ``lobe = "view_angle"`` (BRIEF "hosts interface"): the film lobe alone under a uniform white world of unit
   radiance. The add-on's film is made smooth (roughness 0: the mirror lobe), its base BSDF is turned black
   (its base-colour link removed), every other material
   becomes black diffuse (still occluding), and no object is seen by glossy rays, so each film pixel
   reflects the environment itself (no inter-reflection, as the reference assumes);
4. per view: a camera with the View's OpenGL ``camera_to_world`` mapped through the importer's up-axis
   conversion (the imported root prim's world matrix: ``/Pigeon`` has no transform of its own), vertical
   field of view, size; Cycles on the CPU, ``samples`` per pixel, a 0.01 px pixel filter (pixel centres, like
   the reference), transparent film (background 0), written as float32 EXR.
"""

from __future__ import annotations

import json
import os
import sys


def _black_material(bpy):
    mat = bpy.data.materials.new("rockdove_black")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    return mat


def film_lobe_only(bpy, addon) -> int:
    """Set up the ``view_angle`` lobe (module docstring, step 3); returns the number of thin-film materials."""
    black = _black_material(bpy)
    films = 0
    for ob in bpy.data.objects:
        ob.visible_glossy = False
        if ob.type != "MESH":
            continue
        for slot in ob.material_slots:
            mat = slot.material
            if mat is not None and mat.get(addon.MATERIAL_TAG):
                mat.node_tree.nodes[addon.NODE_FILM].inputs["Roughness"].default_value = 0.0  # smooth film
                base = mat.node_tree.nodes[addon.NODE_BASE]
                for link in list(base.inputs["Base Color"].links):
                    mat.node_tree.links.remove(link)
                base.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
                base.inputs["Specular IOR Level"].default_value = 0.0
                films += 1
            else:
                slot.material = black
    return films


def _world(bpy, radiance: float) -> None:
    world = bpy.data.worlds.new("rockdove_white")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = float(radiance)
    bpy.context.scene.world = world


def _camera(bpy, mathutils, to_blender, view: dict):
    data = bpy.data.cameras.new(view["name"])
    data.sensor_fit = "VERTICAL"
    data.angle_y = float(view["yfov_rad"])
    data.clip_start, data.clip_end = 1e-3, 1e3
    cam = bpy.data.objects.new(view["name"], data)
    bpy.context.scene.collection.objects.link(cam)
    cam.matrix_world = to_blender @ mathutils.Matrix(view["camera_to_world"])
    return cam


def import_asset(bpy, job: dict):
    """Steps 1-2 (module docstring) in an empty scene: ``(add-on module or None, thin-film material names,
    the importer's up-axis conversion matrix)``."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon = None
    if job["addon_zip"]:
        bpy.ops.preferences.addon_install(filepath=job["addon_zip"], overwrite=True)
        bpy.ops.preferences.addon_enable(module=job["addon_module"])
        addon = sys.modules[job["addon_module"]]
    result = bpy.ops.wm.usd_import(filepath=job["asset"])
    if "FINISHED" not in result:
        raise RuntimeError(f"usd_import of {job['asset']} returned {result}")
    films = [m.name for m in bpy.data.materials if addon is not None and m.get(addon.MATERIAL_TAG)]
    if addon is not None and not films:
        raise RuntimeError(f"the add-on built no thin-film material for {job['asset']}")
    root = bpy.data.objects.get(job["root_object"])
    if root is None:
        raise RuntimeError(f"no imported object {job['root_object']!r} (the asset's root prim)")
    return addon, films, root.matrix_world.copy()  # the importer's up-axis conversion


def render_views(bpy, mathutils, to_blender, job: dict) -> None:
    """Step 4 (module docstring): Cycles on the CPU as the job says, one EXR per View with its camera exactly
    (also the OSL host's, :mod:`rockdove.hosts.osl_job`)."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = int(job["samples"])
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.transparent_max_bounces = int(job["transparent_bounces"])
    scene.cycles.filter_width = 0.01
    scene.cycles.seed = 0
    scene.render.film_transparent = True
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    scene.render.threads_mode = "FIXED"
    scene.render.threads = int(job["threads"])
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_depth = "32"
    settings.color_mode = "RGBA"
    if job.get("exr_colorspace"):  # the OSL host's (set after file_format, which resets it)
        settings.color_management = "OVERRIDE"
        settings.linear_colorspace_settings.name = job["exr_colorspace"]
    scene.view_settings.view_transform = "Standard"
    for view in job["views"]:
        scene.render.resolution_x, scene.render.resolution_y = int(view["width"]), int(view["height"])
        scene.camera = _camera(bpy, mathutils, to_blender, view)
        scene.render.filepath = os.path.join(job["out_dir"], f"{view['name']}.exr")
        bpy.ops.render.render(write_still=True)


def run(job: dict) -> None:
    import bpy
    import mathutils

    addon, films, to_blender = import_asset(bpy, job)
    if job["lobe"] == "view_angle":
        film_lobe_only(bpy, addon)
    elif job["lobe"] != "as_imported":
        raise RuntimeError(f"lobe {job['lobe']!r} is not rendered by this host")
    _world(bpy, job["environment_radiance"])
    render_views(bpy, mathutils, to_blender, job)
    with open(os.path.join(job["out_dir"], "done.json"), "w", encoding="utf-8") as fh:
        json.dump({"films": films, "blender": bpy.app.version_string}, fh)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("usage: python -m rockdove.hosts.blender_job JOB.json", file=sys.stderr)
        return 2
    with open(argv[0], encoding="utf-8") as fh:
        job = json.load(fh)
    run(job)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The Blender side of :mod:`rockdove.hosts.blender`, run as ``PYTHON blender_job.py JOB.json`` by a Python that
has bpy; stdlib, bpy and :mod:`.jobs` only. Its own process: the add-on's ``USDHook`` gets a stage only bpy's ``pxr``
can read (measured: "No to_python converter found for C++ type ... UsdStage" with usd-core's). For ``view_angle``:
the film smooth, its base black, every other material black but occluding, under a uniform white world (no
inter-reflection, as the reference assumes); a 0.01 px pixel filter (pixel centres, like the reference)."""

from __future__ import annotations

import json
import os
import sys
import time

import jobs  # the sibling module (this file is run by path: its folder is sys.path[0])


def _black(bsdf, tree=None, unlink=()) -> None:
    """A Principled BSDF black and without specular, its ``unlink`` inputs' links removed from ``tree`` first."""
    for name in unlink:
        for link in list(bsdf.inputs[name].links):
            tree.links.remove(link)
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Specular IOR Level"].default_value = 0.0


def black_material(bpy):
    mat = bpy.data.materials.new("rockdove_black")
    mat.use_nodes = True
    _black(mat.node_tree.nodes.get("Principled BSDF"))
    return mat


def occluder(mat, black):
    """``mat`` black but keeping its alpha cut-out (occluding as the reference's rays do), else ``black``."""
    nodes = mat.node_tree.nodes if mat is not None and mat.use_nodes else ()
    bsdf = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None or not bsdf.inputs["Alpha"].links:
        return black
    _black(bsdf, mat.node_tree, ("Base Color", "Normal"))
    return mat


def film_lobe_only(bpy, addon) -> None:
    """Set up the ``view_angle`` lobe (module docstring)."""
    black = black_material(bpy)
    for ob in bpy.data.objects:
        ob.visible_glossy = False
        if ob.type != "MESH":
            continue
        for slot in ob.material_slots:
            mat = slot.material
            if mat is not None and mat.get(addon.MATERIAL_TAG):
                mat.node_tree.nodes[addon.NODE_FILM].inputs["Roughness"].default_value = 0.0  # smooth film
                _black(mat.node_tree.nodes[addon.NODE_BASE], mat.node_tree, ("Base Color",))
            else:
                slot.material = occluder(mat, black)


def white_world(bpy, radiance: float) -> None:
    world = bpy.data.worlds.new("rockdove_white")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = float(radiance)
    bpy.context.scene.world = world


def _camera(bpy, mathutils, to_blender, view: jobs.JobView):
    data = bpy.data.cameras.new(view.name)
    data.sensor_fit = "VERTICAL"
    data.angle_y = float(view.yfov_rad)
    data.clip_start, data.clip_end = 1e-3, 1e3
    cam = bpy.data.objects.new(view.name, data)
    bpy.context.scene.collection.objects.link(cam)
    cam.matrix_world = to_blender @ mathutils.Matrix(view.camera_to_world)
    return cam


def import_asset(bpy, job: jobs.CyclesJob):
    """The add-on installed as a user does, the asset imported into an empty scene: ``(add-on module or None, film
    material names, up-axis conversion matrix)``."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon = None
    if job.addon_zip:
        bpy.ops.preferences.addon_install(filepath=job.addon_zip, overwrite=True)
        bpy.ops.preferences.addon_enable(module=job.addon_module)
        addon = sys.modules[job.addon_module]
    result = bpy.ops.wm.usd_import(filepath=job.asset)
    if "FINISHED" not in result:
        raise RuntimeError(f"usd_import of {job.asset} returned {result}")
    films = [m.name for m in bpy.data.materials if addon is not None and m.get(addon.MATERIAL_TAG)]
    if addon is not None and not films:
        raise RuntimeError(f"the add-on built no thin-film material for {job.asset}")
    if (root := bpy.data.objects.get(job.root_object)) is None:
        raise RuntimeError(f"no imported object {job.root_object!r} (the asset's root prim)")
    return addon, films, root.matrix_world.copy()  # the importer's up-axis conversion


def cycles(scene, job: jobs.CyclesJob) -> None:
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = int(job.samples)
    scene.cycles.transparent_max_bounces = int(job.transparent_bounces)
    scene.cycles.seed = 0
    scene.render.resolution_percentage = 100
    scene.render.threads_mode, scene.render.threads = "FIXED", int(job.threads)


def shoot(bpy, mathutils, to_blender, views: list[jobs.JobView], out_dir: str, ext: str, aim=None) -> dict:
    """Render each view with its camera exactly as ``out_dir/<view>.<ext>``; seconds per view."""
    scene = bpy.context.scene
    seconds = {}
    for view in views:
        scene.render.resolution_x, scene.render.resolution_y = int(view.width), int(view.height)
        scene.camera = _camera(bpy, mathutils, to_blender, view)
        if aim is not None:
            aim(view)
        t = time.perf_counter()
        bpy.ops.render.render()
        # saved by path as given: scene.render.filepath expands {...} templates and reads "\\" as "/" (Blender 5)
        bpy.data.images["Render Result"].save_render(filepath=os.path.join(out_dir, f"{view.name}.{ext}"))
        seconds[view.name] = time.perf_counter() - t
    return seconds


def render_views(bpy, mathutils, to_blender, job: jobs.CyclesJob, colorspace: str | None = None) -> None:
    """One float32 EXR per View (in ``colorspace``, else Blender's default), Cycles on the CPU (also the OSL host's,
    :mod:`rockdove.hosts.osl_job`)."""
    scene = bpy.context.scene
    cycles(scene, job)
    scene.cycles.use_denoising = scene.cycles.use_adaptive_sampling = False
    scene.cycles.filter_width = 0.01
    scene.render.film_transparent = True
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    settings = scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGBA"
    if colorspace:  # set after file_format, which resets it
        settings.color_management = "OVERRIDE"
        settings.linear_colorspace_settings.name = colorspace
    scene.view_settings.view_transform = "Standard"
    shoot(bpy, mathutils, to_blender, job.views, job.out_dir, "exr")


def run(job: jobs.BlenderJob) -> None:
    import bpy
    import mathutils

    addon, films, to_blender = import_asset(bpy, job)
    if job.frame is not None:  # an animated asset (its armature's action) at that frame
        bpy.context.scene.frame_set(int(job.frame))
    if job.lobe == "view_angle":  # else "as_imported" (BlenderHost.render checks)
        film_lobe_only(bpy, addon)
    white_world(bpy, job.environment_radiance)
    render_views(bpy, mathutils, to_blender, job)
    with open(os.path.join(job.out_dir, "done.json"), "w", encoding="utf-8") as fh:
        json.dump({"films": films, "blender": bpy.app.version_string}, fh)


if __name__ == "__main__":
    run(jobs.BlenderJob.read(sys.argv[1]))

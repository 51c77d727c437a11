"""The Blender side of the beauty render (:mod:`rockdove.render.beauty`), run like :mod:`.blender_job`: the asset as
a user imports it, staged as a hero shot (cyclorama ground, sky-gradient world, a warm sun from each view's own
direction), Cycles with OpenImageDenoise, an 8-bit PNG per view through AgX."""

from __future__ import annotations

import json
import os
import sys

import blender_job as bj  # the sibling job module (this file is run by path: its folder is sys.path[0])
import jobs


def _ground(bpy, to_blender, job: jobs.BeautyJob):
    """The ground the job names (USD world metres: :func:`rockdove.render.beauty.cyclorama`), neutral grey."""
    mesh = bpy.data.meshes.new("rockdove_ground")
    mesh.from_pydata([tuple(v) for v in job.ground_vertices_m], [], [tuple(f) for f in job.ground_quads])
    mesh.shade_smooth()
    ob = bpy.data.objects.new("rockdove_ground", mesh)
    bpy.context.scene.collection.objects.link(ob)
    ob.matrix_world = to_blender.copy()
    mat = bpy.data.materials.new("rockdove_ground")
    mat.use_nodes = True  # Blender 4.x; always so in 5.x
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    g = float(job.ground_albedo)
    bsdf.inputs["Base Color"].default_value = (g, g, g, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.7
    ob.data.materials.append(mat)
    return ob


def _sky(bpy, job: jobs.BeautyJob):
    """World: a vertical gradient of the ray direction's up component, horizon to zenith, at ``sky_strength``."""
    world = bpy.data.worlds.new("rockdove_sky")
    world.use_nodes = True
    nt = world.node_tree
    coords = nt.nodes.new("ShaderNodeTexCoord")
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    nt.links.new(coords.outputs["Generated"], sep.inputs[0])
    nt.links.new(sep.outputs["Z"], ramp.inputs["Fac"])  # Blender is Z up: Z is the direction's elevation sine
    stops = ramp.color_ramp.elements
    stops[0].position, stops[0].color = 0.0, (*job.sky_horizon_rgb, 1.0)
    stops[1].position, stops[1].color = 1.0, (*job.sky_zenith_rgb, 1.0)
    bg = nt.nodes["Background"]
    nt.links.new(ramp.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = float(job.sky_strength)
    bpy.context.scene.world = world


def _sun(bpy, job: jobs.BeautyJob):
    data = bpy.data.lights.new("rockdove_sun", "SUN")
    data.energy = float(job.sun_strength)  # W/m^2
    data.color = tuple(job.sun_rgb)
    data.angle = float(job.sun_angle_deg) * 3.141592653589793 / 180.0
    ob = bpy.data.objects.new("rockdove_sun", data)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def _settings(scene, job: jobs.BeautyJob):
    bj.cycles(scene, job)
    c = scene.cycles
    c.use_adaptive_sampling = True
    c.adaptive_threshold = 0.02
    c.use_denoising = True
    c.denoiser = "OPENIMAGEDENOISE"
    c.max_bounces, c.diffuse_bounces, c.glossy_bounces, c.transmission_bounces = 6, 2, 2, 2
    scene.render.film_transparent = False
    scene.render.use_persistent_data = True  # the second view reuses the first's BVH and shaders
    settings = scene.render.image_settings
    settings.file_format, settings.color_mode, settings.color_depth = "PNG", "RGB", "8"
    scene.view_settings.view_transform = "AgX"
    scene.view_settings.look = job.look
    scene.view_settings.exposure = float(job.exposure)


def run(job: jobs.BeautyJob) -> None:
    import bpy
    import mathutils

    _, films, to_blender = bj.import_asset(bpy, job)
    _ground(bpy, to_blender, job)
    _sky(bpy, job)
    sun = _sun(bpy, job)
    _settings(bpy.context.scene, job)

    def aim(view):  # the sun shines down its local -Z, from view.sun_direction (USD world, bird to sun)
        towards = (to_blender.to_3x3() @ mathutils.Vector(view.sun_direction)).normalized()
        sun.rotation_euler = towards.to_track_quat("Z", "Y").to_euler()

    seconds = bj.shoot(bpy, mathutils, to_blender, job.views, job.out_dir, "png", aim=aim)
    with open(os.path.join(job.out_dir, "done.json"), "w", encoding="utf-8") as fh:
        json.dump({"films": films, "blender": bpy.app.version_string, "render_s": seconds}, fh)


if __name__ == "__main__":
    run(jobs.BeautyJob.read(sys.argv[1]))

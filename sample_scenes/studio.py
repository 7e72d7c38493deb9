"""Scene plumbing shared by the builders: empty scene, materials, camera, lights, Cycles."""

import contextlib
import math
import os
import sys

import bpy
from mathutils import Vector

from ..addon.io import blender_versions


def empty_scene(name: str):
    """Clear the current file's objects and data (keeps preferences and add-ons)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.name = name
    return scene


def material(obj, name, colour, roughness=0.6):
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    blender_versions.use_nodes(mat)
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = colour
    bsdf.inputs["Roughness"].default_value = roughness
    mat.diffuse_color = colour
    obj.data.materials.append(mat)
    # Both sides of open garments render, so back faces must not be culled.
    mat.use_backface_culling = False
    return mat


def camera_and_lights(scene, target=(0, 0, 1), distance=3.0, elevation_deg=15.0, azimuth_deg=-30.0):
    target = Vector(target)
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    offset = Vector((math.sin(az) * math.cos(el), -math.cos(az) * math.cos(el), math.sin(el))) * distance
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 50
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = target + offset
    cam.rotation_euler = (target - cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    for name, energy, rot in (("Key", 3.0, (0.8, 0.2, -0.6)), ("Fill", 1.0, (1.0, -0.3, 2.4))):
        light_data = bpy.data.lights.new(name, "SUN")
        light_data.energy = energy
        light = bpy.data.objects.new(name, light_data)
        light.rotation_euler = rot
        scene.collection.objects.link(light)
    world = bpy.data.worlds.new("World")
    blender_versions.use_nodes(world)
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.05, 0.06, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    scene.world = world
    return cam


def render_cycles(scene, filepath, resolution=(480, 480), samples=16, denoise=False, quiet=False):
    """Render the scene camera to a PNG with Cycles on the CPU; returns seconds taken. ``denoise``:
    OpenImageDenoise, clean at a few samples; ``quiet``: without Blender's line per render tile."""
    import time

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = denoise
    if denoise:
        scene.cycles.denoiser = "OPENIMAGEDENOISE"
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(filepath)
    start = time.perf_counter()
    with _silent_stdout() if quiet else _nothing():
        bpy.ops.render.render(write_still=True)
    return time.perf_counter() - start


@contextlib.contextmanager
def _nothing():
    yield


@contextlib.contextmanager
def _silent_stdout():
    """Blender's own output (a "Fra:" line per tile) to nowhere, at the file descriptor: it
    writes from C, past sys.stdout."""
    sys.stdout.flush()
    kept = os.dup(1)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        try:
            yield
        finally:
            os.dup2(kept, 1)
            os.close(kept)


def render_passes(scene, folder, passes=("Image",)):
    """Render the scene camera once with its engine and read the named passes back as float
    arrays through the compositor's File Output node (linear, no view transform), rows top to
    bottom: "Image" as (h, w, 4), any other pass ("Depth", "IndexOB", ...) as (h, w)."""
    from pathlib import Path

    import numpy as np

    folder = Path(folder)
    scene.use_nodes = True
    tree = scene.node_tree
    tree.nodes.clear()
    layers = tree.nodes.new("CompositorNodeRLayers")
    out = tree.nodes.new("CompositorNodeOutputFile")
    out.base_path = str(folder) + "/"
    out.format.file_format = "OPEN_EXR"
    out.format.color_mode = "RGBA"
    # the node's own first slot takes the first pass (removing a slot leaves a block Blender
    # never frees: "Not freed memory blocks" at exit)
    out.file_slots[0].path = passes[0]
    for name in passes[1:]:
        out.file_slots.new(name)
    for k, name in enumerate(passes):
        tree.links.new(layers.outputs[name], out.inputs[k])
    if bpy.ops.render.render() != {"FINISHED"}:
        raise RuntimeError(f"rendering {scene.name} with {scene.render.engine} failed")
    planes = {}
    for name in passes:
        path = folder / f"{name}{scene.frame_current:04d}.exr"
        img = bpy.data.images.load(str(path))
        w, h = img.size  # the frame's, or a render border's when it crops to it
        px = np.empty(w * h * 4, np.float32)
        img.pixels.foreach_get(px)
        bpy.data.images.remove(img)
        path.unlink()
        px = px.reshape(h, w, 4)[::-1]
        planes[name] = px if name == "Image" else px[..., 0]
    scene.node_tree.nodes.clear()
    scene.use_nodes = False
    return planes

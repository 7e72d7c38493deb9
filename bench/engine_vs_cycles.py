"""The DEFORMRT_LAYERED render engine beside Cycles on one scene of what Blender users light and
shade with: a flat-shaded cube in two material slots, a UV sphere with an image texture, a
bevelled curve, emissive text, a sun and a soft-edged spot. Writes docs/img/engine_vs_cycles.png
(this engine left, Cycles right, 128 samples, no bounces) and a small table into docs/REPORT.md.

    .venv/bin/python -m bench.engine_vs_cycles
"""

import tempfile
import time
from pathlib import Path

import numpy as np

from bench.blender import load_package
from bench.report import REPORT, machine, table, write_section

SIZE = (400, 260)


def _material(name, colour, roughness=0.6):
    import bpy

    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Specular IOR Level"].default_value = 0.2
    return mat


def _aim(obj, target):
    from mathutils import Vector

    obj.rotation_euler = (Vector(target) - Vector(obj.location)).to_track_quat("-Z", "Y").to_euler()


def build():
    """The scene, made current."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.05, 0.06, 1.0)
    scene.world = world
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.location = (0.0, -7.5, 4.0)
    _aim(cam, (0.0, 0.0, 0.6))
    bpy.ops.mesh.primitive_plane_add(size=12.0)
    bpy.context.active_object.data.materials.append(_material("Floor", (0.6, 0.6, 0.6)))
    # a flat-shaded cube whose faces alternate between two slots
    bpy.ops.mesh.primitive_cube_add(size=1.2, location=(-2.0, 0.5, 0.6), rotation=(0.0, 0.0, 0.5))
    cube = bpy.context.active_object
    cube.data.materials.append(_material("Red", (0.8, 0.15, 0.1)))
    cube.data.materials.append(_material("Blue", (0.1, 0.3, 0.8)))
    cube.data.polygons.foreach_set("material_index", np.array([0, 1, 0, 1, 0, 1], np.int32))
    cube.data.update()
    # a smooth UV sphere with a checker image on its Base Color
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(0.0, 0.8, 0.8))
    bpy.ops.object.shade_smooth()
    checked = _material("Checked", (1.0, 1.0, 1.0))
    bpy.context.active_object.data.materials.append(checked)
    image = bpy.data.images.new("Checker", 64, 32)
    rows, cols = np.mgrid[0:32, 0:64]
    on = ((cols // 8 + rows // 8) % 2).astype(np.float32)
    image.pixels.foreach_set(np.stack([0.9 * on + 0.1, 0.8 * on + 0.15, np.full_like(on, 0.3), np.ones_like(on)],
                                      -1).ravel())
    texture = checked.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    base = checked.node_tree.nodes["Principled BSDF"].inputs["Base Color"]
    checked.node_tree.links.new(texture.outputs["Color"], base)
    # a bevelled curve and emissive text
    bpy.ops.curve.primitive_bezier_circle_add(radius=0.7, location=(2.1, 0.5, 0.25))
    bpy.context.active_object.data.bevel_depth = 0.2
    bpy.context.active_object.data.materials.append(_material("Green", (0.2, 0.7, 0.3)))
    bpy.ops.object.text_add(location=(-1.3, -1.6, 0.01))
    text = bpy.context.active_object
    text.data.body, text.data.extrude = "DeformRT", 0.05
    glow = _material("Glow", (0.1, 0.1, 0.1))
    glow.node_tree.nodes["Principled BSDF"].inputs["Emission Color"].default_value = (1.0, 0.6, 0.2, 1.0)
    glow.node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 2.0
    text.data.materials.append(glow)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.rotation_euler = 2.0, (0.7, 0.2, 0.6)
    scene.collection.objects.link(sun)
    spot = bpy.data.objects.new("Spot", bpy.data.lights.new("Spot", "SPOT"))
    spot.data.energy, spot.data.spot_size, spot.data.spot_blend = 800.0, np.radians(30.0), 0.4
    spot.data.shadow_soft_size, spot.data.color = 0.0, (0.6, 0.8, 1.0)
    spot.location = (2.5, -2.0, 5.0)
    _aim(spot, (1.5, 0.5, 0.0))
    scene.collection.objects.link(spot)
    return scene


def main():
    load_package()
    from deformrt.sample_scenes import studio

    from bench.jellyfish import write_png

    scene = build()
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    out, seconds = {}, {}
    for engine in ("DEFORMRT_LAYERED", "CYCLES"):
        scene.render.engine = engine
        scene.cycles.samples, scene.cycles.max_bounces, scene.cycles.use_denoising = 128, 0, False
        t0 = time.perf_counter()
        out[engine] = studio.render_passes(scene, Path(tempfile.mkdtemp()), ("Image",))["Image"][..., :3]
        seconds[engine] = time.perf_counter() - t0
    ours, theirs = out["DEFORMRT_LAYERED"], out["CYCLES"]
    both = np.concatenate([ours, np.ones((SIZE[1], 6, 3)), theirs], 1)
    srgb = np.where(both <= 0.0031308, 12.92 * both, 1.055 * np.clip(both, 0, None) ** (1 / 2.4) - 0.055)
    write_png(REPORT.parent / "img" / "engine_vs_cycles.png",
              np.ascontiguousarray((np.clip(srgb, 0, 1) * 255).astype(np.uint8)))
    diff = np.abs(ours - theirs).mean(-1)
    rows = [("DeformRT Layered", f"{seconds['DEFORMRT_LAYERED']:.2f}", *(f"{x:.3f}" for x in ours.mean((0, 1)))),
            ("Cycles, 128 samples", f"{seconds['CYCLES']:.2f}", *(f"{x:.3f}" for x in theirs.mean((0, 1))))]
    text = (f"Machine: {machine()}. {SIZE[0]}x{SIZE[1]}; F12 through the compositor's file output, linear "
            "radiance. The scene: a flat-shaded cube in two material slots, a UV sphere with an image "
            "texture on its Base Color, a bevelled Bezier circle, emissive text, a sun and a spot with a "
            "blended edge.\n\n"
            + table(("engine", "seconds", "mean R", "mean G", "mean B"), rows)
            + f"\n\nPixels differing by more than 0.05 in mean channel: {100 * (diff > 0.05).mean():.1f}%; "
            f"median difference {np.median(diff):.4f}.\n\n"
            "![DeformRT Layered (left) and Cycles (right)](img/engine_vs_cycles.png)\n\n"
            "Reading: the same materials, slots, texture, spot cone and flat faces. Where they differ: "
            "Cycles' emissive text lights the floor round it (this engine's emission lights nothing "
            "else), its sun casts slightly soft shadows (here every light is a point or a direction), "
            "and its noise and pixel filter.")
    write_section("engine_vs_cycles", "Layered ray tracing for display: one scene beside Cycles", text)
    print(text)


if __name__ == "__main__":
    main()

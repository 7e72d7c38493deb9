"""A sea-water stage for the jellyfish: blue-green scattering water, a sand floor, light from above.

The jellyfish issues add the animal; this scene only holds the world, an anchor empty
where the bell goes, the camera and lights.
"""

import bpy

from ..addon.io import blender_versions
from . import studio


def build():
    """Replace the scene's contents; returns the anchor empty the jellyfish is placed at."""
    scene = studio.empty_scene("Sea")
    col = scene.collection
    world = bpy.data.worlds.new("Deep")
    blender_versions.use_nodes(world)
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.005, 0.03, 0.05, 1.0)
    scene.world = world
    # sea water: a box of scattering, absorbing medium (a world volume would swallow the sun)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, 0.0))
    water = bpy.context.active_object
    water.name, water.scale = "SeaWater", (60.0, 60.0, 8.0)  # wider than the floor: no dry horizon
    mat = bpy.data.materials.new("SeaWater")
    blender_versions.use_nodes(mat)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.remove(nodes["Principled BSDF"])
    volume = nodes.new("ShaderNodeVolumePrincipled")
    volume.inputs["Color"].default_value = (0.08, 0.3, 0.42, 1.0)
    volume.inputs["Density"].default_value = 0.35
    volume.inputs["Absorption Color"].default_value = (0.35, 0.75, 0.85, 1.0)
    links.new(volume.outputs["Volume"], nodes["Material Output"].inputs["Volume"])
    water.data.materials.append(mat)
    water.visible_shadow = False
    bpy.ops.mesh.primitive_plane_add(size=40.0, location=(0.0, 0.0, -3.5))
    floor = bpy.context.active_object
    floor.name = "SeaFloor"
    studio.material(floor, "Sand", (0.55, 0.48, 0.35, 1.0), roughness=0.9)
    anchor = bpy.data.objects.new("JellyfishAnchor", None)
    anchor.empty_display_type = "SPHERE"
    anchor.empty_display_size = 0.1
    col.objects.link(anchor)
    sun_data = bpy.data.lights.new("Surface", "SUN")
    sun_data.energy = 4.0
    sun_data.color = (0.8, 0.95, 1.0)
    sun = bpy.data.objects.new("Surface", sun_data)
    sun.rotation_euler = (0.15, 0.1, 0.0)
    col.objects.link(sun)
    cam_data = bpy.data.cameras.new("Camera")
    cam = bpy.data.objects.new("Camera", cam_data)
    col.objects.link(cam)
    cam.location = (0.0, -2.2, 0.0)
    cam.rotation_euler = (1.5708, 0.0, 0.0)
    scene.camera = cam
    return anchor

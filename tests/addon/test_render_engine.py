"""The DEFORMRT_LAYERED render engine through bpy.ops.render.render in background mode."""

import bpy
import numpy as np


def _render(scene, tmp_path, size=(32, 32)):
    scene.render.engine = "DEFORMRT_LAYERED"
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"  # linear floats, no view transform
    scene.render.filepath = str(tmp_path / "frame.exr")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    img = bpy.data.images.load(str(tmp_path / "frame.exr"))
    px = np.empty(size[0] * size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(size[1], size[0], 4)[::-1]  # rows top to bottom


def _material(obj, colour):
    mat = bpy.data.materials.new(f"M{colour}")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = 1.0
    obj.data.materials.append(mat)


def _stage(scene, sun_strength=2.0):
    world = bpy.data.worlds.new("Black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.world = world
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = sun_strength  # shines down -z at rest
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.location = (0, 0, 5)  # looks down -z at rest
    scene.collection.objects.link(cam)
    scene.camera = cam


def test_engine_is_registered_and_shades_a_sphere_by_lambert(extension, clean_scene, tmp_path):
    assert "DEFORMRT_LAYERED" in {getattr(e, "bl_idname", None) for e in bpy.types.RenderEngine.__subclasses__()}
    scene = clean_scene
    _stage(scene)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    _material(bpy.context.active_object, (0.5, 0.4, 0.3))
    px = _render(scene, tmp_path)
    # straight under the sun and the camera: E * albedo * cos(0)
    centre = px[15:17, 15:17, :3].reshape(-1, 3)
    np.testing.assert_allclose(centre, np.tile([1.0, 0.8, 0.6], (4, 1)), rtol=0.01)
    np.testing.assert_allclose(px[0, 0, :3], 0.0)  # the corner sees the black world
    # the 50 mm lens on a 36 mm sensor at 5 m sees 3.6 m across: the sphere is 2 m wide
    covered = px[..., 0] > 0
    assert abs(covered[16].sum() / 32 - 2.0 / 3.6) < 0.08


def test_coincident_garments_show_the_outer_layer_only(extension, clean_scene, tmp_path):
    scene = clean_scene
    _stage(scene)
    for name, layer, colour, bump in (("Shirt", 1, (1.0, 0.0, 0.0), 0.004), ("Jacket", 2, (0.0, 0.0, 1.0), 0.0)):
        bpy.ops.mesh.primitive_grid_add(x_subdivisions=24, y_subdivisions=24, size=2.0)
        obj = bpy.context.active_object
        obj.name = name
        co = np.empty(len(obj.data.vertices) * 3)
        obj.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        co[:, 2] += bump * np.sin(29 * co[:, 0]) * np.cos(31 * co[:, 1])  # the shirt pokes through
        obj.data.vertices.foreach_set("co", co.ravel())
        obj.data.update()
        obj.deformrt.role, obj.deformrt.layer = "GARMENT", layer
        _material(obj, colour)
    body = bpy.data.objects.new("Body", bpy.data.meshes.new("Body"))
    scene.collection.objects.link(body)
    body.deformrt.role = "BODY"
    scene.deformrt.probe_distance = 0.02
    px = _render(scene, tmp_path)
    covered = px[..., :3].sum(-1) > 0
    assert covered.mean() > 0.1
    assert (px[covered, 0] < 1e-6).all() and (px[covered, 2] > 0.9).all()  # only the jacket's blue
    # the same scene untagged is plain ray tracing: the shirt's red shows where it pokes out
    for name in ("Shirt", "Jacket"):
        bpy.data.objects[name].deformrt.role = "NONE"
    px = _render(scene, tmp_path)
    assert (px[..., 0] > 0.5).mean() > 0.05

"""DeformRT Layered: a render engine that shows garments in layer order without moving them
(seed 4.4, the image-space mode), shaded Whitted-style by core.whitted.

Objects tagged as body or garments are layered (global normals from the stored
``deformrt_global_normal`` attribute, else each mesh's own normals); everything else is drawn
as it is. Materials come from the Principled BSDF: base colour, metallic as mirror,
transmission and IOR, roughness as Blinn-Phong shininess. Sun and point lights. The colour
is irradiance times albedo (no 1/pi), so a white surface facing a sun of strength 1 is 1.
"""

import bpy
import numpy as np

from ..core.layered_trace import LayeredScene
from ..core.whitted import Light, Material, camera_rays, render
from . import mesh_io
from .layer_resolve import GLOBAL_NORMAL_ATTRIBUTE


def _material(obj):
    mat = obj.active_material
    bsdf = mat.node_tree.nodes.get("Principled BSDF") if mat is not None and mat.use_nodes else None
    if bsdf is None:
        colour = tuple(mat.diffuse_color[:3]) if mat is not None else tuple(obj.color[:3])
        return Material(colour=colour)
    value = lambda name: bsdf.inputs[name].default_value  # noqa: E731
    rough = float(value("Roughness"))
    return Material(colour=tuple(value("Base Color")[:3]), specular=0.5 * float(value("Specular IOR Level")),
                    shininess=2.0 / max(rough**4, 1e-4), mirror=float(value("Metallic")),
                    transmission=float(value("Transmission Weight")), ior=float(value("IOR")))


def _lights(depsgraph):
    out = []
    for inst in depsgraph.object_instances:
        obj = inst.object
        if obj.type != "LIGHT":
            continue
        m = np.array(inst.matrix_world)
        colour = tuple(np.array(obj.data.color) * obj.data.energy)
        if obj.data.type == "SUN":
            out.append(Light("SUN", tuple(-m[:3, 2]), colour))
        elif obj.data.type == "POINT":
            # a point lamp of P watts sends P / (4 pi) per steradian
            out.append(Light("POINT", tuple(m[:3, 3]), tuple(np.array(colour) / (4 * np.pi))))
    return out


def scene_arrays(depsgraph):
    """(LayeredScene, materials, object names) of the visible meshes, in world space."""
    objects, layers, normals, materials, names = [], [], [], [], []
    for obj in depsgraph.scene.objects:
        if obj.type != "MESH" or not obj.visible_get():
            continue
        a = mesh_io.read_mesh(obj, depsgraph)
        if not len(a.triangles):
            continue
        role = obj.deformrt.role
        objects.append((a.vertices, a.triangles))
        layers.append(None if role == "NONE" else (0 if role == "BODY" else obj.deformrt.layer))
        n = mesh_io.read_point_vectors(obj, GLOBAL_NORMAL_ATTRIBUTE, depsgraph) if role != "NONE" else None
        # stored in object space; normals turn with the inverse transpose
        normals.append(None if n is None or len(n) != len(a.vertices) else n @ np.linalg.inv(a.matrix_world[:3, :3]))
        materials.append(_material(obj))
        names.append(obj.name)
    settings = depsgraph.scene.deformrt
    probe = settings.probe_distance if settings.probe_distance > 0 else 0.05
    return LayeredScene(objects, layers, normals, probe_distance=probe, offset=settings.offset), materials, names


def vertical_fov(cam, width, height):
    """The camera's vertical field of view for a width x height image (sensor fit as Blender)."""
    if cam.type != "PERSP":
        raise ValueError(f"DeformRT Layered renders perspective cameras only, not {cam.type.lower()}")
    fit = cam.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if width >= height else "VERTICAL"
        half = cam.sensor_width / (2 * cam.lens)  # AUTO fits the sensor width to the longer side
    else:
        half = (cam.sensor_width if fit == "HORIZONTAL" else cam.sensor_height) / (2 * cam.lens)
    if fit == "HORIZONTAL":
        half *= height / width
    return 2 * np.arctan(half)


class DEFORMRT_RE_layered(bpy.types.RenderEngine):
    bl_idname = "DEFORMRT_LAYERED"
    bl_label = "DeformRT Layered"
    bl_use_preview = False

    def render(self, depsgraph):
        scene = depsgraph.scene
        scale = scene.render.resolution_percentage / 100.0
        w, h = int(scene.render.resolution_x * scale), int(scene.render.resolution_y * scale)
        result = self.begin_result(0, 0, w, h)
        rgba = np.zeros((h, w, 4), np.float32)
        cam = scene.camera
        if cam is None or cam.type != "CAMERA" or cam.data.type != "PERSP":
            self.report({"ERROR"}, "DeformRT Layered needs a perspective scene camera")
        else:
            self.update_stats("", "DeformRT: reading the scene")
            layered, materials, _ = scene_arrays(depsgraph)
            o, d = camera_rays(np.array(cam.matrix_world), vertical_fov(cam.data, w, h), w, h)
            world = scene.world
            bg = (0.05, 0.05, 0.05)
            if world is not None and world.use_nodes and "Background" in world.node_tree.nodes:
                node = world.node_tree.nodes["Background"]
                bg = tuple(np.array(node.inputs["Color"].default_value[:3]) * node.inputs["Strength"].default_value)
            self.update_stats("", "DeformRT: tracing")
            img = render(layered, materials, _lights(depsgraph), o, d, background=bg, ambient=0.0)
            rgba[..., :3] = img.colour.reshape(h, w, 3)
            rgba[..., 3] = 1.0
        # Blender's rows run bottom-up
        result.layers[0].passes["Combined"].rect = rgba[::-1].reshape(-1, 4)
        self.end_result(result)


def _panels():
    """Blender's own panels that work with this engine (render size, output, camera, lights)."""
    keep = {"RENDER_PT_format", "RENDER_PT_output", "RENDER_PT_dimensions", "DATA_PT_lens", "DATA_PT_camera",
            "DATA_PT_light", "DATA_PT_EEVEE_light", "MATERIAL_PT_preview", "EEVEE_MATERIAL_PT_surface",
            "WORLD_PT_context_world", "EEVEE_WORLD_PT_surface"}
    return [getattr(bpy.types, name) for name in keep if hasattr(bpy.types, name)]


def register():
    bpy.utils.register_class(DEFORMRT_RE_layered)
    for panel in _panels():
        panel.COMPAT_ENGINES.add(DEFORMRT_RE_layered.bl_idname)


def unregister():
    for panel in _panels():
        panel.COMPAT_ENGINES.discard(DEFORMRT_RE_layered.bl_idname)
    bpy.utils.unregister_class(DEFORMRT_RE_layered)

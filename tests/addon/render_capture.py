"""What F12 renders, read from the render's own depsgraph: a minimal render engine that records the
evaluated meshes Blender hands to a render (render levels, render-only modifiers), the way
Cycles and Eevee receive them, without shading a pixel."""

import bpy
import numpy as np

_captured = {}


class CaptureEngine(bpy.types.RenderEngine):
    bl_idname = "DEFORMRT_TEST_CAPTURE"
    bl_label = "Capture (tests)"

    def render(self, depsgraph):
        _captured.clear()
        for inst in depsgraph.object_instances:
            obj = inst.object
            if obj.type != "MESH" or inst.is_instance:
                continue
            mesh = obj.to_mesh()
            try:
                mesh.calc_loop_triangles()
                co = np.empty(len(mesh.vertices) * 3)
                mesh.vertices.foreach_get("co", co)
                tris = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
                mesh.loop_triangles.foreach_get("vertices", tris)
            finally:
                obj.to_mesh_clear()
            mw = np.array(obj.matrix_world)
            _captured[obj.original.name] = (co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3], tris.reshape(-1, 3))
        self.end_result(self.begin_result(0, 0, 4, 4))


def rendered_meshes(scene) -> dict:
    """{object name: (world vertices, triangles)} of every mesh F12 would render now."""
    bpy.utils.register_class(CaptureEngine)
    engine, size = scene.render.engine, (scene.render.resolution_x, scene.render.resolution_y,
                                         scene.render.resolution_percentage)
    scene.render.engine = CaptureEngine.bl_idname
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 4, 4, 100
    try:
        bpy.ops.render.render()
    finally:
        scene.render.engine = engine
        scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = size
        bpy.utils.unregister_class(CaptureEngine)
    return dict(_captured)

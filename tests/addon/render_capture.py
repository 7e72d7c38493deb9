"""What F12 renders, read from the render's own depsgraph: a minimal render engine that records the
evaluated meshes Blender hands to a render (render levels, render-only modifiers), the way
Cycles and Eevee receive them, without shading a pixel. Also what the viewport evaluates, and the
modifier stacks artists put on garments (tests and bench.render_modifiers)."""

import bmesh
import bpy
import numpy as np


def overlapping_pairs(a, b) -> int:
    """Intersecting triangle pairs between two meshes ((vertices, triangles) each) by mathutils' BVH,
    independent of core.metrics."""
    from mathutils.bvhtree import BVHTree

    ta = BVHTree.FromPolygons(a[0].tolist(), a[1].tolist(), all_triangles=True)
    tb = BVHTree.FromPolygons(b[0].tolist(), b[1].tolist(), all_triangles=True)
    return len(ta.overlap(tb))


def without_result(obj):
    """The object's evaluated vertices with its DeformRT modifier switched off (then on again)."""
    mod = obj.modifiers["DeformRT"]
    mod.show_viewport = False
    plain = evaluated_points(obj)
    mod.show_viewport = True
    return plain


def evaluated_points(obj):
    """Object-space vertices of what the viewport evaluates for ``obj`` now."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    try:
        co = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", co)
    finally:
        ev.to_mesh_clear()
    return co.reshape(-1, 3)


def _halve(obj):
    """Keep the x >= 0 half of the mesh (a garment modelled for a Mirror modifier)."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.delete(bm, geom=[v for v in bm.verts if v.co.x < -1e-6], context="VERTS")
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()


def add_stack(obj, stack, solidify_m=None, bevel_m=None):
    """Append the named modifiers in order: "subdivision" (viewport 1, render 2, as Ctrl+1 adds it),
    "solidify" (grown inward, Blender's default), "solidify_out" (grown outward), "mirror" (the mesh
    halved first), "bevel"; thickness and width are Blender's defaults unless given."""
    for kind in stack:
        if kind == "subdivision":
            mod = obj.modifiers.new("Subdivision", "SUBSURF")
            mod.levels, mod.render_levels = 1, 2
        elif kind in ("solidify", "solidify_out"):
            mod = obj.modifiers.new("Solidify", "SOLIDIFY")
            mod.offset = 1.0 if kind == "solidify_out" else -1.0
            if solidify_m is not None:
                mod.thickness = solidify_m
        elif kind == "mirror":
            _halve(obj)
            mod = obj.modifiers.new("Mirror", "MIRROR")
            mod.use_clip = mod.use_mirror_merge = True
        elif kind == "bevel":
            mod = obj.modifiers.new("Bevel", "BEVEL")
            if bevel_m is not None:
                mod.width = bevel_m
        else:
            raise ValueError(f"unknown modifier kind {kind!r}")

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

"""Resolve, clear and bake the layered garments of the scene."""

import json

import bpy

from ..addon import layer_resolve, results, scene_roles


def _fail(op, exc):
    op.report({"ERROR"}, str(exc))
    return {"CANCELLED"}


class DEFORMRT_OT_resolve_layers(bpy.types.Operator):
    """Move lower garments behind higher ones and hide what still pokes through (non-destructive:
    a DeformRT modifier on each garment; its mesh is not changed)"""

    bl_idname = "deformrt.resolve_layers"
    bl_label = "Resolve Layers"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if context.scene is None or not scene_roles.garments(context.scene):
            cls.poll_message_set("Tag a body and at least two garments first")
            return False
        return True

    def execute(self, context):
        wm = context.window_manager
        wm.progress_begin(0, 3)
        try:
            summary = layer_resolve.resolve_scene(context.scene, progress=wm.progress_update)
        except (ValueError, RuntimeError) as exc:
            return _fail(self, exc)
        finally:
            wm.progress_end()
        context.scene.deformrt.last_report = json.dumps({
            "kind": "resolve", "message": summary.message(), "seconds": summary.seconds,
            "garments": summary.garments, "max_move": summary.max_move, "faces_hidden": summary.faces_hidden,
            "parts": summary.parts_source, "skirts": [summary.garments[i] for i in summary.stats["skirts"]],
            "far_from_body": summary.stats["vertices_far_from_body"],
            "stages_s": {k: v for k, v in summary.stats.items() if k.endswith("_s")}})
        self.report({"INFO"}, summary.message())
        return {"FINISHED"}


class DEFORMRT_OT_auto_segment(bpy.types.Operator):
    """Split the body into parts (from its rig's vertex groups) and give every garment the
    part of the body under it, as DRT_<part> vertex groups you can repaint; the resolve
    follows them"""

    bl_idname = "deformrt.auto_segment"
    bl_label = "Auto-Segment"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if context.scene is None or not scene_roles.bodies(context.scene):
            cls.poll_message_set("Tag a body first")
            return False
        return True

    def execute(self, context):
        try:
            message = layer_resolve.auto_segment(context.scene)
        except (ValueError, RuntimeError) as exc:
            return _fail(self, exc)
        self.report({"INFO"}, message)
        return {"FINISHED"}


class DEFORMRT_OT_clear_results(bpy.types.Operator):
    """Remove the layering result from every garment (they render as fitted again)"""

    bl_idname = "deformrt.clear_results"
    bl_label = "Clear Results"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        count = layer_resolve.clear_scene(context.scene)
        context.scene.deformrt.last_report = ""
        self.report({"INFO"}, f"Cleared the result of {count} garment(s)" if count else "No results to clear")
        return {"FINISHED"}


class DEFORMRT_OT_bake_results(bpy.types.Operator):
    """Write what the body and garments render now as plain meshes into the "DeformRT Baked"
    collection, for export (glTF, FBX, OBJ, Alembic)"""

    bl_idname = "deformrt.bake_results"
    bl_label = "Bake Meshes"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if context.scene is None or not scene_roles.garments(context.scene):
            cls.poll_message_set("Tag a body and garments first")
            return False
        return True

    def execute(self, context):
        scene = context.scene
        try:
            body, garments = layer_resolve.layered_objects(scene)
        except ValueError as exc:
            return _fail(self, exc)
        made = results.bake(scene, [body, *garments], context.evaluated_depsgraph_get())
        unresolved = [g.name for g in garments if results.result_modifier(g) is None]
        note = f" ({', '.join(unresolved)} not resolved: baked as fitted)" if unresolved else ""
        self.report({"INFO"}, f"Baked {len(made)} meshes into '{results.BAKED_COLLECTION}' (hidden: show it in "
                              f"the Outliner to export){note}")
        return {"FINISHED"}


CLASSES = (DEFORMRT_OT_resolve_layers, DEFORMRT_OT_auto_segment, DEFORMRT_OT_clear_results,
           DEFORMRT_OT_bake_results)

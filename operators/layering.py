"""Resolve, clear and bake the layered garments of the scene."""

import bpy

from ..addon.io import blender_versions
from ..addon.layers import frame_bake, inspect_layers, part_tools, report, resolve_job, results, scene_roles
from ..addon.layers.scene_read import layered_objects
from .base import BackgroundOperator, DeformRTOperator, SteppedOperator


class _NeedsGarments:
    @classmethod
    def unavailable(cls, context):
        if context.scene is None or not scene_roles.garments(context.scene):
            return "Tag a body and garments first"
        return None


class DEFORMRT_OT_resolve_layers(BackgroundOperator, bpy.types.Operator):
    """Move lower garments behind higher ones and hide what still shows through, without changing the meshes"""

    bl_idname = "deformrt.resolve_layers"
    bl_label = "Resolve Layers"
    bl_options = {"REGISTER", "UNDO"}
    status = "DeformRT: resolving layers (Esc to cancel)"
    cancelled_message = "Resolve cancelled: the garments are unchanged"

    @classmethod
    def unavailable(cls, context):
        if context.scene is None or not scene_roles.garments(context.scene):
            return "Tag a body and at least two garments first"
        return None

    def prepare(self, context):
        return resolve_job.prepare_resolve(context.scene)

    def work(self, job, progress, stop):
        return resolve_job.compute_resolve(job)

    def finish(self, context, job, result):
        try:
            summary = resolve_job.finish_resolve(context.scene, job, result)
        except ReferenceError:
            return self.fail(RuntimeError("A garment was deleted while resolving: nothing written"))
        report.write(context.scene, summary.report())
        self.report({"INFO"}, summary.message())
        return {"FINISHED"}


class DEFORMRT_OT_add_part_probe(DeformRTOperator, bpy.types.Operator):
    """Set how far under one body part's cloth DeformRT looks for the garment worn over it"""

    bl_idname = "deformrt.add_part_probe"
    bl_label = "Reach for One Part"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        settings = context.scene.deformrt
        last = report.read(context.scene)
        used = last.probe_by_part if last is not None else {}
        taken = {p.part for p in settings.part_probes}
        free = [p for p in (used or {"torso": None}) if p not in taken] or ["torso"]
        item = settings.part_probes.add()
        item.part = free[0]
        if used.get(free[0]):
            item.distance = used[free[0]]
        return {"FINISHED"}


class DEFORMRT_OT_remove_part_probe(DeformRTOperator, bpy.types.Operator):
    """Let this part's reach follow the body again"""

    bl_idname = "deformrt.remove_part_probe"
    bl_label = "Remove Reach for One Part"
    bl_options = {"REGISTER", "UNDO"}

    index: bpy.props.IntProperty(default=0, min=0)

    def execute(self, context):
        probes = context.scene.deformrt.part_probes
        if self.index >= len(probes):
            return {"CANCELLED"}
        probes.remove(self.index)
        return {"FINISHED"}


class DEFORMRT_OT_auto_segment(DeformRTOperator, bpy.types.Operator):
    """Split the body into parts from its rig and give each garment the part under it as editable vertex groups"""

    bl_idname = "deformrt.auto_segment"
    bl_label = "Auto-Segment"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        if context.scene is None or not scene_roles.bodies(context.scene):
            return "Tag a body first"
        return None

    def execute(self, context):
        try:
            message = part_tools.auto_segment(context.scene)
        except (ValueError, RuntimeError) as exc:
            return self.fail(exc)
        self.report({"INFO"}, message)
        return {"FINISHED"}


class DEFORMRT_OT_transfer_normals(_NeedsGarments, DeformRTOperator, bpy.types.Operator):
    """Store on each garment which way is out from the body, the way the resolve moves it; edit it to steer the fit"""

    bl_idname = "deformrt.transfer_normals"
    bl_label = "Transfer Global Normals"
    bl_options = {"REGISTER", "UNDO"}

    remove: bpy.props.BoolProperty(name="Remove", description="Remove the stored directions instead (as Remove "
                                   "Global Normals)", default=False, options={"HIDDEN"})

    def execute(self, context):
        if self.remove:
            return DEFORMRT_OT_remove_normals.execute(self, context)
        try:
            message = part_tools.transfer_normals(context.scene)
        except (ValueError, RuntimeError) as exc:
            return self.fail(exc)
        self.report({"INFO"}, message)
        return {"FINISHED"}


class DEFORMRT_OT_remove_normals(_NeedsGarments, DeformRTOperator, bpy.types.Operator):
    """Remove the stored outward directions: the resolve reads them from the body again"""

    bl_idname = "deformrt.remove_normals"
    bl_label = "Remove Global Normals"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        n = part_tools.remove_normals(context.scene)
        self.report({"INFO"}, f"Removed the stored directions of {n} garments" if n else "No stored directions")
        return {"FINISHED"}


class DEFORMRT_OT_clear_results(DeformRTOperator, bpy.types.Operator):
    """Remove the layering result from every garment (they render as fitted again)"""

    bl_idname = "deformrt.clear_results"
    bl_label = "Clear Results"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        count = resolve_job.clear_scene(context.scene)
        report.write(context.scene, None)
        self.report({"INFO"}, f"Cleared the result of {count} garment(s)" if count else "No results to clear")
        return {"FINISHED"}


class DEFORMRT_OT_bake_results(_NeedsGarments, DeformRTOperator, bpy.types.Operator):
    """Copy what the body and garments render now as plain meshes into the DeformRT Baked collection, for export"""

    bl_idname = "deformrt.bake_results"
    bl_label = "Bake Meshes"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        scene = context.scene
        try:
            body, garments = layered_objects(scene)
        except ValueError as exc:
            return self.fail(exc)
        made = results.bake(scene, [body, *garments], context.evaluated_depsgraph_get())
        unresolved = [g.name for g in garments if results.result_modifier(g) is None]
        note = f" ({', '.join(unresolved)} not resolved: baked as fitted)" if unresolved else ""
        self.report({"INFO"}, f"Baked {len(made)} meshes into '{results.BAKED_COLLECTION}' (hidden: show it in "
                              f"the Outliner to export){note}")
        return {"FINISHED"}


class DEFORMRT_OT_inspect_layers(_NeedsGarments, DeformRTOperator, bpy.types.Operator):
    """Measure crossing edges, poke-through, moves and stretch of the layers as fitted and as shown now"""

    bl_idname = "deformrt.inspect_layers"
    bl_label = "Inspect"
    bl_options = {"REGISTER"}

    def execute(self, context):
        try:
            found = inspect_layers.inspect_scene(context.scene)
        except (ValueError, RuntimeError) as exc:
            return self.fail(exc)
        report.write(context.scene, found)
        self.report({"INFO"}, found.message)
        return {"FINISHED"}


class DEFORMRT_OT_bake_frames(_NeedsGarments, SteppedOperator, bpy.types.Operator):
    """Resolve every frame of a range and write body and garments to an Alembic cache that needs no DeformRT"""

    bl_idname = "deformrt.bake_frames"
    bl_label = "Bake Frames"
    bl_options = {"REGISTER", "UNDO"}
    status = "DeformRT: resolving {total} frames to bake (Esc to stop)"

    frame_start: bpy.props.IntProperty(name="Start", default=1, min=0)
    frame_end: bpy.props.IntProperty(name="End", default=250, min=0)
    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH", default="//deformrt_layers.abc",
                                       options=blender_versions.path_options())

    # set by invoke: the bake asked for in the UI runs frame by frame under a timer (Esc stops it);
    # a script's call blocks, as a script expects
    in_ui: bpy.props.BoolProperty(default=False, options={"HIDDEN", "SKIP_SAVE"})

    @property
    def headless(self) -> bool:
        return not self.in_ui

    def invoke(self, context, _event):
        self.frame_start, self.frame_end = context.scene.frame_start, context.scene.frame_end
        self.in_ui = context.window is not None and not bpy.app.background
        return context.window_manager.invoke_props_dialog(self)

    def start(self, context):
        return frame_bake.start_bake(context.scene, self.frame_start, self.frame_end, self.filepath,
                                     context.evaluated_depsgraph_get())


CLASSES = (DEFORMRT_OT_resolve_layers, DEFORMRT_OT_add_part_probe, DEFORMRT_OT_remove_part_probe,
           DEFORMRT_OT_auto_segment, DEFORMRT_OT_transfer_normals, DEFORMRT_OT_remove_normals,
           DEFORMRT_OT_clear_results, DEFORMRT_OT_bake_results, DEFORMRT_OT_bake_frames, DEFORMRT_OT_inspect_layers)

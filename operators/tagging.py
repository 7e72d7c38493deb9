"""Tag objects as body or garment and order the garment layers."""

import bpy
from bpy.props import EnumProperty, StringProperty

from ..addon.layers import scene_roles
from .base import DeformRTOperator


def _selected_meshes(context):
    return [o for o in context.selected_objects if o.type == "MESH"]


class DEFORMRT_OT_tag_body(DeformRTOperator, bpy.types.Operator):
    """Make the active mesh the body the garments are worn on (layer 0)"""

    bl_idname = "deformrt.tag_body"
    bl_label = "Tag as Body"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        obj = context.active_object
        return "Select a mesh object to use as the body" if obj is None or obj.type != "MESH" else None

    def execute(self, context):
        obj = context.active_object
        previous = [o for o in scene_roles.bodies(context.scene) if o is not obj]
        for o in previous:
            o.deformrt.role = "NONE"
        obj.deformrt.role = "BODY"
        obj.deformrt.layer = 0
        note = f" (was: {', '.join(o.name for o in previous)})" if previous else ""
        self.report({"INFO"}, f"Body: {obj.name}{note}")
        return {"FINISHED"}


class DEFORMRT_OT_tag_garments(DeformRTOperator, bpy.types.Operator):
    """Make the selected meshes garments on new outer layers, ordered by kind (underwear to coat)"""

    bl_idname = "deformrt.tag_garments"
    bl_label = "Tag as Garments"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        if not _selected_meshes(context):
            return "Select one or more mesh objects"
        return None

    def execute(self, context):
        new = [o for o in _selected_meshes(context) if o.deformrt.role != "GARMENT"]
        skipped = len(_selected_meshes(context)) - len(new)
        layer = scene_roles.top_layer(context.scene)
        for obj in sorted(new, key=lambda o: (scene_roles.kind_rank(o.name), o.name)):
            layer += 1
            obj.deformrt.role = "GARMENT"
            obj.deformrt.layer = layer
        msg = f"Tagged {len(new)} garment(s)"
        if skipped:
            msg += f"; {skipped} already garments kept their layers"
        self.report({"INFO"}, msg)
        return {"FINISHED"}


class DEFORMRT_OT_tag_makehuman(DeformRTOperator, bpy.types.Operator):
    """Tag an MPFB2 character: its body or proxy as the body, its clothes as garments in MakeHuman's order"""

    bl_idname = "deformrt.tag_makehuman"
    bl_label = "Tag MakeHuman Character"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        if context.scene is None or not any(scene_roles.mpfb_type(o) in scene_roles.BODY_TYPES
                                                 for o in context.scene.objects):
            return "No MPFB2 (MakeHuman) character in the scene"
        return None

    def execute(self, context):
        found = scene_roles.mpfb_character(context.scene, near=context.active_object)
        if found is None:
            return self.fail(ValueError("More than one MakeHuman character: select one of its objects first"))
        body, clothes, order = found
        if not clothes:
            return self.fail(ValueError(f"{body.name} wears no MakeHuman clothes: nothing to layer"))
        untagged = []
        for obj in context.scene.objects:  # one character's layers: other tags would mix in
            if obj.deformrt.role != "NONE" and obj is not body and obj not in clothes:
                obj.deformrt.role = "NONE"
                untagged.append(obj.name)
        body.deformrt.role, body.deformrt.layer = "BODY", 0
        for layer, obj in enumerate(clothes, start=1):
            obj.deformrt.role, obj.deformrt.layer = "GARMENT", layer
        how = "MakeHuman's z_depth" if order == "z_depth" else "kind (no z_depth on every piece)"
        said = f"Body: {body.name}; layers by {how}: " + " < ".join(o.name for o in clothes)
        if untagged:  # a scene resolves one character at a time: say whose tags went
            said += f"; untagged (one character is layered at a time): {', '.join(untagged)}"
        self.report({"INFO"}, said)
        return {"FINISHED"}


class DEFORMRT_OT_clear_role(DeformRTOperator, bpy.types.Operator):
    """Take the selected objects out of garment layering"""

    bl_idname = "deformrt.clear_role"
    bl_label = "Clear Role"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        if not any(scene_roles.is_tagged_mesh(o) for o in context.selected_objects):
            return "No selected object is tagged as body or garment"
        return None

    def execute(self, context):
        cleared = [o for o in context.selected_objects if scene_roles.is_tagged_mesh(o)]
        for obj in cleared:
            obj.deformrt.role = "NONE"
            obj.deformrt.layer = 0
        self.report({"INFO"}, f"Cleared {len(cleared)} object(s)")
        return {"FINISHED"}


class DEFORMRT_OT_order_by_kind(DeformRTOperator, bpy.types.Operator):
    """Re-order all garments by kind, from underwear to coats; garments of one kind keep their order"""

    bl_idname = "deformrt.order_by_kind"
    bl_label = "Order by Kind"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        if context.scene is None or len(scene_roles.garments(context.scene)) < 2:
            return "Tag at least two garments"
        return None

    def execute(self, context):
        garments = scene_roles.garments(context.scene)
        ordered = sorted(garments, key=lambda o: scene_roles.kind_rank(o.name))  # stable: ties keep layers
        for layer, obj in enumerate(ordered, start=1):
            obj.deformrt.layer = layer
        self.report({"INFO"}, "Layers: " + " < ".join(o.name for o in ordered))
        return {"FINISHED"}


class DEFORMRT_OT_move_layer(DeformRTOperator, bpy.types.Operator):
    """Move a garment one layer further out (up) or in (down), swapping with the garment there"""

    bl_idname = "deformrt.move_layer"
    bl_label = "Move Garment Layer"
    bl_options = {"REGISTER", "UNDO"}

    object_name: StringProperty(name="Object", description="Garment to move; the active object when empty")
    direction: EnumProperty(
        name="Direction",
        items=(("UP", "Up", "Worn further out"), ("DOWN", "Down", "Worn closer to the body")),
        default="UP",
    )

    def _target(self, context):
        obj = bpy.data.objects.get(self.object_name) if self.object_name else context.active_object
        return obj if obj is not None and obj.type == "MESH" and obj.deformrt.role == "GARMENT" else None

    @classmethod
    def unavailable(cls, context):
        return "No scene" if context.scene is None else None

    def execute(self, context):
        obj = self._target(context)
        if obj is None:
            return self.fail(ValueError("Nothing to move: pick a garment (role Garment) first"))
        step = 1 if self.direction == "UP" else -1
        old = obj.deformrt.layer
        new = old + step
        if new < 1:
            self.report({"WARNING"}, f"{obj.name} is already the innermost garment (layer 1)")
            return {"CANCELLED"}
        for other in scene_roles.garments(context.scene):
            if other is not obj and other.deformrt.layer == new:
                other.deformrt.layer = old
        obj.deformrt.layer = new
        self.report({"INFO"}, f"{obj.name}: layer {old} -> {new}")
        return {"FINISHED"}


CLASSES = (DEFORMRT_OT_tag_body, DEFORMRT_OT_tag_garments, DEFORMRT_OT_tag_makehuman, DEFORMRT_OT_clear_role,
           DEFORMRT_OT_order_by_kind, DEFORMRT_OT_move_layer)

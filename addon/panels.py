"""The DeformRT sidebar tab in the 3D View."""

import bpy

from . import scene_roles


class DEFORMRT_PT_layers(bpy.types.Panel):
    bl_idname = "DEFORMRT_PT_layers"
    bl_label = "Layers"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "DeformRT"

    def draw(self, context):
        layout = self.layout
        scene = context.scene
        row = layout.row(align=True)
        row.operator("deformrt.tag_body", icon="OUTLINER_OB_ARMATURE")
        row.operator("deformrt.tag_garments", icon="MOD_CLOTH")
        layout.operator("deformrt.clear_role", icon="X")

        body = scene_roles.bodies(scene)
        garments = scene_roles.garments(scene)
        if not body and not garments:
            layout.label(text="Tag a body and its garments to begin", icon="INFO")
            return
        box = layout.box()
        # Outermost first, the way the garments are seen from outside.
        for obj in reversed(garments):
            row = box.row(align=True)
            row.label(text=obj.name, icon="MOD_CLOTH")
            row.label(text=f"layer {obj.deformrt.layer}")
            up = row.operator("deformrt.move_layer", text="", icon="TRIA_UP")
            up.object_name, up.direction = obj.name, "UP"
            down = row.operator("deformrt.move_layer", text="", icon="TRIA_DOWN")
            down.object_name, down.direction = obj.name, "DOWN"
        for obj in body:
            box.row().label(text=f"{obj.name}  (body)", icon="OUTLINER_OB_ARMATURE")
        if not body:
            layout.label(text="No body: tag the figure as Body", icon="ERROR")
        elif len(body) > 1:
            layout.label(text="More than one body: keep one", icon="ERROR")
        layers = [o.deformrt.layer for o in garments]
        if len(set(layers)) != len(layers):
            layout.label(text="Two garments share a layer", icon="ERROR")


CLASSES = (DEFORMRT_PT_layers,)

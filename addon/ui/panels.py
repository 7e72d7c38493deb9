"""The DeformRT sidebar tab in the 3D View."""

import textwrap

import bpy

from ..io import scene_units
from ..jellyfish import animal as jellyfish
from ..layers import report, scene_roles, staleness


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
        if any(scene_roles.mpfb_type(o) == "Basemesh" for o in scene.objects):
            layout.operator("deformrt.tag_makehuman", icon="COMMUNITY")
        row = layout.row(align=True)
        row.operator("deformrt.clear_role", icon="X")
        row.operator("deformrt.order_by_kind", icon="SORTSIZE")

        body = scene_roles.bodies(scene)
        garments = scene_roles.garments(scene)
        if not body and not garments:
            layout.label(text="Tag a body and its garments to begin", icon="INFO")
            return
        box = layout.box()
        # Outermost first, the way the garments are seen from outside.
        stale = dict(staleness.stale_garments(scene))
        for obj in reversed(garments):
            row = box.row(align=True)
            row.label(text=obj.name, icon="ERROR" if obj in stale else "MOD_CLOTH")
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
        if stale:
            col = layout.box().column(align=True)
            col.label(text="Out of date, shown as fitted:", icon="ERROR")
            for reason in stale.values():
                col.label(text=reason)
            col.label(text="Resolve Layers to update them")


class DEFORMRT_PT_resolve(bpy.types.Panel):
    bl_idname = "DEFORMRT_PT_resolve"
    bl_label = "Resolve"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "DeformRT"

    def draw(self, context):
        layout = self.layout
        settings = context.scene.deformrt
        layout.use_property_split = True
        layout.use_property_decorate = False
        row = layout.row(align=True)
        row.prop(settings, "scheme")
        row.operator("deformrt.auto_segment", text="Auto-Segment", icon="GROUP_VERTEX")
        row = layout.row(align=True)
        row.operator("deformrt.transfer_normals", icon="NORMALS_VERTEX")
        row.operator("deformrt.remove_normals", text="Remove", icon="X")
        for name in ("offset", "probe_distance"):  # 0 means "found from the body": say so
            row = layout.row(align=True)
            row.prop(settings, name)
            if getattr(settings, name) == 0:
                row.label(text="Auto")
        if settings.scheme != "NONE":
            col = layout.column(align=True)
            for k, item in enumerate(settings.part_probes):
                row = col.row(align=True)
                row.prop(item, "part", text="")
                row.prop(item, "distance", text="")
                row.operator("deformrt.remove_part_probe", text="", icon="X").index = k
            col.operator("deformrt.add_part_probe", text="Reach for One Part", icon="ADD")
        layout.prop(settings, "boundary_pass")
        layout.prop(settings, "body_guard")
        layout.prop(settings, "outer_room")
        layout.prop(settings, "remove_hidden")
        layout.prop(settings, "hide_covered_skin")
        # everyday work first; exports (long) apart; the one that removes work last, set off
        row = layout.row(align=True)
        row.scale_y = 1.3
        row.operator("deformrt.resolve_layers", icon="MOD_CLOTH")
        row.operator("deformrt.inspect_layers", icon="VIEWZOOM")
        layout.prop(settings, "resolve_on_frame_change")
        if settings.resolve_on_frame_change:
            layout.prop(settings, "playback_in_background")
            if not settings.playback_in_background:
                layout.prop(settings, "playback_step")
        lines = report_lines(report.read(context.scene), scene_units.formatter(context.scene))
        if lines:
            box = layout.box().column(align=True)
            width = max(24, int(context.region.width / 7)) if context.region is not None else 60
            for line in lines:  # the sidebar clips a label: long lines are wrapped to its width
                for piece in textwrap.wrap(line, width) or [""]:
                    box.label(text=piece)
        box = layout.box()
        box.label(text="Export", icon="EXPORT")
        row = box.row(align=True)
        row.operator("deformrt.bake_results", icon="MESH_DATA")
        row.operator("deformrt.bake_frames", icon="RENDER_ANIMATION")
        layout.separator()
        layout.operator("deformrt.clear_results", icon="TRASH")


class DEFORMRT_PT_jellyfish(bpy.types.Panel):
    bl_idname = "DEFORMRT_PT_jellyfish"
    bl_label = "Jellyfish"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Jellyfish"  # a tab of its own: it has nothing to do with the garments

    def draw(self, context):
        layout = self.layout
        layout.operator("deformrt.add_jellyfish", icon="ADD")
        bell = jellyfish.jellyfish_of(context.active_object)
        if bell is None:
            layout.label(text="Select a jellyfish to optimize and bake it", icon="INFO")
            return
        layout.operator("deformrt.optimize_jellyfish", icon="PLAY")
        line = jellyfish.stroke_line(bell)
        if line is not None:
            layout.label(text=line)
        else:
            layout.label(text="No optimized stroke yet: baking uses the default one", icon="INFO")
        layout.operator("deformrt.bake_jellyfish", icon="ANIM")


def report_lines(last, length=lambda v: f"{100 * v:.0f} cm") -> list:
    """What the panel says of a LayersReport (None: nothing), lengths by ``length`` (the scene's
    units); a report whose entries are not what this version writes (a crafted or damaged file)
    is said to be damaged, not raised on every redraw."""
    try:
        return _report_lines(last, length)
    except (TypeError, ValueError, AttributeError):
        return [report.DAMAGED.message]


def _report_lines(last, length) -> list:
    if last is None:
        return []
    lines = [last.message]
    if last.skirts:
        lines.append("Skirts: " + ", ".join(last.skirts))
    if last.far_from_body:
        # the thesis' known limit (4.6): cloth far from its body part is not probed
        lines.append(f"{last.far_from_body} garment points farther from the body than the Reach still showed "
                     "through")
    if last.probe_by_part:
        lines.append("Reach: " + ", ".join(f"{p.replace('_', ' ')} {length(float(d))}"
                                                 for p, d in last.probe_by_part.items()))
    for a, b, n in last.still_crossing:
        # the thesis' known limits (4.6): what the method cannot untangle
        lines.append(f"{a} and {b} still cross at {n} edges: interlocking, self-intersecting or far from the body?")
    for name in last.inward:
        lines.append(f"{name}: faces point inward (Mesh > Normals > Recalculate Outside)")
    return lines


CLASSES = (DEFORMRT_PT_layers, DEFORMRT_PT_resolve, DEFORMRT_PT_jellyfish)

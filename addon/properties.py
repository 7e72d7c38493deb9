"""Per-object and per-scene DeformRT settings (the names other tools rely on: see NOTES.md)."""

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, PointerProperty

ROLE_ITEMS = (
    ("NONE", "None", "Not part of garment layering"),
    ("BODY", "Body", "The figure the garments are worn on (layer 0)"),
    ("GARMENT", "Garment", "A garment; a higher layer is worn further out"),
)


class DeformRTObjectProperties(bpy.types.PropertyGroup):
    role: EnumProperty(name="Role", items=ROLE_ITEMS, default="NONE")
    layer: IntProperty(
        name="Layer",
        description="Body is 0; a garment on a higher layer is worn over the lower ones",
        default=0,
        min=0,
        soft_max=20,
    )


class DeformRTSceneProperties(bpy.types.PropertyGroup):
    resolve_on_frame_change: BoolProperty(
        name="Resolve on Frame Change",
        description="Re-run the layer correction whenever the frame changes (playback, rendering an animation)",
        default=False,
    )


CLASSES = (DeformRTObjectProperties, DeformRTSceneProperties)


def attach():
    bpy.types.Object.deformrt = PointerProperty(type=DeformRTObjectProperties)
    bpy.types.Scene.deformrt = PointerProperty(type=DeformRTSceneProperties)


def detach():
    del bpy.types.Scene.deformrt
    del bpy.types.Object.deformrt

"""Per-object and per-scene DeformRT settings (the names other tools rely on: see NOTES.md)."""

import bpy
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from ..core.layering.segmentation import SCHEMES
from .io import blender_versions

ROLE_ITEMS = (
    ("NONE", "None", "Not part of garment layering"),
    ("BODY", "Body", "The figure the garments are worn on (layer 0)"),
    ("GARMENT", "Garment", "A garment; a higher layer is worn further out"),
)


class DeformRTObjectProperties(bpy.types.PropertyGroup):
    role: EnumProperty(name="Role", items=ROLE_ITEMS, default="NONE",
                       description="What the object is in garment layering: the body, a garment, or neither")
    layer: IntProperty(
        name="Layer",
        description="Body is 0; a garment on a higher layer is worn over the lower ones",
        default=0,
        min=0,
        soft_max=20,
    )


SCHEME_ITEMS = (
    ("S5", "5 Parts", "Torso, arms and legs, and one part for a skirt or dress: for standing figures"),
    ("S13", "13 Parts", "Upper and lower limbs, hands and feet apart: for posed and animated figures"),
    ("NONE", "Whole Body", "No body parts: every garment point meets every higher layer near it"),
)


PART_ITEMS = tuple((p, p.replace("_", " ").title(), f"The {p.replace('_', ' ')} part")
                   for p in dict.fromkeys(p for scheme in SCHEMES.values() for p in scheme.parts))


class DeformRTPartProbe(bpy.types.PropertyGroup):
    part: EnumProperty(name="Part", items=PART_ITEMS, description="Body part whose reach this sets")
    distance: FloatProperty(
        name="Reach",
        description="How far under a garment over this part DeformRT looks for the garment worn over it",
        default=0.05,
        min=0.0,
        soft_max=0.5,
        subtype="DISTANCE",
        unit="LENGTH",
    )


def _frame_change_toggled(self, _context):
    from .layers import frame_handler  # it imports the resolve, which needs these properties first

    frame_handler.switched(self.id_data)


class DeformRTSceneProperties(bpy.types.PropertyGroup):
    resolve_on_frame_change: BoolProperty(
        name="Resolve on Frame Change",
        description="Re-run the layer correction whenever the frame changes (playback, rendering an animation); "
        "switching it off shows the garments as simulated again",
        default=False,
        update=_frame_change_toggled if blender_versions.PROPERTY_CALLBACKS else None,
    )
    playback_step: IntProperty(
        name="While Playing, Resolve Every",
        description="Frames between resolves while the animation plays in the viewport: the frames between "
        "show the last resolve's correction on the new pose (about that many times faster; poke-through "
        "under 0.02% on a walk at 2). Renders, Bake Frames, scripts and stepping frame by frame resolve "
        "every frame, and so does the frame playback stops on",
        default=1,
        min=1,
        max=4,
    )
    playback_in_background: BoolProperty(
        name="While Playing, Resolve in the Background",
        description="While the animation plays in the viewport, resolve on a worker thread: each frame shows the "
        "newest finished correction on its own pose (a frame or two old), and playback keeps its speed. "
        "Renders, Bake Frames, scripts and stepping resolve every frame, and so does the frame playback "
        "stops on",
        default=True,
    )
    scheme: EnumProperty(
        name="Body Parts",
        description="How the body is split into parts: cloth over one part is only fitted under garments over "
        "the same part (a sleeve is never pushed under the shirt's front)",
        items=SCHEME_ITEMS,
        default="S5",
    )
    offset: FloatProperty(
        name="Offset",
        description="Gap left behind a higher layer; Auto (0) takes 0.1% of the body's size, about 2 mm on a person",
        default=0.0,
        min=0.0,
        soft_max=0.05,
        subtype="DISTANCE",
        unit="LENGTH",
        precision=4,
    )
    probe_distance: FloatProperty(
        name="Reach",
        description="How far under each point of a garment DeformRT looks for a garment worn over it: loose "
        "clothes need more. Auto (0) takes each body part's thickness, more where lower garments hang loose",
        default=0.0,
        min=0.0,
        soft_max=1.0,
        subtype="DISTANCE",
        unit="LENGTH",
    )
    part_probes: CollectionProperty(type=DeformRTPartProbe, name="Reach per Part",
                                   description="The reach set for single body parts")
    boundary_pass: BoolProperty(
        name="Tuck Under Hems",
        description="Smoothly pull lower layers in under higher layers' hems and cuffs",
        default=True,
    )
    body_guard: BoolProperty(
        name="Keep Out of Body",
        description="Take back moves that would put cloth through the body (sharp edges of a mannequin or a "
                    "collider); a smooth body rarely needs it",
        default=True,
    )
    outer_room: BoolProperty(
        name="Outer Layer Makes Room",
        description="Where the body leaves a lower layer no room and a higher layer's long edges still pass "
                    "through it (armpits, crotch), move those edges out by up to a gap instead of hiding the "
                    "lower triangles, which could show as holes past the higher layer's outline",
        default=True,
    )
    remove_hidden: BoolProperty(
        name="Hide Poke-Through",
        description="Leave out triangles that still cross a higher layer after the move",
        default=True,
    )
    hide_covered_skin: BoolProperty(
        name="Hide Covered Skin",
        description="Leave out the body's faces that garments cover all over, so skin that pokes through a "
                    "tight garment does not show (non-destructive, as MakeHuman's delete groups; off leaves the "
                    "body as it is)",
        default=True,
    )
    render_layered: BoolProperty(
        name="Hide Covered Garments",
        description="Show each garment only where no garment worn over it covers it, as a resolve would (off: "
        "every garment as it is, to compare)",
        default=True,
    )
    render_max_depth: IntProperty(
        name="Max Bounces",
        description="Reflection and refraction recursion limit of the DeformRT Layered render",
        default=4,
        min=0,
        max=16,
        soft_max=12,
    )
    render_area_samples: IntProperty(
        name="Area Light Samples",
        description="How smooth the soft shadows of area lights are: more is smoother and slower",
        default=4,
        min=1,
        max=32,
        soft_max=16,
    )
    last_report: StringProperty(
        name="Last Report",
        description="What the last resolve or inspect measured (shown in the panel)",
        default="",
    )


CLASSES = (DeformRTObjectProperties, DeformRTPartProbe, DeformRTSceneProperties)


def attach():
    bpy.types.Object.deformrt = PointerProperty(type=DeformRTObjectProperties)
    bpy.types.Scene.deformrt = PointerProperty(type=DeformRTSceneProperties)


def detach():
    del bpy.types.Scene.deformrt
    del bpy.types.Object.deformrt

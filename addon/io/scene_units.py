"""Lengths in messages as the scene's own fields show them: its unit system and Unit Scale (a
scene modelled in millimetres, Unit Scale 0.001, reads a move of 19.4 units as 19.4 mm)."""

import bpy


def length(scene, value: float, precision: int = 3) -> str:
    """``value`` (Blender units) in the scene's units, e.g. "1.94 cm"."""
    settings = scene.unit_settings
    return bpy.utils.units.to_string(settings.system, "LENGTH", value * settings.scale_length,
                                     precision=precision).strip()


def formatter(scene):
    """``length`` for this scene, for text made where the scene is not at hand."""
    return lambda value: length(scene, value)

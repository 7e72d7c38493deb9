"""Blender glue: registration of properties, operators, panels, preferences and the CLI."""

import bpy

from ..core.layering.body_facts import forget_garments
from ..operators import jellyfish as jellyfish_ops
from ..operators import layering, tagging
from . import cli, frame_handler, panels, preferences, properties, render_engine, staleness

_classes = (*properties.CLASSES, *preferences.CLASSES, *tagging.CLASSES, *layering.CLASSES, *jellyfish_ops.CLASSES,
            *panels.CLASSES)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(_classes)


def register():
    _register_classes()
    bpy.types.VIEW3D_MT_add.append(jellyfish_ops.menu_add)
    properties.attach()
    preferences.apply_thread_setting()
    cli.register()
    frame_handler.register()
    staleness.register()
    render_engine.register()


def unregister():
    render_engine.unregister()
    staleness.unregister()
    frame_handler.unregister()
    bpy.types.VIEW3D_MT_add.remove(jellyfish_ops.menu_add)
    cli.unregister()
    properties.detach()
    _unregister_classes()
    forget_garments()  # what resolves kept of garments, their ray scenes too: Embree memory back

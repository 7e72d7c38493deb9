"""Blender glue: registration of properties, operators, panels, preferences and the CLI."""

import bpy

from ..operators import jellyfish, layering, tagging
from . import cli, frame_handler, panels, preferences, properties

_classes = (*properties.CLASSES, *preferences.CLASSES, *tagging.CLASSES, *layering.CLASSES, *jellyfish.CLASSES,
            *panels.CLASSES)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(_classes)


def register():
    _register_classes()
    bpy.types.VIEW3D_MT_add.append(jellyfish.menu_add)
    properties.attach()
    preferences.apply_thread_setting()
    cli.register()
    frame_handler.register()


def unregister():
    frame_handler.unregister()
    bpy.types.VIEW3D_MT_add.remove(jellyfish.menu_add)
    cli.unregister()
    properties.detach()
    _unregister_classes()

"""DeformRT: layered garments that never poke through, and jellyfish that swim.

Blender loads this package as an extension (``bl_ext.<repo>.deformrt``); the
algorithms live in ``core`` and never import bpy. Importing this package does not
import bpy either (the Blender glue loads in ``register``), so tools and test
runners can walk the tree without Blender.
"""


def register():
    from .addon import register as register_addon

    register_addon()


def unregister():
    from .addon import unregister as unregister_addon

    unregister_addon()

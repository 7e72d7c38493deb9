"""DeformRT: layered garments that never poke through, and jellyfish that swim.

Blender loads this package as an extension (``bl_ext.<repo>.deformrt``); the algorithms live in
``core`` and never import bpy. Registration lives here, above what it registers: the operators
(``operators``), the Blender-side parts under them (``addon``) and the command line
(``sample_scenes.cli``, which builds the bundled scenes and runs the jobs on them).
Importing this package does not import bpy (the Blender glue loads in ``register``), so tools and
test runners can walk the tree without Blender.
"""

_unregister_classes = None


def register():
    global _unregister_classes
    import bpy

    from .addon import properties
    from .addon.layers import frame_handler, staleness
    from .addon.render import engine as render_engine
    from .addon.ui import panels, preferences
    from .operators import jellyfish as jellyfish_ops
    from .operators import layering, tagging
    from .sample_scenes.cli import commands as cli

    classes = (*properties.CLASSES, *preferences.CLASSES, *tagging.CLASSES, *layering.CLASSES,
               *jellyfish_ops.CLASSES, *panels.CLASSES)
    register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)
    register_classes()
    bpy.types.VIEW3D_MT_add.append(jellyfish_ops.menu_add)
    properties.attach()
    preferences.apply_thread_setting()
    cli.register()
    staleness.register()
    frame_handler.register()
    render_engine.register()


def unregister():
    import bpy

    from .addon import properties
    from .addon.layers import frame_handler, staleness
    from .addon.render import engine as render_engine
    from .core.geometry import parallel
    from .core.layering.body_facts import forget_garments
    from .operators import jellyfish as jellyfish_ops
    from .sample_scenes.cli import commands as cli

    render_engine.unregister()
    frame_handler.unregister()
    staleness.unregister()
    bpy.types.VIEW3D_MT_add.remove(jellyfish_ops.menu_add)
    cli.unregister()
    properties.detach()
    if _unregister_classes is not None:
        _unregister_classes()
    forget_garments()  # what resolves kept of garments, their ray scenes too: Embree memory back
    parallel.shutdown()  # and the ray and search threads

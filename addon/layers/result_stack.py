"""Where a garment's layering result sits in its modifier stack, and reading the garment there.

The result is stored per vertex and per face by index, so it must sit where the viewport and
the render see the same vertices: before the first modifier that subdivides (Subdivision
Surface, Multires: their viewport and render levels differ, and a level-2 mesh has other
indices than a level-1 one) or that runs in only one of the two. Everything above that point
(Armature, Cloth, Shape keys, Mirror, Solidify, Bevel, ...) is what the resolve reads and
corrects; what comes after smooths the corrected cage exactly as it would smooth the fitted one.
Resolving the cage instead of the subdivided mesh is also what keeps a resolve fast: Blender's
CPU subdivision of Fig 4.12's garments takes longer than the resolve itself.
"""

from contextlib import contextmanager

import bpy

from . import result_nodes

SUBDIVIDING = frozenset({"SUBSURF", "MULTIRES"})


def is_result(mod) -> bool:
    """A DeformRT result modifier: its group is ours by its mark, whatever it is called (a garment
    appended from another file brings the group as "DeformRT Result.001")."""
    return mod.type == "NODES" and result_nodes.is_our_group(mod.node_group)


def _uses_is_viewport(tree, seen=None) -> bool:
    """Whether a node tree (or a group inside it) asks whether it runs in the viewport."""
    seen = set() if seen is None else seen
    if tree is None or tree.name in seen:
        return False
    seen.add(tree.name)
    for node in tree.nodes:
        if node.bl_idname == "GeometryNodeIsViewport":
            return True
        if getattr(node, "node_tree", None) is not None and _uses_is_viewport(node.node_tree, seen):
            return True
    return False


def differs_in_render(mod) -> bool:
    """True when this modifier can give the render other vertices than the viewport."""
    if not (mod.show_viewport or mod.show_render):
        return False  # off in both: it changes nothing anywhere
    if mod.show_viewport != mod.show_render:
        return True
    if mod.type == "MULTIRES":  # its viewport and render levels may agree (Subdivision's the GPU may still change)
        return mod.levels != mod.render_levels
    if mod.type in SUBDIVIDING:
        return True
    return mod.type == "NODES" and _uses_is_viewport(mod.node_group)


def subdivided_on_demand(obj) -> bool:
    """Whether the viewport leaves the garment's last Subdivision Surface to the GPU (the user's
    preference; Blender then evaluates only the cage): reading its evaluated mesh from Python makes
    Blender subdivide it on the CPU first (0.4-1.5 s for each of Fig 4.13's garments)."""
    if not bpy.context.preferences.system.use_gpu_subdivision:
        return False
    shown = [m for m in obj.modifiers if m.show_viewport]
    return bool(shown) and shown[-1].type == "SUBSURF"


def user_modifiers(obj) -> list:
    return [m for m in obj.modifiers if not is_result(m)]


def cut_index(obj) -> int:
    """How many of the user's modifiers run before the result: all up to the first that differs
    in render (the user's own order is kept; the result is slotted in)."""
    own = user_modifiers(obj)
    return next((i for i, m in enumerate(own) if differs_in_render(m)), len(own))


def after_cut(obj) -> list:
    """The user's modifiers that run after the result (after where it goes, if there is none)."""
    own = user_modifiers(obj)
    result = next((m for m in obj.modifiers if is_result(m)), None)
    if result is None:
        return own[cut_index(obj):]
    names = [m.name for m in obj.modifiers]
    return [m for m in own if names.index(m.name) > names.index(result.name)]


def before_result(obj) -> list:
    """The user's modifiers that the result's input goes through."""
    result = next((m for m in obj.modifiers if is_result(m)), None)
    if result is None:
        return user_modifiers(obj)[:cut_index(obj)]
    out = []
    for m in obj.modifiers:
        if m == result:
            break
        out.append(m)
    return out


def placement_problem(obj) -> str | None:
    """Why the result cannot go where it must in this object's stack, or None. Blender lets
    nothing run before a Multires (it needs the original mesh), so a Multires whose render level
    differs from its viewport level leaves no place that both see alike."""
    own = user_modifiers(obj)
    late = next((m for m in own[cut_index(obj):] if m.type == "MULTIRES"), None)
    if late is None:
        return None
    return (f"{obj.name}'s {late.name} has Viewport level {late.levels} and Render level {late.render_levels}: "
            "DeformRT's result must run before modifiers that give the render other vertices, and Blender lets "
            "nothing run before a Multires. Set both levels the same (the result then follows the Multires) "
            "or apply it; nothing was changed")


def in_place(obj, mod) -> bool:
    return [m.name for m in obj.modifiers].index(mod.name) == cut_index(obj)


def place(obj, mod) -> bool:
    """Move the result modifier to its place in the stack; returns whether it moved."""
    if in_place(obj, mod):
        return False
    obj.modifiers.move([m.name for m in obj.modifiers].index(mod.name), cut_index(obj))
    return True


# Modifiers that move vertices where they are: run after the result, they move the corrected
# garment again, and what the resolve kept apart may cross (a Displace added later lands there).
# Subdivision and Multires smooth the cage the correction was made on, Solidify is given room
# (outward_shell); those are where they belong.
MOVING = frozenset({"DISPLACE", "SMOOTH", "LAPLACIANSMOOTH", "CORRECTIVE_SMOOTH", "CAST", "SIMPLE_DEFORM", "WAVE",
                    "WARP", "SHRINKWRAP", "HOOK", "LATTICE", "CURVE", "ARMATURE", "MESH_DEFORM", "SURFACE_DEFORM",
                    "CLOTH", "SOFT_BODY", "OCEAN"})


def moving_after(obj) -> list:
    """Names of the modifiers after the result (after where it goes) that move vertices."""
    return [m.name for m in after_cut(obj) if m.type in MOVING and (m.show_viewport or m.show_render)]


def _uses(modifiers, types) -> bool:
    """Whether any of ``modifiers`` of one of ``types`` is shown in the viewport or the render."""
    return any(m.type in types and (m.show_viewport or m.show_render) for m in modifiers)


def simulated(obj) -> bool:
    """Whether a cloth or soft body solver moves the garment (shown in the viewport or the render)."""
    return _uses(obj.modifiers, {"CLOTH", "SOFT_BODY"})


def shelled(obj) -> bool:
    """Whether a Solidify after the result gives the corrected garment a second shell."""
    return _uses(after_cut(obj), {"SOLIDIFY"})


def subdivided(obj) -> bool:
    """Whether a Subdivision Surface after the result smooths the corrected garment (in the viewport or
    the render): the resolve then widens what it lifts (core.layering.outer_room)."""
    return _uses(after_cut(obj), {"SUBSURF"})


def outward_shell(obj) -> float:
    """How far, in world units, Solidify modifiers after the result grow the corrected garment
    outward (offset 1 grows it all outward, -1, the default, all inward): the resolve leaves
    that much more room in front of it."""
    scale = max(abs(s) for s in obj.matrix_world.to_scale())
    outward = 0.0
    for mod in after_cut(obj):
        if mod.type == "SOLIDIFY" and mod.show_render:
            side = mod.offset if mod.thickness >= 0 else -mod.offset
            outward += abs(mod.thickness) * scale * (1 + side) / 2
    return outward


@contextmanager
def cages_shown(objs):
    """Each object evaluates in the viewport up to where its result sits (or would sit): the
    modifiers after that point are switched off for the moment (a cloth cache before them is
    kept) and put back as they were, whatever happens inside."""
    switched = []
    try:
        for obj in objs:
            for mod in after_cut(obj):
                if mod.show_viewport:
                    mod.show_viewport = False
                    switched.append(mod)
        yield
    finally:
        for mod in switched:
            mod.show_viewport = True

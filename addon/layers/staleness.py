"""What a garment's layering result was made for, and noticing when it no longer fits.

A result is a correction per vertex and per face of the mesh that was resolved. When that mesh
changes afterwards (edited, its shape keys or the modifiers above the result changed, moved
against the body, or the body itself changed), the correction would move the wrong vertices:
the result is marked stale and switched off for that garment, so it shows and renders as
fitted, and the panel, Inspect and the renders say why until Resolve Layers runs again (with
Resolve on Frame Change on, frame_handler does that at once). Animation is not a change: posed,
simulated and keyed shapes are what Resolve on Frame Change follows.

The result's Geometry Nodes group also refuses a mesh with other point or face counts by itself
(``result_nodes``), so a changed topology never scrambles a render, even without the add-on.
"""

import json
from contextlib import contextmanager

import bpy
import numpy as np
from bpy.app.handlers import persistent

from ...core.geometry.keys import digest
from ..io import blender_versions
from . import result_stack, results, scene_roles

# Not what a modifier does to the mesh: its place in the UI, its name, timing
_UI_ONLY = frozenset({"rna_type", "name", "show_expanded", "show_in_editmode", "show_on_cage", "is_active",
                      "is_override_data", "use_pin_to_last", "execution_time", "persistent_uid", "use_apply_on_spline",
                      "is_override_data_editable", "debug_options", "open_output_attributes_panel",
                      "open_manage_panel", "open_bake_panel", "open_named_attributes_panel", "show_group_selector",
                      "show_manage_panel", "bake_target", "bake_directory", "node_warnings"})
_checking = False
_paused = False


def _digest(*parts) -> str:
    return digest(*[p if isinstance(p, np.ndarray) else np.frombuffer(repr(p).encode(), np.uint8)
                    for p in parts]).hex()


def _mesh_digest(mesh) -> str:
    """Rest positions and topology of a mesh datablock (not evaluated)."""
    n, m = len(mesh.vertices), len(mesh.loops)
    co = np.empty(n * 3, dtype=np.float32)
    if n:
        mesh.attributes["position"].data.foreach_get("vector", co)
    corner = np.empty(m, dtype=np.int32)
    attr = mesh.attributes.get(".corner_vert")
    if attr is not None and attr.domain == "CORNER":
        attr.data.foreach_get("value", corner)
    else:
        mesh.loops.foreach_get("vertex_index", corner)
    starts = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_start", starts)
    return _digest(co, corner, starts)


def _keys_digest(mesh) -> str:
    """Shape keys' data, and their values when nothing animates or drives them."""
    key = mesh.shape_keys
    if key is None:
        return ""
    anim = key.animation_data
    animated = anim is not None and (anim.action is not None or len(anim.drivers) > 0)
    parts = [key.use_relative, None if animated else round(key.eval_time, 6)]
    for block in key.key_blocks:
        co = np.empty(len(block.data) * 3, dtype=np.float32)
        block.data.foreach_get("co", co)
        parts += [block.name, block.relative_key.name, block.mute, block.vertex_group, co,
                  None if animated else round(block.value, 6)]
    return _digest(*parts)


def _modifier_settings(mod) -> list:
    out = [mod.type, mod.name, mod.show_viewport, mod.show_render]
    for prop in mod.bl_rna.properties:
        name = prop.identifier
        if name in _UI_ONLY:
            continue
        value = getattr(mod, name, None)
        if prop.type == "POINTER":
            out.append((name, getattr(value, "name", None) if isinstance(value, bpy.types.ID) else None))
        elif prop.type != "COLLECTION":
            out.append((name, tuple(value) if getattr(prop, "is_array", False) else value))
    if mod.type == "NODES":
        inputs = blender_versions.modifier_inputs(mod)
        out += [(k, getattr(inputs[k], "name", repr(inputs[k]))) for k in sorted(inputs)]
    return out


def _modifiers_digest(mods) -> str:
    return _digest(*[_modifier_settings(m) for m in mods])


def _still(obj) -> bool:
    """Whether nothing animates or constrains the object's placement, its parents' included."""
    while obj is not None:
        anim = obj.animation_data
        if obj.constraints or (anim is not None and (anim.action is not None or len(anim.drivers))):
            return False
        obj = obj.parent
    return True


def _object_print(obj, mods, prints) -> dict:
    key = (obj.name, "mesh data", None)  # three long: no (name, modifiers) key of fingerprint's
    data = prints.get(key)
    if data is None:  # a body's mesh read once though its result and the garments' both need it
        data = prints[key] = (_mesh_digest(obj.data), _keys_digest(obj.data))
    return {"name": obj.name, "mesh": data[0], "keys": data[1], "modifiers": _modifiers_digest(mods)}


def fingerprint(garment, body, prints=None) -> str:
    """What a garment's result is made for now: its mesh, shape keys, the modifiers above the
    result, where it sits on the body, and the body's own (JSON, kept on the result's data).
    ``prints``: a dict kept over one resolve's calls, so the body is read once, not per garment."""
    prints = {} if prints is None else prints
    placed = None
    if _still(garment) and _still(body):
        relative = np.linalg.inv(np.array(body.matrix_world)) @ np.array(garment.matrix_world)
        placed = relative[:3].ravel().tolist()
    for obj, mods in ((garment, result_stack.before_result), (body, result_stack.user_modifiers)):
        key = (obj.name, mods.__name__)
        if key not in prints:
            prints[key] = _object_print(obj, mods(obj), prints)
    return json.dumps({"garment": prints[(garment.name, "before_result")],
                       "body": prints[(body.name, "user_modifiers")], "placed": placed})


def _differences(then: dict, now: dict, garment, body) -> str | None:
    g0, g1, b0, b1 = then["garment"], now["garment"], then["body"], now["body"]
    if g0["mesh"] != g1["mesh"]:
        return f"{garment.name}'s mesh was edited"
    if g0["keys"] != g1["keys"]:
        return f"{garment.name}'s shape keys changed"
    if g0["modifiers"] != g1["modifiers"]:
        return f"{garment.name}'s modifiers above DeformRT changed"
    if b0["mesh"] != b1["mesh"] or b0["keys"] != b1["keys"]:
        return f"{body.name}'s mesh or shape keys changed"
    if b0["modifiers"] != b1["modifiers"]:
        return f"{body.name}'s modifiers changed"
    p0, p1 = then.get("placed"), now.get("placed")
    if p0 is not None and p1 is not None:
        size = float(np.ptp(np.array(garment.bound_box), axis=0).max())
        if not np.allclose(np.reshape(p0, (3, 4)), np.reshape(p1, (3, 4)), atol=1e-5 * max(size, 1.0), rtol=0):
            return f"{garment.name} was moved against {body.name}"
    return None


def why_stale(garment, body) -> str | None:
    """Why the garment's result does not fit what it is now, or None (it fits, or was made before
    fingerprints). Decided afresh each time: a change undone is forgotten."""
    data = results.data_object(garment)
    if data is None:
        return None
    made_for = data.get(results.FINGERPRINT_PROPERTY)
    if not isinstance(made_for, str) or not made_for:
        return None
    shifted = [m.name for m in result_stack.before_result(garment) if result_stack.differs_in_render(m)]
    if shifted:
        return f"{garment.name}'s {shifted[0]} runs before DeformRT, so the render has other vertices"
    try:
        then = json.loads(made_for)
        return _differences(then, json.loads(fingerprint(garment, body)), garment, body)
    except (ValueError, KeyError, TypeError):  # a damaged or crafted file: named, never raised
        return "what it was made for cannot be read (the file's DeformRT data is damaged)"


def mark(garment, reason: str) -> None:
    """Switch the garment's result off and say why, once."""
    data = results.data_object(garment)
    if data is None or data.get(results.STALE_PROPERTY) == reason:
        return
    data[results.STALE_PROPERTY] = reason
    results.set_enabled(garment, False)
    print(f"DeformRT: {garment.name} shows as fitted until Resolve Layers: {reason} since the last resolve")


def unmark(garment) -> None:
    """The garment is again what its result was made for (an edit undone, a drag cancelled, back
    at the resolved frame): show the result again."""
    data = results.data_object(garment)
    if data is None or results.STALE_PROPERTY not in data:
        return
    del data[results.STALE_PROPERTY]
    results.set_enabled(garment, True)


def stale_garments(scene) -> list:
    """(object, reason) for every garment (or body, for its covered skin) of the scene whose result
    was marked stale."""
    out = []
    for obj in scene_roles.garments(scene) + scene_roles.bodies(scene):
        data = results.data_object(obj)
        if data is not None and data.get(results.STALE_PROPERTY):
            out.append((obj, str(data[results.STALE_PROPERTY])))
    return out


def _with_results(scene) -> list:
    return [o for o in scene.objects if o.type == "MESH" and results.result_modifier(o) is not None]


def check_scene(scene, depsgraph=None, subdivide=False) -> list:
    """Look at every result of the scene as it is now: a field holding what is not the object's
    own result is emptied, a result that does not fit is switched off and one that fits again is
    switched back on. Returns (garment, reason) of those switched off. ``subdivide``: read the
    result group's verdict also where that makes Blender subdivide on the CPU (results.fits_now;
    when the user asks to look, not on every edit)."""
    if _paused:
        return stale_garments(scene)
    depsgraph = depsgraph if depsgraph is not None else bpy.context.evaluated_depsgraph_get()
    bodies = scene_roles.bodies(scene)
    tagged = set(scene_roles.garments(scene) + bodies)
    for obj in _with_results(scene):
        foreign = results.disconnect_foreign(obj)
        if foreign:
            print(f"DeformRT: {obj.name} shows as fitted until Resolve Layers: {foreign}")
        if obj not in tagged or results.data_object(obj) is None:
            continue
        reason = why_stale(obj, bodies[0]) if len(bodies) == 1 else "the scene has no single body"
        if not reason:
            # the fingerprints do not see it (a value inside a node group, a lattice's points, a
            # hook's target, a driver): the vertices themselves moved
            moved = f"{obj.name}'s vertices above DeformRT moved"
            fits = results.fits_now(obj, depsgraph, subdivide)
            if fits is False or (fits is None and results.data_object(obj).get(results.STALE_PROPERTY) == moved):
                reason = moved  # (not read: as it was last read)
        if reason:
            mark(obj, reason)
        else:
            unmark(obj)
    return stale_garments(scene)


@contextmanager
def paused():
    """No checks while a resolve reads the scene with its results switched off for the moment."""
    global _paused
    before, _paused = _paused, True
    try:
        yield
    finally:
        _paused = before


def _watched(scene) -> set:
    ids = set()
    for obj in scene_roles.bodies(scene) + scene_roles.garments(scene):
        ids.update({obj, obj.data})
        if obj.type == "MESH" and obj.data.shape_keys is not None:
            ids.add(obj.data.shape_keys)
    return ids


def touched(scene, depsgraph) -> bool:
    """Whether this update changed a body or a garment, or anything with a result (not while marking)."""
    if _checking or _paused:
        return False
    holders = _with_results(scene)
    if not holders:
        return False
    watched = _watched(scene) | set(holders) | {o.data for o in holders}
    return bool({u.id.original for u in depsgraph.updates} & watched)


@persistent
def on_depsgraph_update(scene, depsgraph):
    global _checking
    if not touched(scene, depsgraph):
        return
    _checking = True  # marking switches a result off, which is an update of its own
    try:
        check_scene(scene, depsgraph)  # with Resolve on Frame Change on, frame_handler resolves what was marked
    finally:
        _checking = False


@persistent
def on_load(_file):
    for scene in bpy.data.scenes:
        check_scene(scene)


@persistent
def on_render_pre(scene, _depsgraph=None):
    for garment, reason in check_scene(scene):
        print(f"DeformRT: {garment.name} renders as fitted: {reason} since the last resolve (Resolve Layers again)")
    for garment in scene_roles.garments(scene):
        if results.data_object(garment) is not None:
            for name in result_stack.moving_after(garment):
                print(f"DeformRT: {garment.name}'s {name} runs after DeformRT and moves what it corrected "
                      "(move it above DeformRT and resolve again)")


_HANDLERS = (("depsgraph_update_post", on_depsgraph_update), ("load_post", on_load), ("render_pre", on_render_pre))


def register():
    for name, fn in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if fn not in handlers:
            handlers.append(fn)


def unregister():
    for name, fn in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        while fn in handlers:
            handlers.remove(fn)

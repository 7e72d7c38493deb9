"""Non-destructive layering results on garment objects, and baking them to plain meshes.

Each resolved garment gets a "DeformRT" Geometry Nodes modifier (where ``result_stack`` puts
it: before the modifiers that subdivide) and a hidden data object in the "DeformRT Data"
collection holding the correction and what it was made for (``staleness``). The garment's own
mesh is never written; Clear removes both and the garment renders as fitted.
"""

import bpy
import numpy as np

from ..io import blender_versions
from . import result_nodes, result_stack, scene_roles

MODIFIER_NAME = "DeformRT"
DATA_COLLECTION = "DeformRT Data"
BAKED_COLLECTION = scene_roles.BAKED_COLLECTION
# On the data object: what the result was made for, and why it no longer fits (absent: it fits).
FINGERPRINT_PROPERTY = "deformrt_made_for"
STALE_PROPERTY = "deformrt_stale"


def result_modifier(obj):
    """The garment's DeformRT result modifier, or None."""
    return next((m for m in obj.modifiers if result_stack.is_result(m)), None)


def data_object(obj):
    mod = result_modifier(obj)
    if mod is None:
        return None
    return blender_versions.modifier_input(mod, result_nodes.data_socket_id(mod.node_group))


def set_enabled(obj, enabled: bool) -> bool:
    """Show or bypass the garment's result (to read what its stack produces on its own),
    leaving the modifier's visibility to the user. Returns whether it was shown before."""
    mod = result_modifier(obj)
    data = data_object(obj)
    if mod is None or not mod.show_viewport or data is None:
        return False
    result_nodes.node_group()  # a file's older group knows no bypass: rebuilt first
    attr = data.data.attributes.get(result_nodes.BYPASS_ATTRIBUTE)
    before = not (attr is not None and len(attr.data) and attr.data[0].value)
    if before != enabled:
        _set_bypass(data.data, not enabled)
        data.data.update()  # the garment evaluates again as the data's dependent
    return before


def _set_bypass(mesh, bypass: bool):
    name = result_nodes.BYPASS_ATTRIBUTE
    attr = mesh.attributes.get(name)
    if attr is None or attr.data_type != "BOOLEAN" or attr.domain != "POINT":
        if attr is not None:
            mesh.attributes.remove(attr)
        attr = mesh.attributes.new(name, "BOOLEAN", "POINT")
    attr.data.foreach_set("value", np.full(len(mesh.vertices), bypass, dtype=bool))


def _hidden_collection(scene, name):
    """The named collection under the scene's, created hidden in viewport and render."""
    coll = bpy.data.collections.get(name)
    if coll is None:
        coll = bpy.data.collections.new(name)
        coll.hide_render = True
        coll.hide_viewport = True
    if coll.name not in scene.collection.children:
        scene.collection.children.link(coll)
    return coll


def _set_points(mesh, name, kind, values):
    attr = mesh.attributes.get(name)
    if attr is None or attr.data_type != kind or attr.domain != "POINT":
        if attr is not None:
            mesh.attributes.remove(attr)
        attr = mesh.attributes.new(name, kind, "POINT")
    attr.data.foreach_set("value", values)


def _fill_data_mesh(mesh, offsets, hidden):
    """Offsets per vertex and hidden flags per face, both indexed from 0 on the data mesh's
    points (a point cloud in mesh form: the Sample Index nodes read them by index), and the
    counts of the mesh they were made for."""
    count = max(len(offsets), len(hidden), 1)
    if len(mesh.vertices) != count or mesh.polygons:
        mesh.clear_geometry()
        mesh.vertices.add(count)
    for name, kind in ((result_nodes.OFFSET_ATTRIBUTE, "FLOAT_VECTOR"), (result_nodes.HIDDEN_ATTRIBUTE, "BOOLEAN")):
        attr = mesh.attributes.get(name)
        if attr is None or attr.data_type != kind or attr.domain != "POINT":
            if attr is not None:
                mesh.attributes.remove(attr)
            mesh.attributes.new(name, kind, "POINT")
    off = np.zeros((count, 3), dtype=np.float32)
    off[:len(offsets)] = offsets
    mesh.attributes[result_nodes.OFFSET_ATTRIBUTE].data.foreach_set("vector", off.ravel())
    hid = np.zeros(count, dtype=bool)
    hid[:len(hidden)] = hidden
    mesh.attributes[result_nodes.HIDDEN_ATTRIBUTE].data.foreach_set("value", hid)
    _set_points(mesh, result_nodes.POINT_COUNT_ATTRIBUTE, "INT", np.full(count, len(offsets), dtype=np.int32))
    _set_points(mesh, result_nodes.FACE_COUNT_ATTRIBUTE, "INT", np.full(count, len(hidden), dtype=np.int32))
    _set_points(mesh, result_nodes.COUNTS_KNOWN_ATTRIBUTE, "BOOLEAN", np.ones(count, dtype=bool))
    _set_bypass(mesh, False)
    mesh.update()  # the garment's result follows as the data's dependent


def write(scene, obj, offsets_local, hidden_faces, stats=None, made_for=None) -> None:
    """Show ``obj`` moved by ``offsets_local`` (per vertex where the result sits, object space)
    and without ``hidden_faces`` (per polygon there): data object and modifier, created or
    updated, the modifier put in its place in the stack. ``made_for`` is the fingerprint of
    what was resolved (``staleness.fingerprint``)."""
    group = result_nodes.node_group()
    key = result_nodes.data_socket_id(group)
    mod = result_modifier(obj)
    data = blender_versions.modifier_input(mod, key) if mod is not None else None
    if data is None:
        mesh = bpy.data.meshes.new(f"DeformRT {obj.name}")
        data = bpy.data.objects.new(f"DeformRT {obj.name}", mesh)
        data.hide_render = True
        data.hide_viewport = True
        _hidden_collection(scene, DATA_COLLECTION).objects.link(data)
    _fill_data_mesh(data.data, offsets_local, hidden_faces)
    if stats:
        data["deformrt_stats"] = stats
    if made_for is not None:
        data[FINGERPRINT_PROPERTY] = made_for
    if STALE_PROPERTY in data:
        del data[STALE_PROPERTY]
    changed = mod is None or blender_versions.modifier_input(mod, key) != data or \
        not (mod.show_viewport and mod.show_render)
    if mod is None:
        mod = obj.modifiers.new(MODIFIER_NAME, "NODES")
        mod.node_group = group
        mod.show_expanded = False
    changed = result_stack.place(obj, mod) or changed
    if changed:
        # a new modifier or data object changes what the garment depends on; new numbers in the
        # same data do not need the garment tagged (which would start its cloth modifier over)
        blender_versions.set_modifier_input(mod, key, data)
        mod.show_viewport = mod.show_render = True
        obj.update_tag()


def read_offsets(obj, n_vertices):
    """The garment's stored offsets (object space) for its first ``n_vertices`` evaluated
    vertices, or None when it has no result."""
    data = data_object(obj)
    if data is None:
        return None
    attr = data.data.attributes.get(result_nodes.OFFSET_ATTRIBUTE)
    out = np.zeros(len(data.data.vertices) * 3, dtype=np.float32)
    attr.data.foreach_get("vector", out)
    out = out.reshape(-1, 3).astype(np.float64)
    full = np.zeros((n_vertices, 3))
    full[:min(n_vertices, len(out))] = out[:n_vertices]
    return full


def clear(obj) -> bool:
    """Remove the garment's result (modifier and data). Returns whether it had one."""
    mod = result_modifier(obj)
    if mod is None:
        return False
    data = blender_versions.modifier_input(mod, result_nodes.data_socket_id(mod.node_group))
    obj.modifiers.remove(mod)
    if data is not None and not any(data_object(o) == data for o in bpy.data.objects if o.type == "MESH"):
        mesh = data.data
        bpy.data.objects.remove(data)
        if mesh is not None and mesh.users == 0:
            bpy.data.meshes.remove(mesh)
    coll = bpy.data.collections.get(DATA_COLLECTION)
    if coll is not None and not coll.objects:
        bpy.data.collections.remove(coll)
    group = bpy.data.node_groups.get(result_nodes.GROUP_NAME)
    if group is not None and group.users == 0:
        bpy.data.node_groups.remove(group)
    return True


def bake(scene, objects, depsgraph) -> list:
    """Plain meshes of what ``objects`` render now (modifiers applied, result included) in
    the "DeformRT Baked" collection, each keeping its role, layer, materials and placement;
    an earlier bake of the same object is replaced. The collection starts hidden (in
    viewport and render) so the scene does not show everything twice; it is for export."""
    coll = _hidden_collection(scene, BAKED_COLLECTION)
    baked = []
    for obj in objects:
        name = f"{obj.name} (baked)"
        old = coll.objects.get(name)
        if old is not None:
            old_mesh = old.data
            bpy.data.objects.remove(old)
            if old_mesh.users == 0:
                bpy.data.meshes.remove(old_mesh)
        mesh = bpy.data.meshes.new_from_object(obj.evaluated_get(depsgraph), preserve_all_data_layers=True,
                                               depsgraph=depsgraph)
        mesh.name = name
        new = bpy.data.objects.new(name, mesh)
        new.matrix_world = obj.matrix_world.copy()
        new.deformrt.role = obj.deformrt.role
        new.deformrt.layer = obj.deformrt.layer
        coll.objects.link(new)
        baked.append(new)
    return baked

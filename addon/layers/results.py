"""Non-destructive layering results on garment objects, and baking them to plain meshes.

Each resolved garment gets a "DeformRT" Geometry Nodes modifier (where ``result_stack`` puts
it: before the modifiers that subdivide) and a hidden data object in the "DeformRT Data"
collection holding the correction and what it was made for (``staleness``). The garment's own
mesh is never written; Clear removes both and the garment renders as fitted.
"""

from contextlib import contextmanager
from dataclasses import dataclass

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
# On the data object: the garment (an object pointer) DeformRT made it for.
OWNER_PROPERTY = "deformrt_result_of"

_recorded = None  # while a frame bake resolves: each write's object and Shown, to be written again


@dataclass
class Shown:
    """What an object shows of a resolve: its vertices moved by ``offsets`` (per vertex where the
    result sits, object space), without ``hidden`` (per polygon there); ``made_for``, the
    fingerprint of what was resolved (``staleness.fingerprint``); ``cage``: where the vertices
    were (object space), so the result passes a mesh whose vertices moved since through
    (``result_nodes``)."""

    offsets: np.ndarray
    hidden: np.ndarray
    made_for: str | None = None
    cage: np.ndarray | None = None


@contextmanager
def recording():
    """Collect the writes made inside as (garment, arguments) to pass to ``write`` again."""
    global _recorded
    _recorded = []
    try:
        yield _recorded
    finally:
        _recorded = None


def result_modifier(obj):
    """The garment's DeformRT result modifier, or None."""
    return next((m for m in obj.modifiers if result_stack.is_result(m)), None)


def linked_data(obj):
    """Whatever the result modifier's Result Data field holds (any object, or None): read only."""
    mod = result_modifier(obj)
    if mod is None:
        return None
    try:
        return blender_versions.modifier_input(mod, result_nodes.data_socket_id(mod.node_group))
    except RuntimeError:  # a group of ours edited by hand until it lost its input
        return None


def _made_by_us(data) -> bool:
    """A data object DeformRT made: a point cloud in mesh form with our offsets. (The owner mark
    below says for whom; files from before it have this shape and no mark.)"""
    return (data is not None and data.type == "MESH" and data.data is not None and not data.data.polygons
            and result_nodes.OFFSET_ATTRIBUTE in data.data.attributes)


def is_own_data(data, obj) -> bool:
    """Whether ``data`` is the result data DeformRT made for ``obj``: the only objects the add-on
    ever writes into or deletes. Its mark names its garment (an ID pointer, so renames keep it
    and a copied modifier or a linked duplicate, pointing at the same data, is not its owner).
    Data from before the mark is taken as the garment's when only this garment points at it."""
    if not _made_by_us(data):
        return False
    owner = data.get(OWNER_PROPERTY)
    if owner is not None:
        return isinstance(owner, bpy.types.Object) and owner == obj
    users = [o for o in bpy.data.objects if o.type == "MESH" and linked_data(o) == data]
    return users == [obj]


def data_object(obj):
    """The garment's own result data, or None (no result, or the field holds something else)."""
    data = linked_data(obj)
    return data if is_own_data(data, obj) else None


def foreign_data(obj):
    """What the result modifier's field holds when it is not this garment's own result (another
    garment's, after Copy Modifiers or a linked duplicate; any object picked there), or None."""
    data = linked_data(obj)
    return None if data is None or is_own_data(data, obj) else data


def disconnect_foreign(obj) -> str | None:
    """Empty a result modifier's field that holds what is not this garment's own result, so the
    garment shows as fitted and not another mesh's correction by index; the object it pointed at
    is left as it is. Returns why, or None when there was nothing to do."""
    data = foreign_data(obj)
    if data is None:
        return None
    mod = result_modifier(obj)
    blender_versions.set_modifier_input(mod, result_nodes.data_socket_id(mod.node_group), None)
    obj.update_tag()
    return f"its DeformRT modifier pointed at {data.name}, which holds no result made for it"


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
    attr.data.foreach_set("vector" if kind == "FLOAT_VECTOR" else "value", values)


def _fill_data_mesh(mesh, offsets, hidden, cage=None):
    """Offsets per vertex and hidden flags per face, both indexed from 0 on the data mesh's
    points (a point cloud in mesh form: the Sample Index nodes read them by index), the counts
    of the mesh they were made for and, given, where its vertices were (object space)."""
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
    known = cage is not None and len(cage) == len(offsets)
    at = np.zeros((count, 3), dtype=np.float32)
    tolerance = 0.0
    if known:
        at[:len(cage)] = cage
        # float32 positions read, turned to the world and back: a few units in the last place of the
        # coordinates; a move a hundred-thousandth of the mesh's size is a move
        size = float(np.ptp(cage, axis=0).max(initial=0.0)) + float(np.abs(cage).max(initial=0.0))
        tolerance = 1e-5 * size
    _set_points(mesh, result_nodes.CAGE_ATTRIBUTE, "FLOAT_VECTOR", at.ravel())
    _set_points(mesh, result_nodes.CAGE_TOLERANCE_ATTRIBUTE, "FLOAT", np.full(count, tolerance, dtype=np.float32))
    _set_points(mesh, result_nodes.CAGE_KNOWN_ATTRIBUTE, "BOOLEAN", np.full(count, known))
    _set_bypass(mesh, False)
    mesh.update()  # the garment's result follows as the data's dependent


def write(scene, obj, shown: Shown) -> None:
    """Make ``obj`` show ``shown``: data object and modifier, created or updated, the modifier put
    in its place in the stack."""
    if _recorded is not None:
        # single precision, as the data mesh stores them
        cage = None if shown.cage is None else np.asarray(shown.cage, np.float32)
        _recorded.append((obj, Shown(np.asarray(shown.offsets, np.float32), np.array(shown.hidden, bool),
                                     shown.made_for, cage)))
    group = result_nodes.node_group()
    key = result_nodes.data_socket_id(group)
    mod = result_modifier(obj)
    if mod is not None and mod.node_group != group:  # another file's copy of the group: ours from now on
        old = data_object(obj)
        mod.node_group = group
        blender_versions.set_modifier_input(mod, key, old)
        _remove_unused_groups()
    data = data_object(obj) or next(iter(_unused_ours(obj)), None)
    if data is None:
        mesh = bpy.data.meshes.new(f"DeformRT {obj.name}")
        data = bpy.data.objects.new(f"DeformRT {obj.name}", mesh)
        data.hide_render = True
        data.hide_viewport = True
        _hidden_collection(scene, DATA_COLLECTION).objects.link(data)
    data[OWNER_PROPERTY] = obj
    _fill_data_mesh(data.data, shown.offsets, shown.hidden, shown.cage)
    if shown.made_for is not None:
        data[FINGERPRINT_PROPERTY] = shown.made_for
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


def check_cage(obj, on: bool) -> bool:
    """Switch the check that passes a mesh moved off the result's cage through (``result_nodes``) off
    or back on, for a result written with its cage (a motion blur step shows the frame's result on
    the pose a fraction of a frame away). Returns whether the object has such a result."""
    data = data_object(obj)
    mesh = data.data if data is not None else None
    tolerance = mesh.attributes.get(result_nodes.CAGE_TOLERANCE_ATTRIBUTE) if mesh is not None else None
    if tolerance is None or not len(tolerance.data) or tolerance.data[0].value <= 0:  # written without its cage
        return False
    known = mesh.attributes.get(result_nodes.CAGE_KNOWN_ATTRIBUTE)
    if known is not None and len(known.data) and known.data[0].value != on:
        _set_points(mesh, result_nodes.CAGE_KNOWN_ATTRIBUTE, "BOOLEAN", np.full(len(mesh.vertices), on))
        mesh.update()
    return True


def fits_now(obj, depsgraph, subdivide=False) -> bool | None:
    """Whether the garment's vertices are where its result was made for, as its evaluated mesh
    says (``result_nodes.FITS_ATTRIBUTE``); None when that cannot be read (no result shown, an
    older group) or, unless ``subdivide``, not without subdividing on the CPU what the viewport
    leaves to the GPU (checked on every edit and frame, that cost seconds a frame)."""
    if not subdivide and result_stack.subdivided_on_demand(obj):
        return None
    mesh = obj.evaluated_get(depsgraph).data
    attr = mesh.attributes.get(result_nodes.FITS_ATTRIBUTE) if mesh is not None else None
    if attr is None or attr.data_type != "BOOLEAN" or not len(attr.data):
        return None
    return bool(attr.data[0].value)


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


def _unused_ours(owner=None) -> list:
    """Data DeformRT made (marked, in its collection) that no modifier uses any more (the field was
    set to something else, the modifier replaced by Copy Modifiers, or applied by hand); only
    ``owner``'s when given."""
    coll = bpy.data.collections.get(DATA_COLLECTION)
    if coll is None:
        return []
    used = {linked_data(o) for o in bpy.data.objects if o.type == "MESH"}
    return [d for d in coll.objects if d not in used and _made_by_us(d) and OWNER_PROPERTY in d
            and (owner is None or d[OWNER_PROPERTY] == owner)]


def _drop_empty_collection() -> None:
    coll = bpy.data.collections.get(DATA_COLLECTION)
    if coll is not None and not coll.objects and not coll.children:
        bpy.data.collections.remove(coll)


def _remove_unused_groups():
    for group in [g for g in bpy.data.node_groups if result_nodes.is_our_group(g) and g.users == 0]:
        bpy.data.node_groups.remove(group)


def _remove_data(data) -> None:
    mesh = data.data
    bpy.data.objects.remove(data)
    if mesh is not None and mesh.users == 0:
        bpy.data.meshes.remove(mesh)


def remove_unused_data() -> int:
    """Delete the data DeformRT made that no modifier uses any more (its modifier applied or
    removed by hand); returns how many."""
    unused = _unused_ours()
    for data in unused:
        _remove_data(data)
    _drop_empty_collection()
    return len(unused)


def clear(obj) -> bool:
    """Remove the garment's result modifiers and the data DeformRT made for it; an object in the
    field that DeformRT did not make for this garment is left alone. Returns whether it had one."""
    mods = [m for m in obj.modifiers if result_stack.is_result(m)]
    if not mods:
        return False
    own = data_object(obj)
    for mod in mods:
        obj.modifiers.remove(mod)
    if own is not None and not any(linked_data(o) == own for o in bpy.data.objects if o.type == "MESH"):
        _remove_data(own)
    for data in _unused_ours(obj):
        _remove_data(data)
    _drop_empty_collection()
    _remove_unused_groups()
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

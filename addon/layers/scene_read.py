"""Reading the tagged scene for the layering: which objects take part (checked, with a message
that says what to change), their evaluated meshes as fitted (any earlier result switched off),
the body's parts, the garments' painted parts and stored global normals, and the probe distances
the panel sets. The render engine reads its layers through here too."""

from contextlib import contextmanager
from dataclasses import dataclass

import bpy
import numpy as np
import trimesh

from ...core.geometry.vectors import inverse3, matmul3
from ...core.layering.segmentation import get_scheme, part_of_group, segments_from_groups
from ..io import mesh_io
from . import frame_memory, result_stack, results, scene_roles, staleness

PART_GROUP_PREFIX = "DRT_"
GLOBAL_NORMAL_ATTRIBUTE = "deformrt_global_normal"
GLOBAL_NORMAL_COLOR = "deformrt_global_normal_color"


class LayeringInputError(ValueError):
    """The scene cannot be resolved as it is; the message says what to change."""


def layered_objects(scene):
    """(body, garments inner to outer) after checking the scene can be resolved."""
    odd = [o for o in scene_roles.tagged(scene, "BODY") + scene_roles.tagged(scene, "GARMENT") if o.type != "MESH"]
    if odd:
        raise LayeringInputError(f"{odd[0].name} is a {odd[0].type.lower()}, not a mesh: clear its role")
    bodies = scene_roles.bodies(scene)
    if not bodies:
        raise LayeringInputError("No body: select the figure and press Tag as Body")
    if len(bodies) > 1:
        raise LayeringInputError(f"More than one body ({', '.join(o.name for o in bodies)}): keep one")
    garments = scene_roles.garments(scene)
    if not garments:
        raise LayeringInputError("No garments: select them and press Tag as Garments")
    view_layer = bpy.context.view_layer
    for obj in [bodies[0], *garments]:
        hidden = obj.hide_viewport or (view_layer is not None and obj.name in view_layer.objects
                                       and obj.hide_get(view_layer=view_layer))
        if hidden or (view_layer is not None and obj.name not in view_layer.objects):
            raise LayeringInputError(f"{obj.name} is hidden or not in the view layer: show it or clear its role")
    for obj in [bodies[0], *garments]:
        linked = obj.library or obj.data.library
        if linked is not None:
            # the result is a modifier and data on the object: linked data cannot take them
            raise LayeringInputError(f"{obj.name} is linked from {linked.filepath}: make a library override of it "
                                     "(Object > Library Override > Make) or make it local, then resolve")
    layers = [o.deformrt.layer for o in garments]
    for a, b in zip(garments, garments[1:], strict=False):
        if a.deformrt.layer == b.deformrt.layer:
            raise LayeringInputError(f"{a.name} and {b.name} are both on layer {a.deformrt.layer}: "
                                     "move one with the arrows in the Layers panel")
    if min(layers) < 1:
        raise LayeringInputError(f"{garments[0].name} is on layer {min(layers)}: garments start at layer 1")
    return bodies[0], garments


def part_groups(obj, scheme) -> list:
    """The object's DRT_<part> vertex group names of ``scheme``, in the scheme's order."""
    names = [PART_GROUP_PREFIX + p for p in scheme.parts]
    return [n for n in names if n in obj.vertex_groups]


def body_parts(body, scheme_name, vertices, painted_groups=True, groups=True, depsgraph=None):
    """Part id per evaluated body vertex, and where it came from; (None, reason) without.

    In order: DRT_<part> vertex groups (auto-segmented or painted), the stored part
    attribute of the sample figures, a rig's deform groups named after the limbs. Reading
    groups adds a modifier for a moment; ``groups`` False (inside a render) reads only the
    stored attribute, from ``depsgraph`` when given."""
    if scheme_name == "NONE":
        return None, "none: the whole body as one"
    scheme = get_scheme(scheme_name)
    painted = ([n for n in part_groups(body, scheme) if n != PART_GROUP_PREFIX + "skirt"]
               if painted_groups and groups else [])
    if painted:
        w = mesh_io.read_vertex_groups(body, painted)
        names = [n[len(PART_GROUP_PREFIX):] for n in painted]
        return segments_from_groups(w, names, scheme, vertices), "the painted DRT_ part groups"
    stored = mesh_io.read_point_ints(body, scene_roles.PART_ATTRIBUTE[scheme.name], depsgraph)
    if stored is not None:
        return np.clip(stored, 0, scheme.skirt - 1), "the parts stored with the figure"
    names = [g.name for g in body.vertex_groups if not g.name.startswith(PART_GROUP_PREFIX)] if groups else []
    if names and len({part_of_group(n, scheme) for n in names}) > 1:
        w = mesh_io.read_vertex_groups(body, names)
        return segments_from_groups(w, names, scheme, vertices), "the rig's vertex groups"
    return None, "its separate pieces (no part groups on the body)"


def garment_parts(garment, scheme_name):
    """Segment per evaluated garment vertex from its DRT_<part> groups, or None (nearest body part)."""
    if scheme_name == "NONE":
        return None
    scheme = get_scheme(scheme_name)
    painted = part_groups(garment, scheme)
    if not painted:
        return None
    w = mesh_io.read_vertex_groups(garment, painted)
    ids = np.array([scheme.parts.index(n[len(PART_GROUP_PREFIX):]) for n in painted])
    return ids[np.argmax(w, axis=1)]


@contextmanager
def results_bypassed(garments):
    """Garments evaluate as their own stack makes them (any earlier result switched off)."""
    with staleness.paused():
        shown = [results.set_enabled(g, False) for g in garments]
        try:
            yield
        finally:
            for g, was in zip(garments, shown, strict=True):
                if was:
                    results.set_enabled(g, True)


@contextmanager
def fitted_cages(garments):
    """Garments evaluate as fitted, up to where their result sits (``result_stack``): the
    vertices a result is made for, the same in the viewport and the render."""
    with results_bypassed(garments), result_stack.cages_shown(garments):
        yield


def as_trimesh(a):
    """MeshArrays as the trimesh core's resolve takes (no processing: the indices stay ours)."""
    return trimesh.Trimesh(a.vertices, a.triangles, process=False, validate=False)


def read_meshes(objs, depsgraph):
    """Evaluated meshes of ``objs`` (world space), each checked to sit at finite positions: a cloth
    solver that blew up or a driver dividing by zero is named here, before anything is changed,
    not by its index in a list deep in core."""
    arrays = [mesh_io.read_mesh(o, depsgraph) for o in objs]
    for obj, a in zip(objs, arrays, strict=True):
        lost = int((~np.isfinite(a.vertices).all(axis=1)).sum())
        if lost:
            raise LayeringInputError(f"{obj.name} has {lost} vertices at no finite position (NaN or infinite) "
                                     "after its modifiers: fix or re-bake it; nothing was changed")
    return arrays


def _parts_key(body, scheme_name) -> tuple:
    """What the body's parts are read from: its groups (names), vertex count and the scheme."""
    return body.name, len(body.data.vertices), scheme_name, tuple(g.name for g in body.vertex_groups)


@dataclass
class LayeredScene:
    """The tagged objects and what the resolve reads of them (world space, no result applied)."""

    body: object
    garments: list
    arrays: list  # MeshArrays: the body's first
    parts: object  # part id per body vertex, or None
    parts_source: str
    garment_parts: list  # per garment, part ids from its painted groups, or None
    garment_normals: list  # per garment, stored global normals (world space), or None


def read_scene(scene, scheme_name, playing=False) -> LayeredScene:
    """Evaluated body and garments (world space) without any earlier result applied. ``playing``
    (frame after frame): the body's parts, read from its groups on the first frame, are kept
    while its groups are the same."""
    body, garments = layered_objects(scene)
    for obj in [body, *garments]:  # every result must have its place before any is written
        problem = result_stack.placement_problem(obj)
        if problem:
            raise LayeringInputError(problem)
    for obj in [body, *garments]:  # read as fitted, not through what another field points at
        results.disconnect_foreign(obj)
        mod = results.result_modifier(obj)
        if mod is not None:  # read where the result goes: a modifier added after it since runs above it
            result_stack.place(obj, mod)
    # the body too, up to where its own result (covered skin) goes: a subdivided body is smoothed
    # inside its cage, so cloth clear of the cage is clear of what renders
    with fitted_cages([body, *garments]):
        depsgraph = bpy.context.evaluated_depsgraph_get()
        arrays = read_meshes([body, *garments], depsgraph)
        key = (*_parts_key(body, scheme_name), len(arrays[0].vertices))
        kept = frame_memory.parts.get(key) if playing else None
        if kept is None:
            kept = body_parts(body, scheme_name, arrays[0].vertices)
            if playing:
                frame_memory.parts.put(key, kept)
        parts, source = kept
        g_parts = [garment_parts(g, scheme_name) for g in garments]
        g_normals = []
        for g, a in zip(garments, arrays[1:], strict=True):
            n = mesh_io.read_point_vectors(g, GLOBAL_NORMAL_ATTRIBUTE, depsgraph)
            # stored in object space; normals turn with the inverse transpose
            g_normals.append(None if n is None or len(n) != len(a.vertices)
                             else matmul3(n, inverse3(a.matrix_world[:3, :3])))
    return LayeredScene(body, garments, arrays, parts, source, g_parts, g_normals)


def probe_distances(settings, has_parts):
    """The probe distance to pass to core: None (each part's radius), one distance, or one per
    part with NaN where the part keeps its default (the panel's per-part overrides)."""
    base = settings.probe_distance if settings.probe_distance > 0 else np.nan
    if settings.scheme == "NONE" or not has_parts or not len(settings.part_probes):
        return None if np.isnan(base) else float(base)
    parts = get_scheme(settings.scheme).parts
    out = np.full(len(parts), base)
    for item in settings.part_probes:
        if item.part in parts:
            out[parts.index(item.part)] = item.distance
    return out

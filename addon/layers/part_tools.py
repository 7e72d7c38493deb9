"""What the resolve finds, written onto the objects for the user to see and change: each body
part as a DRT_<part> vertex group (auto-segmented, repaintable), each garment's global normals as
a vector attribute (and a colour to look at them), and taking those away again."""

import bpy
import numpy as np

from ...core.layering.resolve import resolve_layers
from ...core.layering.segmentation import get_scheme
from ..io import mesh_io
from . import scene_roles
from .scene_read import (
    GLOBAL_NORMAL_ATTRIBUTE,
    GLOBAL_NORMAL_COLOR,
    PART_GROUP_PREFIX,
    LayeringInputError,
    as_trimesh,
    body_parts,
    fitted_cages,
    layered_objects,
    read_meshes,
    read_scene,
)


def found_without_moves(arrays, **params):
    """resolve_layers with every moving stage off: segments, skirts and global normals."""
    return resolve_layers(as_trimesh(arrays[0]), [as_trimesh(a) for a in arrays[1:]], boundary_pass=False,
                          push_behind=False, outer_room=False, remove_hidden=False, **params)


def _check_own_vertices(objs, arrays, what):
    for obj, a in zip(objs, arrays, strict=True):
        if len(obj.data.vertices) != len(a.vertices):
            raise LayeringInputError(f"{obj.name}'s modifiers change its vertex count ({len(obj.data.vertices)} -> "
                                     f"{len(a.vertices)}): {what}")


def _write_parts(obj, parts, scheme):
    for group in [g for g in obj.vertex_groups if g.name.startswith(PART_GROUP_PREFIX)]:
        obj.vertex_groups.remove(group)
    present = np.unique(parts)
    onehot = (parts[:, None] == present[None, :]).astype(np.float64)
    mesh_io.write_vertex_groups(obj, [PART_GROUP_PREFIX + scheme.parts[p] for p in present], onehot)


def auto_segment(scene) -> str:
    """Write DRT_<part> vertex groups on the body and every garment (skirts found), from the
    body's rig groups or stored parts; the user can repaint them and the resolve honours them."""
    settings = scene.deformrt
    if settings.scheme == "NONE":
        raise LayeringInputError("Pick a part scheme (5 or 13 parts) to segment by")
    scheme = get_scheme(settings.scheme)
    body, garments = layered_objects(scene)
    with fitted_cages([body, *garments]):  # the body's own result (the covered skin left out) too
        depsgraph = bpy.context.evaluated_depsgraph_get()
        arrays = read_meshes([body, *garments], depsgraph)
        parts, source = body_parts(body, settings.scheme, arrays[0].vertices, painted_groups=False)
        if parts is None:
            raise LayeringInputError(f"{body.name} has no rig vertex groups or stored parts to segment by: "
                                     "paint DRT_<part> groups (DRT_torso, DRT_left_arm, ...) by hand")
        found = found_without_moves(arrays, body_segments=parts, scheme=scheme)
        # checked for all before writing any: nothing is left half-segmented
        _check_own_vertices([body, *garments], arrays, "part groups need the mesh's own vertices; apply them "
                            "or paint DRT_<part> groups by hand")
        _write_parts(body, parts, scheme)
        for obj, seg in zip(garments, found.segments, strict=True):
            _write_parts(obj, seg, scheme)
    skirts = [garments[i].name for i in found.skirts]
    return (f"Segmented {body.name} and {len(garments)} garments into {scheme.name} parts from {source}"
            + (f"; skirts: {', '.join(skirts)}" if skirts else ""))


def transfer_normals(scene) -> str:
    """Store each garment's global normals (the normal of the nearest body point, or the skirt
    hull's) as a vector attribute the resolve then uses, plus a colour attribute to see them."""
    settings = scene.deformrt
    read = read_scene(scene, settings.scheme)
    _check_own_vertices(read.garments, read.arrays[1:], "apply them first")
    params = {}
    if read.parts is not None:
        params.update(body_segments=read.parts, scheme=settings.scheme, garment_segments=read.garment_parts)
    found = found_without_moves(read.arrays, **params)
    garments = read.garments
    for obj, a, n in zip(garments, read.arrays[1:], found.global_normals, strict=True):
        local = n @ a.matrix_world[:3, :3]  # the inverse of the read's turn
        local /= np.maximum(np.linalg.norm(local, axis=1, keepdims=True), 1e-30)
        mesh_io.write_point_vectors(obj, GLOBAL_NORMAL_ATTRIBUTE, local, GLOBAL_NORMAL_COLOR)
    return (f"Stored global normals on {len(garments)} garments as '{GLOBAL_NORMAL_ATTRIBUTE}' (see them: Solid "
            f"shading, Color: Attribute, '{GLOBAL_NORMAL_COLOR}'); the resolve follows them until removed")


def remove_normals(scene) -> int:
    count = 0
    for obj in scene_roles.garments(scene):
        for name in (GLOBAL_NORMAL_ATTRIBUTE, GLOBAL_NORMAL_COLOR):
            attr = obj.data.attributes.get(name)
            if attr is not None:
                obj.data.attributes.remove(attr)
                count += 1
    return count

"""Figures in Blender: a mesh body with one vertex group per joint, an armature that deforms it,
and the Skin-modifier body built from a stick skeleton."""

import bpy
import numpy as np

from ..addon.io import mesh_io
from ..addon.layers.scene_roles import PART_ATTRIBUTE
from ..core.layering.segmentation import segments_from_groups
from .figures import Figure, bone_weights


def _armature(fig: Figure, collection, name: str):
    data = bpy.data.armatures.new(f"{name}Rig")
    rig = bpy.data.objects.new(f"{name}Rig", data)
    collection.objects.link(rig)
    view_layer = bpy.context.view_layer
    view_layer.update()
    view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    tails = fig.bone_tails()
    bones = []
    for j, jname in enumerate(fig.joint_names):
        b = data.edit_bones.new(jname)
        b.head, b.tail = fig.joints[j], tails[j]
        bones.append(b)
    for j, p in enumerate(fig.parents):
        if p >= 0:
            bones[j].parent = bones[p]
    bpy.ops.object.mode_set(mode="OBJECT")
    data.display_type = "STICK"
    return rig


def figure_object(fig: Figure, collection):
    """The body mesh (role BODY, layer 0) skinned to a new armature; returns (body, rig)."""
    body = mesh_io.new_mesh_object(fig.name, fig.vertices, fig.faces, collection)
    body.deformrt.role, body.deformrt.layer = "BODY", 0
    mesh_io.write_vertex_groups(body, fig.joint_names, fig.weights)
    # body parts of both schemes, read back by the operators and the CLI without group lookups
    for scheme in ("S5", "S13"):
        parts = segments_from_groups(fig.weights, fig.joint_names, scheme, vertices=fig.vertices)
        mesh_io.write_point_ints(body, PART_ATTRIBUTE[scheme], parts)
    rig = _armature(fig, collection, fig.name)
    body.parent = rig
    mod = body.modifiers.new("Armature", "ARMATURE")
    mod.object = rig
    return body, rig


def skin_body(fig: Figure, subdivisions: int = 3) -> Figure:
    """Skin the stick figure with Blender's Skin modifier (+ subdivision); returns the figure
    with its vertices, faces and bone-distance skin weights filled in."""
    edges = np.array([(p, j) for j, p in enumerate(fig.parents) if p >= 0])
    mesh = bpy.data.meshes.new("_stick")
    mesh.from_pydata(fig.joints.tolist(), edges.tolist(), [])
    obj = bpy.data.objects.new("_stick", mesh)
    bpy.context.scene.collection.objects.link(obj)
    try:
        obj.modifiers.new("Skin", "SKIN")
        layer = mesh.skin_vertices[0].data
        layer.foreach_set("radius", fig.radii.astype(np.float32).ravel())
        root = np.zeros(len(fig.joints), dtype=bool)
        root[fig.parents < 0] = True
        layer.foreach_set("use_root", root)
        sub = obj.modifiers.new("Subdivision", "SUBSURF")
        sub.levels = sub.render_levels = subdivisions
        arrays = mesh_io.read_mesh(obj, world=True)
    finally:
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)
    fig.vertices, fig.faces = arrays.vertices, arrays.triangles
    fig.weights = bone_weights(fig.vertices, fig)
    return fig

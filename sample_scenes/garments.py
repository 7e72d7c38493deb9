"""Garments fitted to a figure one at a time, draped with Blender's cloth simulation.

Envelope (voxel remesh of the body) -> cut and eased (fitting.py, numpy) -> cloth drape with
the body as collider, pinned where the garment hangs -> pushed clear of the body. Each
garment alone clears the body; together they cross, as garments made separately do.
"""

from __future__ import annotations

import bpy
import numpy as np

from ..addon.io import mesh_io
from . import fitting
from .figures import Figure


def envelope(fig: Figure, voxel: float):
    """A closed surface around the whole body (its parts merged), from the voxel remesher."""
    mesh = bpy.data.meshes.new("_envelope")
    mesh_io.fill_mesh(mesh, fig.vertices, fig.faces)
    obj = bpy.data.objects.new("_envelope", mesh)
    bpy.context.scene.collection.objects.link(obj)
    try:
        mod = obj.modifiers.new("Remesh", "REMESH")
        mod.mode, mod.voxel_size, mod.adaptivity = "VOXEL", voxel, 0.0
        arrays = mesh_io.read_mesh(obj)
    finally:
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)
    return arrays.vertices, arrays.triangles


def cut_garment(fig: Figure, part, env, kind: str, ease: float, edge: float):
    """Vertices and faces of one garment before draping."""
    spec = fitting.CUTS[kind]
    if isinstance(spec, fitting.Tube):
        return fitting.tube_garment(fig, part, spec, ease, edge)
    ev, ef = env
    cover = fitting.cover_mask(ev, fitting.transfer_parts(ev, fig, part), fig, spec)
    used, faces = fitting.keep_faces(ef, cover)
    if not len(faces):
        raise ValueError(f"{kind}: the cut covers none of the envelope")
    # ease along the envelope's own normals (taken on the whole envelope: no rim effects)
    v = fitting.offset(ev, ef, ease)[used]
    return v, faces


def drape(garment, body, frames: int, pin, collision_distance: float, seed: int = 0):
    """Run the cloth simulation on ``garment`` (an object) for ``frames`` frames with ``body``
    as the collider, ``pin`` (bool per vertex) held; the last frame becomes its mesh."""
    if frames <= 0:
        return
    scene = bpy.context.scene
    names = ["_pin"]
    group = garment.vertex_groups.new(name=names[0])
    ids = np.flatnonzero(pin)
    if len(ids):
        group.add(ids.tolist(), 1.0, "REPLACE")
    col = body.modifiers.new("_collision", "COLLISION")
    body.collision.thickness_outer = collision_distance
    cloth = garment.modifiers.new("_cloth", "CLOTH")
    s = cloth.settings
    s.quality = 5
    s.mass = 0.25
    s.tension_stiffness = s.compression_stiffness = 15.0
    s.shear_stiffness = 5.0
    s.bending_stiffness = 0.2
    s.vertex_group_mass = names[0]
    # a little growth makes the cloth buckle into folds as it settles
    s.shrink_min = -0.02
    cloth.collision_settings.distance_min = collision_distance
    cloth.collision_settings.use_self_collision = False
    cloth.point_cache.frame_start, cloth.point_cache.frame_end = 1, frames
    try:
        for f in range(1, frames + 1):
            scene.frame_set(f)
        arrays = mesh_io.read_mesh(garment, world=False)
    finally:
        garment.modifiers.remove(cloth)
        body.modifiers.remove(col)
        garment.vertex_groups.remove(group)
        scene.frame_set(1)
    count = len(garment.data.vertices)
    if len(arrays.vertices) != count:
        raise RuntimeError("the cloth simulation changed the garment's vertex count")
    garment.data.vertices.foreach_set("co", arrays.vertices.astype(np.float32).ravel())
    garment.data.update()


def pin_mask(vertices, kind: str, fig: Figure) -> np.ndarray:
    """Where a garment hangs from: shoulders for tops and dresses, the waistband for the rest."""
    z = vertices[:, 2]
    if kind in ("pants", "shorts", "skirt"):
        return z > z.max() - 0.03
    shoulder_x = min(abs(fig.joints[fig.limbs[f"upper_arm.{s}"][0], 0]) for s in "LR")
    return (z > fig.heights["armpit"] + 0.02) & (np.abs(vertices[:, 0]) < shoulder_x)

"""A real outfit made by artists: MakeHuman's default young female in its CC0 sports suit (top and
leggings) under its casual suit (t-shirt and jeans), each fitted to the body alone with MakeHuman's
own proxy fit, as an MPFB2 user dresses a character (assets/makehuman/, licence beside them). Worn
together they cut through each other and the skin; a Subdivision (viewport 1, render 2) on each
mesh, as MakeHuman's proxies are meant to be seen."""

from pathlib import Path

import bpy
import mathutils
import numpy as np

from ..addon.io import mesh_io
from . import studio

ASSETS = Path(__file__).parent / "assets" / "makehuman"
OUTFIT = (  # inner to outer: name, file, colour
    ("Sports suit", "female_sportsuit01", (0.12, 0.32, 0.7, 1.0)),
    ("Casual suit", "female_casualsuit01", (0.85, 0.55, 0.15, 1.0)),
)


# MakeHuman's origin is at the hips: the feet of this body go on z = 0, as the other figures'
FLOOR_SHIFT = (0.0, 0.0, 0.81829)


def _arrays(name):
    z = np.load(ASSETS / f"{name}.npz")
    return z["vertices"].astype(np.float64) + FLOOR_SHIFT, z["faces"].astype(np.int64)


def build(seed: int = 0, subdivision: bool = True):
    """Replace the current scene's contents with the outfit; returns (body, garments). ``seed`` is
    unused (the meshes are data): every sample scene builder takes one."""
    scene = studio.empty_scene("MakeHuman")
    col = scene.collection
    body = mesh_io.new_mesh_object("Body", *_arrays("body_female"), col)
    body.deformrt.role, body.deformrt.layer = "BODY", 0
    studio.material(body, "Skin", (0.8, 0.6, 0.48, 1.0), roughness=0.5)
    garments = []
    for layer, (name, stem, colour) in enumerate(OUTFIT, start=1):
        obj = mesh_io.new_mesh_object(name, *_arrays(stem), col)
        obj.deformrt.role, obj.deformrt.layer = "GARMENT", layer
        studio.material(obj, name, colour, roughness=0.8)
        garments.append(obj)
    if subdivision:
        for obj in (body, *garments):
            mod = obj.modifiers.new("Subdivision", "SUBSURF")
            mod.levels, mod.render_levels = 1, 2
    studio.camera_and_lights(scene, target=(0.0, 0.0, 0.85), distance=3.6, elevation_deg=6.0, azimuth_deg=-25.0)
    return body, garments


# the animated figure: rest to MakeHuman's run pose and back, then to its gym pose and back
RAMPS = (("ramp_run01", False), ("ramp_run01", True), ("ramp_gym01", False), ("ramp_gym01", True))
KEY_EVERY = 4  # frames between keys (Blender interpolates between them)


def build_animated(seed: int = 0, subdivision: bool = True):
    """The outfit on MakeHuman's default skeleton as an MPFB2 user has it: an Armature, each mesh
    weighted to its bones (the garments' weights from the body's through their .mhclo binding) with
    an Armature modifier first in its stack, and an action over 96 frames built from MakeHuman's
    poses. Returns (body, garments, armature)."""
    from .posed import Rig

    body, garments = build(seed=seed, subdivision=subdivision)
    scene = bpy.context.scene
    rig = Rig()
    arm = _armature(scene, rig)
    for obj, mesh in zip([body, *garments], [rig.body, *rig.garments], strict=True):
        dense = mesh.weights.toarray()
        used = np.flatnonzero(dense.any(axis=0))
        mesh_io.write_vertex_groups(obj, [rig.bones[b] for b in used], dense[:, used])
        mod = obj.modifiers.new("Armature", "ARMATURE")
        mod.object = arm
        obj.modifiers.move(len(obj.modifiers) - 1, 0)  # first, as MPFB2 puts it
        obj.parent = arm
        obj.matrix_parent_inverse = arm.matrix_world.inverted()  # the meshes carry the floor shift
    frames = np.concatenate([rig.animations[name][::-1] if back else rig.animations[name] for name, back in RAMPS])
    _keyframes(arm, rig, frames)
    scene.frame_start, scene.frame_end = 1, len(frames)
    scene.frame_set(1)
    return body, garments, arm


def _armature(scene, rig):
    """One bone per skinning matrix, each at rest where its vertices are (no parents: the poses
    give every bone's own matrix), the armature carrying the figure's floor shift."""
    data = bpy.data.armatures.new("MakeHuman")
    arm = bpy.data.objects.new("MakeHuman", data)
    scene.collection.objects.link(arm)
    arm.location = FLOOR_SHIFT
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    w = rig.body.weights.tocsc()
    for b, name in enumerate(rig.bones):
        col = w[:, b]
        head = (col.T @ rig.body.rest).ravel() / col.sum() if col.nnz else np.zeros(3)
        bone = data.edit_bones.new(name)
        bone.head, bone.tail = tuple(head), tuple(head + (0.0, 0.0, 0.04))
    bpy.ops.object.mode_set(mode="OBJECT")
    return arm


def _keyframes(arm, rig, frames):
    """pose_bone.matrix = M_b R_b each keyed frame (R_b the bone's rest in the armature), so the
    Armature modifier deforms a vertex by sum_b w_b M_b v, the poses' skinning."""
    rest = {pb.name: np.array(pb.bone.matrix_local) for pb in arm.pose.bones}
    last = {}
    for f in sorted({*range(0, len(frames), KEY_EVERY), len(frames) - 1}):
        for b, name in enumerate(rig.bones):
            pb = arm.pose.bones[name]
            pb.matrix = mathutils.Matrix((frames[f][b] @ rest[name]).tolist())
            # q and -q are one rotation, but Blender interpolates the four numbers: a key on the other
            # side swings the bone the long way round between keys (a handstand's arms and legs went
            # 0.5 m off their path mid-way, 340 mm a frame per frame against 40)
            q = pb.rotation_quaternion.copy()
            if name in last:
                q.make_compatible(last[name])
                pb.rotation_quaternion = q
            last[name] = q
            for path in ("location", "rotation_quaternion", "scale"):
                pb.keyframe_insert(path, frame=f + 1)

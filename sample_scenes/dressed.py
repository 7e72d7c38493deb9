"""Dressed figures: the thesis' layered-garment runs (Fig. 4.12, 4.13) and a posed figure.

Every garment is fitted to the body on its own (cut from the body's envelope with its own
ease and a few millimetres of seeded fold noise, then draped): alone it clears the body,
worn together with the others it crosses them, which is what DeformRT fixes.
"""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np
from scipy.spatial import cKDTree

from ..addon.io import mesh_io
from ..core.geometry.normals import vertex_normals
from . import bodies, figures, fitting, garments, studio

PALETTE = {
    "jumpsuit": (0.20, 0.45, 0.30, 1.0),
    "pants": (0.15, 0.20, 0.40, 1.0),
    "shorts": (0.30, 0.25, 0.20, 1.0),
    "shirt": (0.85, 0.80, 0.70, 1.0),
    "tshirt": (0.80, 0.30, 0.20, 1.0),
    "jacket": (0.45, 0.30, 0.20, 1.0),
    "dress": (0.60, 0.15, 0.35, 1.0),
    "skirt": (0.25, 0.35, 0.60, 1.0),
}


@dataclass(frozen=True)
class Layer:
    kind: str  # a key of fitting.CUTS
    ease: float  # metres between the body's envelope and the garment, before draping
    name: str = ""
    colour: tuple | None = None


# (a) Fig. 4.12: body + jumpsuit + pants + two shirts, about 250k triangles
FIG_4_12 = (Layer("jumpsuit", 0.010), Layer("pants", 0.012), Layer("shirt", 0.011),
            Layer("shirt", 0.013, "Overshirt", (0.35, 0.55, 0.75, 1.0)))
# (b) Fig. 4.13: body + pants + shirt + two dresses, about 121k triangles
FIG_4_13 = (Layer("pants", 0.012), Layer("shirt", 0.010), Layer("dress", 0.012),
            Layer("dress", 0.010, "Overdress", (0.85, 0.65, 0.25, 1.0)))


def _figure(name: str):
    if name == "wooden":
        return figures.wooden()
    if name == "stocky":
        return bodies.skin_body(figures.stick_figure())
    raise ValueError(f"unknown figure {name!r}; use 'wooden' or 'stocky'")


def _fold_noise(v, normals, rng, amplitude, wavelength=0.12, waves=6):
    """Smooth bumps along the normals: a few random plane waves, like loose cloth."""
    out = np.zeros(len(v))
    for _ in range(waves):
        k = rng.normal(size=3)
        k *= 2 * np.pi / (wavelength * np.linalg.norm(k))
        out += np.sin(v @ k + rng.uniform(0, 2 * np.pi)) / np.sqrt(waves)
    return v + normals * (amplitude * out)[:, None]


@dataclass(frozen=True)
class Tailoring:
    """How garments are made: the voxel of the body's envelope they are cut from (m), the cloth
    frames they are draped for, their folds' amplitude and the gap they keep from the body (m)."""

    voxel: float = 0.008
    frames: int = 8
    fold_m: float = 0.004
    gap_m: float = 0.003


def dress(figure: str, layers, seed: int = 0, tailoring: Tailoring = Tailoring(), scene_name: str = "Dressed"):
    """Replace the scene's contents with a figure wearing ``layers`` (inner to outer).

    Returns (body, rig, garments). Deterministic for a given seed.
    """
    voxel, frames, fold_m, gap_m = tailoring.voxel, tailoring.frames, tailoring.fold_m, tailoring.gap_m
    rng = np.random.default_rng(seed)
    scene = studio.empty_scene(scene_name)
    col = scene.collection
    fig = _figure(figure)
    body, rig = bodies.figure_object(fig, col)
    studio.material(body, "Skin", (0.80, 0.62, 0.48, 1.0))
    part = fitting.body_parts(fig)
    env = garments.envelope(fig, voxel)
    made = []
    for k, layer in enumerate(layers, start=1):
        v, f = garments.cut_garment(fig, part, env, layer.kind, layer.ease, voxel)
        v = _fold_noise(v, vertex_normals(v, f), rng, fold_m)
        v = fitting.clear_of_body(v, fig.vertices, fig.faces, gap_m)
        name = layer.name or layer.kind.capitalize()
        obj = mesh_io.new_mesh_object(name, v, f, col)
        obj.deformrt.role, obj.deformrt.layer = "GARMENT", k
        studio.material(obj, name, layer.colour or PALETTE[layer.kind])
        garments.drape(obj, body, frames, garments.pin_mask(v, layer.kind, fig), gap_m)
        # the cloth solver keeps its distance only approximately, and drapes without self-collision:
        # every garment ends clear of the body and of itself
        draped, _ = fitting.untangle(mesh_io.read_mesh(obj, world=False).vertices, f)
        obj.data.vertices.foreach_set("co", fitting.clear_of_body(draped, fig.vertices, fig.faces, gap_m)
                                      .astype(np.float32).ravel())
        obj.data.update()
        _skin_to(obj, fig, rig)
        made.append(obj)
    height = float(fig.vertices[:, 2].max())
    studio.camera_and_lights(scene, target=(0.0, 0.0, 0.55 * height), distance=3.4 * height / 1.75,
                             azimuth_deg=-25.0)
    return body, rig, made


def _skin_to(obj, fig, rig):
    """The garment follows the skeleton: each vertex takes the weights of its nearest body vertex."""
    v = mesh_io.read_mesh(obj, world=False).vertices
    _, near = cKDTree(fig.vertices).query(v, workers=-1)
    mesh_io.write_vertex_groups(obj, fig.joint_names, fig.weights[near])
    obj.parent = rig
    mod = obj.modifiers.new("Armature", "ARMATURE")
    mod.object = rig


def fig_4_12(seed: int = 0, voxel: float = 0.0070, frames: int = 8):
    return dress("wooden", FIG_4_12, seed, Tailoring(voxel, frames), scene_name="Fig 4.12")


def fig_4_13(seed: int = 0, voxel: float = 0.010, frames: int = 8):
    return dress("stocky", FIG_4_13, seed, Tailoring(voxel, frames), scene_name="Fig 4.13")


def save(path, glb: bool = False) -> None:
    """Write the current file (and a .glb beside it for tools without Blender)."""
    bpy.ops.wm.save_as_mainfile(filepath=str(path), check_existing=False)
    if glb:
        bpy.ops.export_scene.gltf(filepath=str(path).rsplit(".", 1)[0] + ".glb", export_format="GLB",
                                  export_skins=True, export_animations=False)


# (c) the posed pipeline's figure: frame 1 the rest T-pose, frame 2 arms lowered, elbows and
# one leg bent. Rotations are about armature axes (x: the figure's left, y: back, z: up).
POSED_LAYERS = (Layer("tshirt", 0.010), Layer("pants", 0.012), Layer("jacket", 0.011))
POSE_2 = {
    "L_Shoulder": ((0.0, 1.0, 0.0), 65.0), "R_Shoulder": ((0.0, 1.0, 0.0), -65.0),
    "L_Elbow": ((0.0, 0.0, 1.0), -40.0), "R_Elbow": ((0.0, 0.0, 1.0), 40.0),
    "L_Hip": ((1.0, 0.0, 0.0), -30.0), "L_Knee": ((1.0, 0.0, 0.0), 45.0),
}


def pose(rig, rotations: dict, frame: int) -> None:
    """Key each named bone at ``frame`` to a rotation given about armature axes at its head;
    every other bone keys its rest pose."""
    from mathutils import Matrix

    for pb in rig.pose.bones:
        pb.rotation_mode = "QUATERNION"
        if pb.name in rotations:
            axis, degrees = rotations[pb.name]
            rest = pb.bone.matrix_local.to_3x3()
            turn = Matrix.Rotation(np.radians(degrees), 3, axis)
            pb.rotation_quaternion = (rest.inverted() @ turn @ rest).to_quaternion()
        else:
            pb.rotation_quaternion = (1.0, 0.0, 0.0, 0.0)
        pb.keyframe_insert("rotation_quaternion", frame=frame)


def posed(seed: int = 0, voxel: float = 0.010, frames: int = 8):
    """(c) A dressed figure in two poses (frames 1 and 2) for the posed pipeline."""
    body, rig, made = dress("wooden", POSED_LAYERS, seed, Tailoring(voxel, frames), scene_name="Posed")
    scene = bpy.context.scene
    pose(rig, {}, 1)
    pose(rig, POSE_2, 2)
    scene.frame_start, scene.frame_end = 1, 2
    scene.frame_set(1)
    return body, rig, made

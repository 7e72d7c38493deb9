"""Falling sheets (thesis Table 4.1, Fig. 4.15): 1-4 cloth sheets over two boxes and two spheres.

Each sheet is a square grid of ``per_sheet`` triangles (512, 2048, 8192 or 32768 in the thesis)
with Blender cloth; the primitives collide, the sheets do not collide with each other (the
thesis' setting: layered ray tracing hides what cloth-cloth collision would have prevented).
"""

import bpy
import numpy as np

from ..addon.io import mesh_io
from . import studio

THESIS_SIZES = (512, 2048, 8192, 32768)
COLOURS = ((0.80, 0.20, 0.15, 1.0), (0.15, 0.45, 0.80, 1.0), (0.90, 0.75, 0.20, 1.0), (0.25, 0.65, 0.30, 1.0))


def grid(n_side: int, size: float):
    """A square sheet of 2 * n_side^2 triangles in the xy plane, centred on the origin."""
    s = np.linspace(-size / 2, size / 2, n_side + 1)
    x, y = np.meshgrid(s, s, indexing="ij")
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    i, j = np.meshgrid(np.arange(n_side), np.arange(n_side), indexing="ij")
    a = (i * (n_side + 1) + j).ravel()
    b, c, d = a + 1, a + n_side + 1, a + n_side + 2
    return v, np.concatenate([np.column_stack([a, c, d]), np.column_stack([a, d, b])])


def build(layers: int = 2, per_sheet: int = 2048, frames: int = 120, seed: int = 0):
    """Replace the scene's contents; returns (sheets, [stage]). Sheets are layered 1..n
    bottom to top (the lowest sheet is the innermost layer); the stage (primitives and
    floor in one object) is the body."""
    if not 1 <= layers <= 4:
        raise ValueError(f"layers must be 1-4 (the thesis' range), got {layers}")
    n_side = int(round(np.sqrt(per_sheet / 2)))
    if 2 * n_side * n_side != per_sheet:
        raise ValueError(f"per_sheet must be 2 n^2 triangles (512, 2048, 8192, 32768...), got {per_sheet}")
    rng = np.random.default_rng(seed)
    scene = studio.empty_scene("Sheets")
    scene.frame_start, scene.frame_end = 1, frames
    col = scene.collection
    colliders = []
    for name, loc, dims in (("BoxA", (-0.35, -0.2, 0.15), (0.4, 0.5, 0.3)), ("BoxB", (0.4, 0.3, 0.1), (0.3, 0.3, 0.2))):
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=loc)
        obj = bpy.context.active_object
        obj.name, obj.scale = name, dims
        colliders.append(obj)
    for name, loc, r in (("SphereA", (0.3, -0.35, 0.2), 0.2), ("SphereB", (-0.25, 0.4, 0.15), 0.15)):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=r, location=loc, segments=48, ring_count=24)
        obj = bpy.context.active_object
        obj.name = name
        bpy.ops.object.shade_smooth()
        colliders.append(obj)
    for obj in colliders:
        studio.material(obj, "Primitive", (0.7, 0.7, 0.72, 1.0))
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    floor = bpy.context.active_object
    floor.name = "Floor"
    studio.material(floor, "Floor", (0.35, 0.35, 0.37, 1.0))
    # one "Stage" object (primitives and floor) the cloth collides with and DeformRT takes
    # as the body the sheets are layered over: every sheet point meets every sheet above it
    with bpy.context.temp_override(active_object=floor, selected_editable_objects=[floor, *colliders]):
        bpy.ops.object.join()
    stage = floor
    stage.name = "Stage"
    stage.modifiers.new("Collision", "COLLISION")
    stage.collision.thickness_outer = 0.005
    stage.deformrt.role, stage.deformrt.layer = "BODY", 0
    scene.deformrt.scheme = "NONE"
    # The sheets fall 6 cm apart, and folds lay lower sheets further than that over higher ones:
    # a shorter probe leaves those pieces on top (bench/cloth_probe.py measures it).
    scene.deformrt.probe_distance = 0.08
    colliders = [stage]
    sheets = []
    v, f = grid(n_side, 1.4)
    for k in range(layers):
        obj = mesh_io.new_mesh_object(f"Sheet{k + 1}", v, f, col)
        obj.location = (rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05), 0.7 + 0.06 * k)
        obj.rotation_euler = (0.0, 0.0, rng.uniform(-0.3, 0.3))
        obj.deformrt.role, obj.deformrt.layer = "GARMENT", k + 1
        cloth = obj.modifiers.new("Cloth", "CLOTH")
        cloth.settings.quality = 5
        cloth.collision_settings.use_collision = True
        cloth.collision_settings.use_self_collision = False
        cloth.collision_settings.distance_min = 0.005
        cloth.point_cache.frame_start, cloth.point_cache.frame_end = 1, frames
        studio.material(obj, f"Sheet{k + 1}", COLOURS[k])
        sheets.append(obj)
    studio.camera_and_lights(scene, target=(0.0, 0.0, 0.2), distance=3.0, elevation_deg=30.0)
    return sheets, colliders

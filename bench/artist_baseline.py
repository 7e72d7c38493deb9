"""What Blender artists do today against deformrt.resolve_layers, on the thesis' dressed figures.

Each lower garment held inside every higher one by Shrinkwrap modifiers (Project along its
normals with limit l_s, or Inside mode restricted to the vertices within l_s), the same
plus a Mask modifier hiding what a higher garment covers, and a cloth-collision settle of
the outer garments against the inner ones; then the DeformRT operator. Each is measured on
what Blender evaluates: poke-through and crossings by core.metrics, intersecting triangle
pairs by mathutils' own BVHTree.overlap as an independent check, distortion, new holes.

    .venv/bin/python -m bench.artist_baseline     # writes its section of docs/REPORT.md (~6 min)
"""

import importlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from bench.blender import load_package
from bench.report import machine, table, write_section
from core.geometry.normals import vertex_normals
from core.layering import metrics
from core.rays import RayScene

SCENES = ("fig_4_12", "fig_4_13")
SETTLE_FRAMES = 8
IMG = Path(__file__).resolve().parent.parent / "docs" / "img"


def _bpy():
    load_package()
    import bpy

    return bpy


def _sub(name):
    return importlib.import_module(f"deformrt.{name}")


def evaluated(objs):
    bpy = _bpy()
    io = _sub("addon.io.mesh_io")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return [(a.vertices, a.triangles) for a in (io.read_mesh(o, depsgraph) for o in objs)]


def bvh_overlaps(layers) -> int:
    """Intersecting triangle pairs between layers (all pairs), by mathutils' BVH."""
    from mathutils.bvhtree import BVHTree

    trees = [BVHTree.FromPolygons(v.tolist(), f.tolist(), all_triangles=True) for v, f in layers]
    return sum(len(trees[i].overlap(trees[j])) for i in range(len(trees)) for j in range(i + 1, len(trees)))


def shrinkwrap(garments, l_s, d, method):
    """Every lower garment wrapped inside each higher one, as an artist stacks the modifiers."""
    for i, g in enumerate(garments[:-1]):
        group = None
        if method == "INSIDE":
            group = _near_group(g, garments[i + 1:], l_s)
        for outer in garments[i + 1:]:
            m = g.modifiers.new(f"Shrinkwrap {outer.name}", "SHRINKWRAP")
            m.target, m.offset, m.wrap_mode = outer, d, "INSIDE"
            if method == "PROJECT":
                m.wrap_method = "PROJECT"
                m.use_negative_direction = m.use_positive_direction = True
                m.project_limit = l_s
            else:
                m.wrap_method = "NEAREST_SURFACEPOINT"
                m.vertex_group = group


def _near_group(g, outers, l_s):
    """Vertices within l_s of a higher garment (Inside mode has no distance limit of its own)."""
    io = _sub("addon.io.mesh_io")
    v = io.read_mesh(g).vertices
    from scipy.spatial import cKDTree

    near = np.zeros(len(v), dtype=bool)
    for o in outers:
        dist, _ = cKDTree(io.read_mesh(o).vertices).query(v, distance_upper_bound=l_s, workers=-1)
        near |= np.isfinite(dist)
    io.write_vertex_groups(g, ["_near"], near[:, None].astype(float))
    return "_near"


def mask_covered(garments, l_s):
    """Hide what a higher garment covers: vertices whose outward normal meets a higher
    garment within l_s (standing in for the group an artist paints), through a Mask modifier."""
    io = _sub("addon.io.mesh_io")
    fitted = [io.read_mesh(g) for g in garments]
    for i, (g, a) in enumerate(zip(garments[:-1], fitted, strict=False)):
        n = vertex_normals(a.vertices, a.triangles)
        covered = np.zeros(len(a.vertices), dtype=bool)
        for b in fitted[i + 1:]:
            covered |= RayScene(b.vertices, b.triangles).intersect(a.vertices, n, max_dist=l_s).face >= 0
        io.write_vertex_groups(g, ["_covered"], covered[:, None].astype(float))
        m = g.modifiers.new("Mask", "MASK")
        m.vertex_group, m.invert_vertex_group = "_covered", True


def cloth_settle(body, garments, d, frames):
    """Outer garments simulated as cloth without gravity against the body and the garments
    inside them (single-sided collision, distance d), for a few frames. Each cloth collides
    only with what is inside it, so the simulations do not depend on each other in a cycle."""
    bpy = _bpy()
    scene = bpy.context.scene
    for obj in (body, garments[0]):
        obj.modifiers.new("Collision", "COLLISION")
    for k, g in enumerate(garments[1:], start=1):
        inside = bpy.data.collections.new(f"_inside_{g.name}")
        for o in (body, *garments[:k]):
            inside.objects.link(o)
        cloth = g.modifiers.new("Cloth", "CLOTH")
        cloth.collision_settings.collection = inside
        s = cloth.settings
        s.quality, s.mass = 5, 0.25
        s.effector_weights.gravity = 0.0
        cloth.collision_settings.distance_min = d
        cloth.collision_settings.use_self_collision = False
        cloth.point_cache.frame_start, cloth.point_cache.frame_end = 1, frames
        g.modifiers.new("Collision", "COLLISION")  # after the cloth: collides as simulated
    for obj in (body, *garments):
        obj.collision.thickness_outer = d
        obj.collision.use_normal = True
    for f in range(1, frames + 1):
        scene.frame_set(f)


def clear_artist_work(objs):
    bpy = _bpy()
    for c in [c for c in bpy.data.collections if c.name.startswith("_inside_")]:
        bpy.data.collections.remove(c)
    for o in objs:
        for m in [m for m in o.modifiers if m.type in {"SHRINKWRAP", "MASK", "CLOTH", "COLLISION"}]:
            o.modifiers.remove(m)
        for name in ("_near", "_covered"):
            if name in o.vertex_groups:
                o.vertex_groups.remove(o.vertex_groups[name])
    bpy.context.scene.frame_set(1)


def measure_figure(name, render):
    bpy = _bpy()
    dressed, scene_read = _sub("sample_scenes.dressed"), _sub("addon.layers.scene_read")
    part_tools = _sub("addon.layers.part_tools")
    studio = _sub("sample_scenes.studio")
    body, _, garments = getattr(dressed, name)()
    objs = [body, *garments]
    scene = bpy.context.scene
    fitted = evaluated(objs)
    read = scene_read.read_scene(scene, "S5")
    st = part_tools.found_without_moves(read.arrays, body_segments=read.parts, scheme="S5").stats
    l_s, d = float(np.median(st["probe_distance"])), float(st["offset"])
    cams = metrics.camera_ring(*metrics.layer_bounds(fitted), views=8, resolution=128)

    def row(method, seconds, layers, moved=None):
        moves, stretch = [0.0], [1.0]
        for (v0, f), (v1, _) in zip(fitted[1:], (moved or layers)[1:], strict=True):
            if len(v1) == len(v0):
                dist = metrics.distortion(v0, v1, f)
                moves.append(dist["max_move"])
                stretch.append(dist["max_stretch"])
        return [method, f"{seconds:.2f}", f"{100 * metrics.poke_through(layers, cameras=cams)[0]:.2f}",
                f"{int(np.triu(metrics.layer_crossings(layers)).sum()):,}", f"{bvh_overlaps(layers):,}",
                f"{1000 * max(moves):.1f}", f"{max(stretch):.2f}",
                f"{100 * metrics.new_holes(fitted, layers, cameras=cams):.2f}"]

    def shot(label):
        if render:
            studio.render_cycles(scene, IMG / f"{name}_{label}.png", resolution=(240, 320), samples=8)

    rows = [row("as fitted", 0.0, fitted)]
    shot("fitted")
    for label, method in (("Shrinkwrap, Project along normals", "PROJECT"), ("Shrinkwrap, Inside", "INSIDE")):
        t0 = time.perf_counter()
        shrinkwrap(garments, l_s, d, method)
        layers = evaluated(objs)
        wrap_s = time.perf_counter() - t0
        rows.append(row(label, wrap_s, layers))
        if method == "PROJECT":
            shot("shrinkwrap")
            t0 = time.perf_counter()
            mask_covered(garments, l_s)
            masked = evaluated(objs)
            rows.append(row("Shrinkwrap (Project) + Mask of covered parts", wrap_s + time.perf_counter() - t0,
                            masked, moved=layers))
            shot("shrinkwrap_mask")
        clear_artist_work(objs)
    t0 = time.perf_counter()
    cloth_settle(body, garments, d, SETTLE_FRAMES)
    rows.append(row(f"Cloth-collision settle ({SETTLE_FRAMES} frames)", time.perf_counter() - t0, evaluated(objs)))
    shot("cloth")
    clear_artist_work(objs)
    t0 = time.perf_counter()
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    layers = evaluated(objs)
    seconds = time.perf_counter() - t0
    # the result hides faces, so the moved vertices come from its stored offsets
    results = _sub("addon.layers.results")
    # offsets are stored in object space: turn them with the object's matrix, no mesh read needed
    moved = [fitted[0]] + [(v + results.read_offsets(g, len(v)) @ np.array(g.matrix_world)[:3, :3].T, f)
                           for g, (v, f) in zip(garments, fitted[1:], strict=True)]
    rows.append(row("DeformRT resolve_layers", seconds, layers, moved=moved))
    shot("deformrt")
    report = json.loads(scene.deformrt.last_report)
    return rows, l_s, d, sum(len(f) for _, f in fitted), report


def main(render=True):
    header = ["method", "seconds (set up + evaluate)", "poke-through %", "crossing edges (core.metrics)",
              "intersecting triangle pairs (BVHTree.overlap)", "max move mm", "max edge stretch", "new holes %"]
    parts = [f"Machine: {machine()}. Scenes from sample_scenes/dressed.py (armature modifiers on). Shrinkwrap "
             "modifiers stack on each lower garment, one per higher garment, wrap mode Inside with offset d; "
             "'Project' projects along the garment's own normals both ways with limit l_s, 'Inside' (nearest "
             "surface point; it has no limit) acts on a vertex group of the vertices within l_s of a higher "
             "garment. The Mask row hides the vertices whose outward normal meets a higher garment within l_s "
             "(computed, standing in for the group an artist paints); its distortion is the Shrinkwrap's. The "
             "cloth settle simulates the outer garments without gravity against Collision modifiers (single "
             "sided, distance d) on the body and the inner garments. l_s is the median of the body parts' "
             "probe distances DeformRT picks, d its default offset. Poke-through over 16 views at 128x128; new "
             "holes: pixels that showed a surface as fitted and show background now. Each row measures what "
             "Blender evaluates.", ""]
    for name in SCENES:
        rows, l_s, d, tris, _ = measure_figure(name, render)
        for r in rows:
            print(name, r, flush=True)
        parts += [f"### {name} ({tris:,} triangles; l_s = {1000 * l_s:.0f} mm, d = {1000 * d:.1f} mm)", "",
                  table(header, rows), ""]
        if render:
            parts += [" ".join(f"![{name} {k}](img/{name}_{k}.png)"
                               for k in ("fitted", "shrinkwrap", "shrinkwrap_mask", "cloth", "deformrt")),
                      "", "Left to right: as fitted, Shrinkwrap (Project), Shrinkwrap + Mask, cloth settle, "
                      "DeformRT (Cycles, 8 spp).", ""]
    write_section("artist_baseline", "Layered garments against what Blender artists do today", "\n".join(parts))


if __name__ == "__main__":
    main(render="--no-render" not in sys.argv)

"""Inspect: how the tagged layers stand as fitted and as shown now (crossing edges,
poke-through, how far the result moved and stretched the cloth), and which results are out of date."""

import bpy
import numpy as np

from ...core.layering import metrics
from ..io import scene_units
from . import results, staleness
from .report import LayersReport
from .scene_read import fitted_cages, layered_objects, read_meshes, results_bypassed


def inspect_scene(scene) -> LayersReport:
    """Crossings, poke-through and distortion of the tagged layers as fitted and as shown now."""
    body, garments = layered_objects(scene)
    objs = [body, *garments]
    stale = staleness.check_scene(scene, subdivide=True)  # the shown meshes are read below anyway
    with results_bypassed(garments):
        depsgraph = bpy.context.evaluated_depsgraph_get()
        fitted = read_meshes(objs, depsgraph)
    with fitted_cages(garments):
        cages = read_meshes(garments, bpy.context.evaluated_depsgraph_get())
    depsgraph = bpy.context.evaluated_depsgraph_get()
    now = read_meshes(objs, depsgraph)
    before = [(a.vertices, a.triangles) for a in fitted]
    after = [(a.vertices, a.triangles) for a in now]
    cameras = metrics.camera_ring(*metrics.layer_bounds(before), views=8, resolution=96)
    crossing_after = metrics.layer_crossings(after)
    names = [o.name for o in objs]
    report = LayersReport(
        kind="inspect", message="",
        crossings_before=int(np.triu(metrics.layer_crossings(before)).sum()),
        crossings_after=int(np.triu(crossing_after).sum()),
        still_crossing=[[names[i], names[j], int(crossing_after[i, j])]
                        for i, j in zip(*np.nonzero(np.triu(crossing_after)), strict=True)],
        poke_through_before=metrics.poke_through(before, cameras=cameras)[0],
        poke_through_after=metrics.poke_through(after, cameras=cameras)[0],
        stale=[[g.name, reason] for g, reason in stale])
    for obj, a in zip(garments, cages, strict=True):
        off = results.read_offsets(obj, len(a.vertices))
        if off is None or any(g == obj for g, _ in stale):
            continue
        d = metrics.distortion(a.vertices, a.vertices + off @ a.matrix_world[:3, :3].T, a.triangles)
        report.max_move_m = max(report.max_move_m, d["max_move"])
        if d["max_stretch"] > report.max_stretch:
            report.max_stretch, worst = d["max_stretch"], (obj.name, d["p99_stretch"])
    stretch = f"max edge stretch {report.max_stretch:.2f}x"
    if report.max_stretch > 1.0:  # where, and whether it is a few edges (a seam pulled in) or the cloth
        stretch += f" on {worst[0]} (99% of its edges {worst[1]:.2f}x or less)"
    report.message = (f"Crossing edges {report.crossings_before:,} -> {report.crossings_after:,}, "
                      f"poke-through {100 * report.poke_through_before:.2f}% -> "
                      f"{100 * report.poke_through_after:.2f}%, "
                      f"max move {scene_units.length(scene, report.max_move_m)}, {stretch}")
    if stale:
        report.message += f"; out of date, shown as fitted: {', '.join(g.name for g, _ in stale)}"
    return report

"""What F12 renders after deformrt.resolve_layers when the garments carry the modifiers artists
use: Subdivision (viewport 1, render 2, as Ctrl+1 adds it), Solidify (Blender's default 1 cm),
Mirror (the garment modelled as a half) and Bevel, on the thesis' dressed figures. Poke-through
and crossings are measured on the meshes the render's own depsgraph evaluates.

    .venv/bin/python -m bench.render_modifiers     # writes the section of docs/REPORT.md (~20 min)
"""

import importlib
import json
import sys
import time

import numpy as np

from bench.blender import load_package
from bench.report import machine, table, write_section
from core.layering import metrics

# Fig 4.12 with Solidify at render level 2 is 10M triangles: measuring its crossings does not fit in 24 GiB
CASES = [("fig_4_12", []), ("fig_4_12", ["subdivision"]),
         ("fig_4_13", []), ("fig_4_13", ["subdivision"]), ("fig_4_13", ["solidify", "subdivision"]),
         ("fig_4_13", ["subdivision", "solidify"]), ("fig_4_13", ["mirror", "subdivision"]),
         ("fig_4_13", ["bevel", "subdivision"])]


def measure(scene_name, stack):
    load_package()
    import bpy

    from tests.addon.render_capture import add_stack, rendered_meshes

    dressed = importlib.import_module("deformrt.sample_scenes.dressed")
    io = importlib.import_module("deformrt.addon.io.mesh_io")
    body, _, garments = getattr(dressed, scene_name)()
    objs = [body, *garments]
    for g in garments:
        add_stack(g, stack)
    scene = bpy.context.scene

    def poke(layers):
        cams = metrics.camera_ring(*metrics.layer_bounds(layers), views=8, resolution=96)
        return 100 * metrics.poke_through(layers, cameras=cams)[0], int(np.triu(metrics.layer_crossings(layers)).sum())

    rendered = rendered_meshes(scene)
    before = poke([rendered[o.name] for o in objs])
    bpy.context.view_layer.update()  # what an open file shows already: Blender's evaluation is not the operator's
    t0 = time.perf_counter()
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    wall = time.perf_counter() - t0
    report = json.loads(scene.deformrt.last_report)
    viewport = poke([(a.vertices, a.triangles) for a in (io.read_mesh(o) for o in objs)])
    rendered = rendered_meshes(scene)
    after = poke([rendered[o.name] for o in objs])
    stack_names = [m.name for m in garments[-1].modifiers if m.type != "ARMATURE"]
    return [scene_name, " > ".join(stack_names), f"{report['seconds']['total_s']:.2f}", f"{wall:.1f}",
            f"{sum(len(rendered[o.name][1]) for o in objs):,}", f"{before[0]:.2f}", f"{viewport[0]:.2f}",
            f"{after[0]:.2f}", f"{before[1]:,}", f"{after[1]:,}"]


def main():
    if len(sys.argv) > 2:  # one case per process: a bpy session keeps what it evaluated
        print(json.dumps(measure(sys.argv[1], sys.argv[2].split(",") if sys.argv[2] != "-" else [])))
        return
    import subprocess

    rows = []
    for scene_name, stack in CASES:
        out = subprocess.run([sys.executable, "-m", "bench.render_modifiers", scene_name, ",".join(stack) or "-"],
                             capture_output=True, text=True, check=True).stdout
        rows.append(json.loads(out.strip().splitlines()[-1]))
        print(rows[-1], flush=True)
    header = ["scene", "stack on every garment (result in place)", "operator s", "with Blender's update s",
              "F12 triangles", "F12 poke-through % before", "viewport after", "F12 after", "F12 crossing edges before",
              "F12 after"]
    text = "\n".join([
        f"Machine: {machine()}. The operator reads each garment up to where its result goes (before the "
        "Subdivision; after Mirror, Solidify or Bevel placed above it), resolves, and writes the result there. "
        "'F12' columns measure the meshes Blender evaluates for a render (render level 2), read from the render's "
        "depsgraph by a capture engine (tests/addon/render_capture.py); poke-through over 16 views. 'operator s' is "
        "the operator's own time; 'with Blender's update' adds the view-layer update Blender runs around any "
        "operator called from Python, which evaluates the subdivided garments (CPU subdivision at the default "
        "quality; a viewport with GPU subdivision does this on the GPU).",
        "",
        table(header, rows),
    ])
    write_section("render_modifiers", "Layered garments: what F12 renders with the artists' modifiers", text)


if __name__ == "__main__":
    main()

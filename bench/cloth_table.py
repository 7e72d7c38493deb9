"""Thesis Table 4.1 and Fig. 4.16 on sample scene (d): 1-4 cloth sheets falling onto the stage
(two boxes, two spheres, the floor) with Blender's cloth solver, cloth-cloth collision off.

For each size: the cloth solver's seconds per frame (the uncorrected frame), then, frame by
frame from the cache, the correction alone (deformrt's frame handler path: read the evaluated
sheets, resolve, write the result modifier), and crossing edges between the sheets before
and after. Writes the table into docs/REPORT.md and the per-frame plot to
docs/img/cloth_table.png.

    .venv/bin/python -m bench.cloth_table [--frames 120] [--sizes 512,2048,8192,32768] [--long 500]
"""

import argparse
import time

import numpy as np

from bench.blender import load_package
from bench.report import REPORT, machine, table, write_section


def baked_sheets(layers, per_sheet, frames):
    """Sample scene (d) with its cloth baked, as the user is told to have it (adding DeformRT's
    modifier would reset an unbaked cache): (sheets, scene, seconds the bake took)."""
    import bpy
    from deformrt.sample_scenes import sheets

    made, _ = sheets.build(layers=layers, per_sheet=per_sheet, frames=frames)
    scene = bpy.context.scene
    scene.deformrt.resolve_on_frame_change = False
    t0 = time.perf_counter()
    bpy.ops.ptcache.bake_all(bake=True)
    return made, scene, time.perf_counter() - t0


def corrected_frame(scene, made):
    """The sheets of the current frame as simulated, then corrected through the frame handler's
    path: (before, after, the resolve's summary, seconds the correction took)."""
    import bpy
    from deformrt.addon.io import mesh_io
    from deformrt.addon.layers import frame_handler, scene_read

    with scene_read.results_bypassed(made):
        depsgraph = bpy.context.evaluated_depsgraph_get()
        before = [mesh_io.read_mesh(o, depsgraph) for o in made]
    t0 = time.perf_counter()
    summary = frame_handler.correct_frame(scene)
    seconds = time.perf_counter() - t0
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return before, [mesh_io.read_mesh(o, depsgraph) for o in made], summary, seconds


def release(scene):
    """Take DeformRT's results off the scene and free the cloth bake."""
    import bpy
    from deformrt.addon.layers import resolve_job

    resolve_job.clear_scene(scene)
    bpy.ops.ptcache.free_bake_all()


def run_case(layers, per_sheet, frames):
    from deformrt.addon.io import mesh_io
    from deformrt.addon.layers import frame_memory, scene_read
    from deformrt.core.layering import metrics
    from deformrt.core.rays import RayScene

    made, scene, bake_s = baked_sheets(layers, per_sheet, frames)
    frame_memory.forget()
    stage = mesh_io.read_mesh(scene_read.layered_objects(scene)[0])
    stage_scene = RayScene(stage.vertices, stage.triangles)

    def through_stage(sheets):
        """Edges of the stage through a sheet and of a sheet through the stage, summed over sheets."""
        return sum(int(metrics.crossing_edges(a.vertices, a.triangles, stage_scene).sum()
                       + metrics.crossing_edges(stage.vertices, stage.triangles,
                                                RayScene(a.vertices, a.triangles)).sum()) for a in sheets)

    rows = []
    for f in range(1, frames + 1):
        scene.frame_set(f)
        before, after, summary, corr = corrected_frame(scene, made)
        report = {**summary.seconds, **{k: v for k, v in summary.stats.items() if k.endswith("_s")}}
        cb = metrics.layer_crossings([(a.vertices, a.triangles) for a in before]) if layers > 1 else np.zeros((1, 1))
        ca = metrics.layer_crossings([(a.vertices, a.triangles) for a in after]) if layers > 1 else np.zeros((1, 1))
        rows.append((f, bake_s / frames, corr, int(np.triu(cb).sum()), int(np.triu(ca).sum()), report,
                     through_stage(before), through_stage(after)))
    release(scene)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--sizes", default="512,2048,8192,32768", help="triangles per sheet")
    ap.add_argument("--layers", default="1,2,3,4")
    ap.add_argument("--long", type=int, default=0, help="also run 4 sheets x 2,048 for this many frames (the "
                    "dissertation ran 500)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    load_package()
    sizes = [int(s) for s in args.sizes.split(",")]
    layer_counts = [int(s) for s in args.layers.split(",")]
    out, series = [], {}
    for n in sizes:
        for layers in layer_counts:
            if layers < 2:
                continue  # one sheet has nothing to be layered against
            rows = run_case(layers, n, args.frames)
            sim = np.array([r[1] for r in rows])
            corr = np.array([r[2] for r in rows])
            cb = np.array([r[3] for r in rows])
            ca = np.array([r[4] for r in rows])
            worse = int((ca > cb).sum())
            sb, sa = np.array([r[6] for r in rows]), np.array([r[7] for r in rows])
            out.append((layers, f"{n:,}", f"{layers * n:,}", f"{1000 * sim.mean():.0f}",
                        f"{1000 * corr.mean():.1f}", f"{1000 * corr.max():.1f}", f"{corr.max() / corr.mean():.1f}",
                        f"{cb.mean():.0f}", f"{ca.mean():.1f}", f"{int(ca.max())}", worse,
                        f"{sb.mean():.0f} / {sa.mean():.0f}", int((sa > sb).sum())))
            series[(layers, n)] = corr
            print(out[-1], flush=True)
    import bpy

    probe = bpy.context.scene.deformrt.probe_distance  # the sample scene's, as the runs above used it
    header = ("sheets", "triangles per sheet", "triangles", "cloth solver ms/frame (bake)",
              "correction ms/frame (mean)", "worst", "worst/mean", "crossing edges before (mean)", "after (mean)",
              "after (worst frame)", "frames worse after", "stage through sheets, before / after (mean)",
              "frames with more after")
    body = (f"Machine: {machine()}. Sample scene (d): sheets fall onto two boxes, two spheres and the floor "
            f"(the stage is the body; Whole Body parts; probe distance {100 * probe:.0f} cm), {args.frames} frames, "
            "Blender "
            "cloth quality 5, cloth-cloth collision off. The correction is deformrt's frame handler on each "
            "cached frame: read the evaluated sheets, resolve, write the result modifier. Crossing edges are "
            "edges of one sheet through a triangle of another, counted on what Blender evaluates; 'stage "
            "through sheets': edges of the stage through a sheet's triangles and of a sheet through the "
            "stage's (the cloth solver leaves some; the correction must add none).\n\n"
            + table(header, out))
    if args.long:
        rows = run_case(4, 2048, args.long)
        corr = np.array([r[2] for r in rows])
        cb, ca = np.array([r[3] for r in rows]), np.array([r[4] for r in rows])
        sb, sa = np.array([r[6] for r in rows]), np.array([r[7] for r in rows])
        body += (f"\n\nA long run like the thesis': 4 sheets x 2,048 for {args.long} frames, correction "
                 f"{1000 * corr.mean():.1f} ms per frame on average, worst {1000 * corr.max():.1f} ms "
                 f"({corr.max() / corr.mean():.1f}x); crossing edges {cb.mean():.0f} per frame before, "
                 f"{ca.mean():.2f} after (worst frame {int(ca.max())}); {int((ca > cb).sum())} frames worse after; "
                 f"stage through sheets {sb.mean():.0f} per frame before, {sa.mean():.0f} after, "
                 f"{int((sa > sb).sum())} frames with more after.")
    if not args.no_write:
        plot(series, args.frames)
        write_section("cloth_table", "Dynamic cloth: the dissertation's Table 4.1 on falling sheets", body
                      + "\n\nPer-frame correction time: docs/img/cloth_table.png (like the thesis' Fig. 4.16).")
    print(body)


def plot(series, frames):
    """A line per case of correction milliseconds against frame, as a small PNG with its axes
    and a legend of the cases (sheets x triangles per sheet)."""
    from bench.jellyfish import write_png
    from bench.png_text import draw_text, text_width

    w, h = 760, 360
    left, right, top_pad, bottom = 60, 150, 20, 40
    img = np.full((h, w, 3), 255, np.uint8)
    top = max(float(c.max()) for c in series.values()) * 1000 * 1.1
    step = 10 ** np.floor(np.log10(top / 2))
    tick = step * (5 if top / step > 10 else 2 if top / step > 5 else 1)
    # a hue per sheet count, darker as the sheets get finer
    hues = [np.array(c, float) for c in ((210, 50, 30), (30, 90, 210), (30, 140, 50), (130, 60, 170))]
    counts = sorted({key[0] for key in series})
    sizes = sorted({key[1] for key in series})

    def colour_of(layers, n):
        fade = 0.6 * (1 - sizes.index(n) / max(len(sizes) - 1, 1))
        return tuple(int(v) for v in (1 - fade) * hues[counts.index(layers) % len(hues)] + fade * 255)

    x0, x1, y0, y1 = left, w - right, h - bottom, top_pad
    img[y0, x0:x1] = 0
    img[y1:y0 + 1, x0] = 0
    for v in np.arange(0.0, top, tick):  # y ticks in milliseconds
        y = int(round(y0 - v / top * (y0 - y1)))
        img[y, x0 - 4:x0] = 0
        img[y, x0 + 1:x1:4] = 215
        label = f"{v:.0f}"
        draw_text(img, x0 - 8 - text_width(label), y - 5, label)
    draw_text(img, 8, y1, "ms")
    for f in sorted({1, frames // 2, frames}):  # x ticks in frames
        x = int(round(x0 + (f - 1) / max(frames - 1, 1) * (x1 - x0 - 1)))
        img[y0:y0 + 4, x] = 0
        draw_text(img, x - text_width(str(f)) // 2, y0 + 8, str(f))
    draw_text(img, (x0 + x1) // 2 - text_width("frame") // 2, y0 + 24, "frame")
    for k, ((layers, n), c) in enumerate(sorted(series.items())):
        colour = colour_of(layers, n)
        x = x0 + 1 + (np.arange(len(c)) / max(len(c) - 1, 1)) * (x1 - x0 - 2)
        y = y0 - (1000 * c / top) * (y0 - y1)
        xs = np.linspace(x[0], x[-1], 16 * len(c))
        ys = np.interp(xs, x, y)
        img[np.clip(ys.astype(int), 0, h - 1), np.clip(xs.astype(int), 0, w - 1)] = colour
        ly = y1 + 14 * k
        img[ly + 4:ly + 6, x1 + 10:x1 + 26] = colour
        draw_text(img, x1 + 32, ly, f"{layers}x{n}", colour)
    path = REPORT.parent / "img" / "cloth_table.png"
    write_png(path, img)


if __name__ == "__main__":
    main()

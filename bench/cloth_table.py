"""Seed Table 4.1 and Fig. 4.16 on sample scene (d): 1-4 cloth sheets falling onto the stage
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


def run_case(layers, per_sheet, frames):
    import bpy
    from deformrt.addon import frame_handler, layer_resolve, mesh_io
    from deformrt.core import metrics
    from deformrt.sample_scenes import sheets

    made, _ = sheets.build(layers=layers, per_sheet=per_sheet, frames=frames)
    scene = bpy.context.scene
    scene.deformrt.resolve_on_frame_change = False
    # a baked cache, as the user is told to have: adding DeformRT's modifier would reset an unbaked one
    t0 = time.perf_counter()
    bpy.ops.ptcache.bake_all(bake=True)
    sim = [(time.perf_counter() - t0) / frames] * frames
    layer_resolve.forget_correspondence()
    rows = []
    for f in range(1, frames + 1):
        scene.frame_set(f)
        with layer_resolve.results_bypassed(made):
            depsgraph = bpy.context.evaluated_depsgraph_get()
            before = [mesh_io.read_mesh(o, depsgraph) for o in made]
        t0 = time.perf_counter()
        summary = frame_handler.correct_frame(scene)
        corr = time.perf_counter() - t0
        report = {**summary.seconds, **{k: v for k, v in summary.stats.items() if k.endswith("_s")}}
        depsgraph = bpy.context.evaluated_depsgraph_get()
        after = [mesh_io.read_mesh(o, depsgraph) for o in made]
        cb = metrics.layer_crossings([(a.vertices, a.triangles) for a in before]) if layers > 1 else np.zeros((1, 1))
        ca = metrics.layer_crossings([(a.vertices, a.triangles) for a in after]) if layers > 1 else np.zeros((1, 1))
        rows.append((f, sim[f - 1], corr, int(np.triu(cb).sum()), int(np.triu(ca).sum()), report))
    layer_resolve.clear_scene(scene)
    bpy.ops.ptcache.free_bake_all()
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--sizes", default="512,2048,8192,32768", help="triangles per sheet")
    ap.add_argument("--layers", default="1,2,3,4")
    ap.add_argument("--long", type=int, default=0, help="also run 4 sheets x 2,048 for this many frames (the "
                    "seed ran 500)")
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
            out.append((layers, f"{n:,}", f"{layers * n:,}", f"{1000 * sim.mean():.0f}",
                        f"{1000 * corr.mean():.1f}", f"{1000 * corr.max():.1f}", f"{corr.max() / corr.mean():.1f}",
                        f"{cb.mean():.0f}", f"{ca.mean():.1f}", f"{int(ca.max())}", worse))
            series[(layers, n)] = corr
            print(out[-1], flush=True)
    header = ("sheets", "triangles per sheet", "triangles", "cloth solver ms/frame (bake)",
              "correction ms/frame (mean)", "worst", "worst/mean", "crossing edges before (mean)", "after (mean)",
              "after (worst frame)", "frames worse after")
    body = (f"Machine: {machine()}. Sample scene (d): sheets fall onto two boxes, two spheres and the floor "
            f"(the stage is the body; Whole Body parts; probe distance 4 cm), {args.frames} frames, Blender "
            "cloth quality 5, cloth-cloth collision off. The correction is deformrt's frame handler on each "
            "cached frame: read the evaluated sheets, resolve, write the result modifier. Crossing edges are "
            "edges of one sheet through a triangle of another, counted on what Blender evaluates.\n\n"
            + table(header, out))
    if args.long:
        rows = run_case(4, 2048, args.long)
        corr = np.array([r[2] for r in rows])
        cb, ca = np.array([r[3] for r in rows]), np.array([r[4] for r in rows])
        body += (f"\n\nA long run like the seed's: 4 sheets x 2,048 for {args.long} frames, correction "
                 f"{1000 * corr.mean():.1f} ms per frame on average, worst {1000 * corr.max():.1f} ms "
                 f"({corr.max() / corr.mean():.1f}x); crossing edges {cb.mean():.0f} per frame before, "
                 f"{ca.mean():.2f} after (worst frame {int(ca.max())}); {int((ca > cb).sum())} frames worse after.")
    if not args.no_write:
        plot(series, args.frames)
        write_section("cloth_table", "Dynamic cloth: seed Table 4.1 on falling sheets", body
                      + "\n\nPer-frame correction time: docs/img/cloth_table.png (like the seed's Fig. 4.16).")
    print(body)


def plot(series, frames):
    """A line per case of correction milliseconds against frame, as a small PNG."""
    from bench.jellyfish import write_png

    w, h, pad = 640, 320, 30
    img = np.full((h, w, 3), 255, np.uint8)
    top = max(float(c.max()) for c in series.values()) * 1000 * 1.1
    colours = [(200, 40, 30), (30, 100, 200), (220, 170, 30), (40, 150, 60), (120, 60, 160), (90, 90, 90)]
    img[h - pad, pad:w - pad] = 0
    img[pad:h - pad, pad] = 0
    for k, ((_layers, _n), c) in enumerate(sorted(series.items())):
        x = pad + (np.arange(len(c)) / max(len(c) - 1, 1)) * (w - 2 * pad - 1)
        y = (h - pad) - (1000 * c / top) * (h - 2 * pad)
        xs = np.linspace(x[0], x[-1], 4 * len(c) * 4)
        ys = np.interp(xs, x, y)
        img[np.clip(ys.astype(int), 0, h - 1), np.clip(xs.astype(int), 0, w - 1)] = colours[k % len(colours)]
    path = REPORT.parent / "img" / "cloth_table.png"
    write_png(path, img)


if __name__ == "__main__":
    main()

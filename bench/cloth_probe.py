"""What the probe distance l_s buys on sample scene (d): pieces of lower sheets left on top
against how far the sheets move, for 4 sheets x 8,192 triangles.

The sheets are baked once; for each l_s the frame handler's correction runs on the same
frames (its correspondence taken at frame 1, as in playback). Poke-through is measured over
views from above (35 and 60 degrees elevation, where the scene is seen from), counting a lower
sheet in front of a higher one's front face up to 5 cm behind it: folds leave pieces of lower
sheets lying that far over higher ones. Writes its table into docs/REPORT.md.

    .venv/bin/python -m bench.cloth_probe [--frames 60] [--probes 2,4,6,8,12]
"""

import argparse

import numpy as np

from bench.blender import load_package
from bench.cloth_table import baked_sheets, corrected_frame, release
from bench.report import machine, table, write_section

DEPTH = 0.05


def run(frames, probes, measured):
    from deformrt.addon.layers import frame_handler, frame_memory
    from deformrt.core.layering import metrics

    made, scene, _ = baked_sheets(4, 8192, frames)
    default = scene.deformrt.probe_distance
    rows = []
    for probe in probes:
        scene.deformrt.probe_distance = probe
        frame_memory.forget()
        scene.frame_set(1)
        frame_handler.correct_frame(scene)
        acc = []
        for f in measured:
            scene.frame_set(f)
            before, after, summary, seconds = corrected_frame(scene, made)
            layers = [(a.vertices, a.triangles) for a in after]
            center, radius = metrics.layer_bounds([(b.vertices, b.triangles) for b in before])
            views = metrics.camera_ring(center, radius, elevations_deg=(35.0, 60.0))
            poke = metrics.poke_through(layers, depth=DEPTH, cameras=views)[0]
            n_v = sum(len(b.vertices) for b in before)
            n_f = sum(len(b.triangles) for b in before)
            moved = summary.stats["vertices_moved_boundary"] + summary.stats["vertices_moved_push"]
            acc.append((seconds, poke, max(summary.max_move), moved / n_v, summary.stats["faces_removed"] / n_f,
                        int(np.triu(metrics.layer_crossings(layers)).sum())))
        a = np.array(acc)
        rows.append((f"{100 * probe:.0f}" + (" (scene default)" if np.isclose(probe, default) else ""),
                     f"{1000 * a[:, 0].mean():.0f}", f"{100 * a[:, 1].mean():.2f}", f"{100 * a[:, 1].max():.2f}",
                     f"{100 * a[:, 3].mean():.1f}", f"{100 * a[:, 2].max():.1f}", f"{100 * a[:, 4].mean():.1f}",
                     int(a[:, 5].sum())))
        print(rows[-1], flush=True)
    release(scene)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--probes", default="2,4,6,8,12", help="probe distances in cm")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    load_package()
    probes = [float(p) / 100 for p in args.probes.split(",")]
    measured = list(range(args.frames // 3, args.frames + 1, max(args.frames // 6, 1)))
    rows = run(args.frames, probes, measured)
    header = ("probe distance cm", "correction ms/frame", "poke-through % (mean)", "worst frame",
              "vertex moves (hem + push) per vertex %", "max move cm", "faces left out %",
              "crossing edges after (all frames)")
    body = (f"Machine: {machine()}. Sample scene (d), 4 sheets x 8,192 triangles, frames "
            f"{', '.join(map(str, measured))} of {args.frames}, through the frame handler. Poke-through: share of "
            f"covered pixels, over 16 views from above (35 and 60 degrees), where a lower sheet shows with a "
            f"front face of a higher one up to {100 * DEPTH:.0f} cm behind it.\n\n" + table(header, rows))
    if not args.no_write:
        write_section("cloth_probe", "Dynamic cloth: the probe distance on falling sheets", body)
    print(body)


if __name__ == "__main__":
    main()

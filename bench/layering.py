"""Layered garments: error against run time for resolve_layers, its stages and parameters,
and a naive baseline (shrink lower layers inward by a constant, as artists do with
Shrinkwrap/Solidify).

    .venv/bin/python -m bench.layering            # writes the section of docs/REPORT.md
    .venv/bin/python -m bench.layering --quick    # small sizes only, prints

Scene: a capped-cylinder body (radius 15 cm) with four noisy open sleeves 1.3-2.2 cm out,
each alone clear of the body, together crossing everywhere (the 'tubes' family; the
mannequin scenes replace it when they land).
"""

import argparse
import time

import numpy as np
import trimesh

from bench.report import machine, table, write_section
from core.geometry.normals import vertex_normals
from core.layering import metrics, resolve_layers
from core.layering.body_facts import forget_garments
from sample_scenes.shapes import sleeves, tube, tube_body

RADII = (0.163, 0.166, 0.169, 0.172)


def mesh(v, f):
    return trimesh.Trimesh(np.asarray(v, float), np.asarray(f), process=False)


def scene(n):
    body = mesh(*tube_body(n))
    return body, [mesh(v, f) for v, f in sleeves(RADII, 0.01, 0, n, z0_step=0.04, stagger=0.003)]


def measure(body, garments, corrected, normals, seconds, removed=None):
    before = [(body.vertices, body.faces)] + [(g.vertices, g.faces) for g in garments]
    after = [(body.vertices, body.faces)] + [(g.vertices, g.faces) for g in corrected]
    # what face removal opened: corrected positions with every face against without the removed ones
    moved_all = [(body.vertices, body.faces)]
    moved_all += [(c.vertices, g.faces) for g, c in zip(garments, corrected, strict=True)]
    n_body = vertex_normals(body.vertices, body.faces)
    cams = metrics.camera_ring(*metrics.layer_bounds(before), views=8, resolution=128)
    poke_after = metrics.poke_through(after, normals=[n_body, *normals], cameras=cams)[0]
    cross = int(np.triu(metrics.layer_crossings(after)).sum())
    dist = [metrics.distortion(g.vertices, c.vertices, g.faces) for g, c in zip(garments, corrected, strict=True)]
    removed_share = 0.0
    if removed is not None:
        area = [metrics.removed_area_share(g.vertices, g.faces, r) for g, r in zip(garments, removed, strict=True)]
        removed_share = float(np.mean(area))
    return {
        "s": seconds,
        "poke": poke_after,
        "cross": cross,
        "holes": metrics.new_holes(moved_all, after, cameras=cams),
        "max_move_mm": 1000 * max(d["max_move"] for d in dist),
        "stretch": max(d["max_stretch"] for d in dist),
        "removed": removed_share,
    }


def before_metrics(body, garments, normals):
    layers = [(body.vertices, body.faces)] + [(g.vertices, g.faces) for g in garments]
    n_body = vertex_normals(body.vertices, body.faces)
    cams = metrics.camera_ring(*metrics.layer_bounds(layers), views=8, resolution=128)
    return (metrics.poke_through(layers, normals=[n_body, *normals], cameras=cams)[0],
            int(np.triu(metrics.layer_crossings(layers)).sum()))


def run_resolve(body, garments, **params):
    """A resolve of garments new to it (what was kept of the body stays) and its seconds."""
    forget_garments()
    t0 = time.perf_counter()
    res = resolve_layers(body, garments, **params)
    return res, time.perf_counter() - t0


def naive_shrink(garments, normals, step):
    """Each layer below the top moves inward by (layers above it) x step along its normals."""
    out = []
    for k, (g, n) in enumerate(zip(garments, normals, strict=True)):
        out.append(mesh(g.vertices - n * step * (len(garments) - 1 - k), g.faces))
    return out


def row(label, tris, m):
    return [label, f"{tris:,}", f"{m['s']:.3f}", f"{100 * m['poke']:.2f}", m["cross"], f"{100 * m['holes']:.2f}",
            f"{m['max_move_mm']:.1f}", f"{m['stretch']:.2f}", f"{100 * m['removed']:.2f}"]


HEADER = ["method", "triangles", "seconds", "poke-through %", "crossing edges", "new holes %", "max move mm",
          "max stretch", "removed area %"]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    sizes = [45, 100] if args.quick else [45, 100, 141, 224, 316]
    mid = 100 if args.quick else 141

    # --- resolution sweep
    sweep = []
    stage_rows = []
    for n in sizes:
        body, garments = scene(n)
        tris = len(body.faces) + sum(len(g.faces) for g in garments)
        res, secs = run_resolve(body, garments)
        p0, c0 = before_metrics(body, garments, res.global_normals)
        sweep.append(row("input (no correction)", tris, {"s": 0.0, "poke": p0, "cross": c0, "holes": 0.0,
                                                         "max_move_mm": 0.0, "stretch": 1.0, "removed": 0.0}))
        sweep.append(row("resolve_layers", tris, measure(body, garments, res.garments, res.global_normals, secs,
                                                         res.removed_faces)))
        st = res.stats
        ms_per_55k = 1000 * st["push_trace_s"] / max(st["rays_push"], 1) * 55000
        stage_rows.append([f"{tris:,}", f"{st['correspondence_s']:.3f}", f"{st['boundary_pass_s']:.3f}",
                           f"{st['push_behind_s']:.3f}", f"{st['body_guard_s']:.3f}", f"{st['hidden_faces_s']:.3f}",
                           f"{st['total_s']:.3f}", f"{st['rays_push']:,}", f"{ms_per_55k:.1f}"])
        print(sweep[-2], "\n", sweep[-1], flush=True)

    # --- parameters, stages and the naive baseline at one size
    body, garments = scene(mid)
    tris = len(body.faces) + sum(len(g.faces) for g in garments)
    ref, secs = run_resolve(body, garments)
    normals = ref.global_normals
    d0 = ref.stats["offset"]
    variants = [("default (all stages)", {}),
                ("no boundary pass", {"boundary_pass": False}),
                ("no push-behind", {"push_behind": False}),
                ("no body guard", {"body_guard": False}),
                ("no hidden-face removal", {"remove_hidden": False}),
                ("boundary pass only", {"push_behind": False, "remove_hidden": False})]
    variants += [(f"d = {f:g} x default ({1000 * f * d0:.2f} mm)", {"offset": f * d0}) for f in (0.25, 4.0)]
    variants += [(f"l_s = {lv * 100:g} cm for all", {"probe_distance": lv}) for lv in (0.01, 0.05)]
    variants += [(f"falloff c = {c * 1000:g} mm", {"falloff": c}) for c in (0.005, 0.04)]
    var_rows = []
    for label, params in variants:
        res, secs = run_resolve(body, garments, **params)
        var_rows.append(row(label, tris, measure(body, garments, res.garments, normals, secs, res.removed_faces)))
        print(var_rows[-1], flush=True)
    for step in (0.002, 0.005, 0.01):
        t0 = time.perf_counter()
        shrunk = naive_shrink(garments, normals, step)
        secs = time.perf_counter() - t0
        var_rows.append(row(f"naive shrink {1000 * step:g} mm per layer", tris,
                            measure(body, garments, shrunk, normals, secs)))
        print(var_rows[-1], flush=True)

    # --- a scene that needs nothing

    n_big = 224 if not args.quick else 100
    body = mesh(*tube_body(n_big))
    calm = [mesh(*tube(0.16 + 0.01 * k, 0.05, 0.55 - 0.01 * k, grid=(n_big, n_big // 2))) for k in range(4)]
    run_resolve(body, calm)  # the body's facts (normals, radii, search tree) are kept for the next calls

    def warm(garments):
        """The last result and the best seconds of three calls."""
        runs = [run_resolve(body, garments) for _ in range(3)]
        return runs[-1][0], min(secs for _, secs in runs)

    res, secs = warm(calm)
    resolve_layers(body, calm)
    again = min(resolve_layers(body, calm).stats["total_s"] for _ in range(3))  # what was found is kept
    moved = max(float(np.abs(m).max()) for m in res.moved)
    alone = [mesh(*tube(0.17, 0.05, 0.55, grid=(2 * n_big, n_big)))]
    one, one_secs = warm(alone)
    # four sleeves at separate heights, 4 cm apart along the body: near each other by their boxes
    apart = [mesh(*tube(0.17, 0.02 + 0.15 * k, 0.13 + 0.15 * k, grid=(n_big, n_big // 2))) for k in range(4)]
    spaced, spaced_secs = warm(apart)
    nothing = (f"Already-correct scene ({len(body.faces) + sum(len(g.faces) for g in calm):,} triangles, four "
               f"concentric garments 1 cm apart), warm (best of 3): resolve {secs:.3f} s (correspondence "
               f"{res.stats['correspondence_s']:.3f} s); the same garments resolved again (their body points "
               f"kept): {again:.3f} s; max displacement {moved:.1e}, faces removed "
               f"{res.stats['faces_removed']}. One garment alone "
               f"({len(body.faces) + len(alone[0].faces):,} triangles), nothing to layer it with: {one_secs:.3f} s "
               f"({one.stats['garments_traced']} garments traced), max displacement "
               f"{float(np.abs(one.moved[0]).max()):.1e}. Four sleeves at separate heights, 4 cm apart: "
               f"{spaced_secs:.3f} s ({spaced.stats['garments_traced']} of 4 through the stages, "
               f"{sum(c is not None for c in spaced.found()[1])} of 4 searched for their body points: the normals "
               f"of the body near each say its moves and rays stay at its own height; correspondence stage "
               f"{spaced.stats['correspondence_s']:.3f} s), max displacement "
               f"{max(float(np.abs(m).max()) for m in spaced.moved):.1e}.")
    print(nothing)

    body_text = "\n".join([
        f"Machine: {machine()}. {__doc__.split(chr(10) + chr(10))[2].strip()}",
        "",
        "Poke-through: share of covered pixels, over 16 views (8 around, at 0 and 35 degrees elevation, 128x128 "
        "each), where a lower layer's first hit has a front face of a higher layer within 2% of the scene radius "
        "behind it. Crossing edges: edges of one layer through triangles of another, summed over layer pairs "
        "(the body included). New holes: pixels where removing hidden faces reveals a lower layer or the "
        "background (corrected layers with all faces against without the removed ones). Max stretch: largest "
        "edge length ratio after/before.",
        "",
        "### Against resolution",
        "",
        table(HEADER, sweep),
        "",
        "### Time per stage",
        "",
        table(["triangles", "correspondence s", "boundary pass s", "push-behind s", "body guard s", "hidden faces s",
               "total s",
               "push probe rays", "ms per 55k probe rays (tracing only)"], stage_rows),
        "",
        f"### Parameters, stages and the naive baseline ({tris:,} triangles)",
        "",
        table(HEADER, var_rows),
        "",
        nothing,
    ])
    if not args.quick:
        write_section("layering", "Layered garments (core/layering)", body_text)
    else:
        print(body_text)


if __name__ == "__main__":
    main()

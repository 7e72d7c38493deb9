"""``deformrt jellyfish``: the thesis' jellyfish run end to end on the bundled sea scene.

Optimise the stroke on a small budget (deformrt.optimize_jellyfish), bake it
(deformrt.bake_jellyfish) over many cycles, render the bell's travel to contact_sheet.png (a
fixed camera, the start of every other cycle, a bar where the bell's top began) and one cycle
of its stroke to stroke_sheet.png (the camera riding along, like the thesis' Fig. 3.2), and
write what was measured to metrics.md.
"""

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import bpy
import numpy as np

from ...addon.io import blender_versions, mesh_io
from ...addon.io.image_io import contact_sheet
from ...addon.jellyfish import animal as jellyfish
from ...core.jellyfish import bell3d
from ...core.jellyfish.fitness import fitness
from ...core.jellyfish.stroke_search import GOAL_WEIGHTS, reference_scales
from ...core.jellyfish.swimming import default_config, default_creature, simulate_cycle

# the travel sheet: the start of every fourth cycle, 32 cycles; a stroke that swims more than SWIFT
# bell diameters in its first cycle from rest is shown every cycle, so 8 cycles stay in the frame
TRAVEL_SHOTS, TRAVEL_EVERY, SWIFT = 8, 4, 0.05


def _markers(at, size):
    """Two thin glowing bars either side of the bell, in the plane of its axis, level with where
    its top began: the travel sheet's yardstick."""
    bars = []
    for side in (-1.0, 1.0):
        where = (at[0] + side * 0.75 * size, at[1], at[2])
        bpy.ops.mesh.primitive_cylinder_add(radius=0.006 * size, depth=0.35 * size, location=where,
                                            rotation=(0.0, np.pi / 2, 0.0))
        bars.append(bpy.context.active_object)
    bars[0].name = bars[1].name = "DeformRT start height"
    mat = bpy.data.materials.new("DeformRT start height")
    mat.diffuse_color = (1.0, 0.35, 0.05, 1.0)
    blender_versions.use_nodes(mat)
    emit = mat.node_tree.nodes.new("ShaderNodeEmission")
    emit.inputs["Color"].default_value = (1.0, 0.35, 0.05, 1.0)
    emit.inputs["Strength"].default_value = 4.0
    mat.node_tree.links.new(emit.outputs["Emission"], mat.node_tree.nodes["Material Output"].inputs["Surface"])
    for bar in bars:
        bar.data.materials.append(mat)
    return bars


def _bell_points(bell, n):
    """The first n vertices of the bell as evaluated now, in its own space."""
    return mesh_io.read_mesh(bell, bpy.context.evaluated_depsgraph_get(), world=False).vertices[:n]


def _bell_top(bell, n):
    world = np.array(bell.matrix_world)
    top = _bell_points(bell, n) @ world[:3, :3].T + world[:3, 3]
    return top[np.argmax(top[:, 2])]


def _render_sheet(scene, out, name, shots, film, place_camera=None):
    """Cycles renders of ``shots`` (frames) at ``film`` = (width, height, samples), put together as
    ``name``.png; returns the seconds rendering."""
    from .. import studio

    width, height, samples = film
    paths, seconds = [], 0.0
    for k, f in enumerate(shots):
        scene.frame_set(f)
        if place_camera is not None:
            place_camera()
        path = out / f"{name}_{k + 1}.png"
        seconds += studio.render_cycles(scene, path, resolution=(width, height), samples=samples, denoise=True,
                                        quiet=True)
        paths.append(path)
    contact_sheet(paths, out / f"{name}.png", columns=4)
    return seconds


def _bell_volume(bell, n, tris):
    return bell3d.volume(_bell_points(bell, n), tris)


@dataclass
class _Swim:
    """What the job found and made: the stroke searched (the operator's stored record), the default
    and the optimized creature's first cycle, the bake's length, and seconds per step."""

    config: object
    before: object  # CycleResult of the default stroke
    after: object  # CycleResult of the optimized one
    creature: object
    stroke: dict
    every: int  # the travel sheet shows every this many cycles
    last_frame: int
    seconds: dict = field(default_factory=dict)


def run(args) -> int:
    from .. import sea

    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    anchor = sea.build()
    scene = bpy.context.scene
    scene.cursor.location = anchor.location
    if bpy.ops.deformrt.add_jellyfish(size=args.size, tentacles=16) != {"FINISHED"}:
        raise RuntimeError("deformrt.add_jellyfish did not finish")
    bell = bpy.context.active_object
    cam = scene.camera
    # the bell and its tentacles from the side, looking a little up (away from the sea floor)
    cam.location = (0.0, -4.6 * args.size, -0.3 * args.size)
    cam.rotation_euler = (np.radians(88.0), 0.0, 0.0)
    cam.data.lens = 50
    swim = _search_and_bake(args, bell)
    volume_err = _volume_change(scene, bell, _bell_vertices(bell), args.cycle_frames)
    stroke_shots, travel_shots, rise = _render_sheets(args, out, bell, anchor, swim)
    table = "\n".join(_metrics_lines(args, swim, volume_err, stroke_shots, travel_shots, rise))
    (out / "metrics.md").write_text(table + "\n")
    scene.frame_set(1)
    bpy.ops.wm.save_as_mainfile(filepath=str(out / "scene.blend"), check_existing=False)
    print(table)
    print(f"\nwrote {out / 'contact_sheet.png'}, {out / 'stroke_sheet.png'}, {out / 'metrics.md'} and "
          f"{out / 'scene.blend'}")
    return 0


def _search_and_bake(args, bell) -> _Swim:
    """The default stroke's first cycle, the operators' search for a better one and the bake of
    it over as many cycles as the travel sheet shows."""
    config = default_config(particles=args.particles, weights=GOAL_WEIGHTS[args.goal.upper()])
    seconds = {}
    t0 = time.perf_counter()
    before = simulate_cycle(default_creature(config), config)
    seconds["default_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    done = bpy.ops.deformrt.optimize_jellyfish(method=args.method, particles=args.particles,
                                               population=args.population, generations=args.generations,
                                               seed=args.seed, goal=args.goal.upper())
    if done != {"FINISHED"}:
        raise RuntimeError("deformrt.optimize_jellyfish did not finish")
    seconds["optimise_s"] = time.perf_counter() - t0
    stroke = json.loads(bell[jellyfish.PROP_STROKE])
    creature, _, _ = jellyfish.stroke_of(bell)
    after = simulate_cycle(creature, config)
    frames = args.cycle_frames
    every = 1 if after.path_m / config.bell.diameter > SWIFT else TRAVEL_EVERY
    last_frame = every * TRAVEL_SHOTS * frames + 1
    t0 = time.perf_counter()
    if bpy.ops.deformrt.bake_jellyfish(frame_start=1, frame_end=last_frame, cycle_frames=frames) != {"FINISHED"}:
        raise RuntimeError("deformrt.bake_jellyfish did not finish")
    seconds["bake_s"] = time.perf_counter() - t0
    return _Swim(config, before, after, creature, stroke, every, last_frame, seconds)


def _volume_change(scene, bell, n, frames) -> list:
    """The bell's volume over the first baked cycle, as a share of its rest volume off."""
    tris = bell3d.triangles([tuple(p.vertices) for p in bell.data.polygons if max(p.vertices) < n])
    scene.frame_set(1)
    rest_volume = _bell_volume(bell, n, tris)
    volume_err = []
    for f in range(1, frames + 1):
        scene.frame_set(f)
        volume_err.append(abs(_bell_volume(bell, n, tris) / rest_volume - 1))
    return volume_err


def _bell_vertices(bell) -> int:
    """How many of the bell object's vertices make its closed bell surface (the first ones)."""
    return json.loads(bell[jellyfish.PROP_MODEL])["bell_vertices"]


def _render_sheets(args, out, bell, anchor, swim):
    """stroke_sheet.png (one cycle, the camera riding along) and contact_sheet.png (the travel,
    a fixed camera); (the stroke's frames, the travel's frames, how far the top rose)."""
    scene, n = bpy.context.scene, _bell_vertices(bell)
    frames, cam = args.cycle_frames, scene.camera
    # one cycle in 8 pictures; the camera rides along so the bell stays in frame
    stroke_shots = [1 + round(k * frames / 8) for k in range(8)]
    z_cam = cam.location.z

    def ride_along():
        cam.location.z = z_cam + bell.matrix_world.translation.z - anchor.location.z

    swim.seconds["render_s"] = _render_sheet(scene, out, "stroke_sheet", stroke_shots,
                                             (args.width, args.height, args.samples), ride_along)
    # its travel: a fixed camera level with the bell's top (tentacles cut off), landscape, and
    # bars where the top began
    scene.frame_set(1)
    start = _bell_top(bell, n)
    scene.frame_set(swim.last_frame)
    rise = _bell_top(bell, n)[2] - start[2]
    _markers(start, args.size)
    cam.data.lens = 50
    # across the frame: the bell and the bars either side, and in its height the whole rise
    view = max(1.9 * args.size, (rise + 1.3 * args.size) * args.height / args.width)
    cam.location = (start[0], start[1] - view * cam.data.lens / 36.0, start[2] + 0.5 * rise)
    cam.rotation_euler = (np.radians(90.0), 0.0, 0.0)
    travel_shots = [1 + swim.every * k * frames for k in range(TRAVEL_SHOTS)]
    swim.seconds["render_s"] += _render_sheet(scene, out, "contact_sheet", travel_shots,
                                              (args.height, args.width, args.samples))
    return stroke_shots, travel_shots, rise


def _metrics_lines(args, swim, volume_err, stroke_shots, travel_shots, rise) -> list:
    config, stroke, sec, frames = swim.config, swim.stroke, swim.seconds, args.cycle_frames
    d = config.bell.diameter
    rows = [
        "# DeformRT jellyfish demo",
        "",
        f"Stroke search: {stroke['method']}, {stroke['evaluations']} cycles on a {args.particles}x{args.particles} "
        f"particle lattice ({stroke['stopped']}), goal: {args.goal} (weights {config.weights} of eq. 3.14).",
        "",
        "| stroke | score (eq. 3.14 over the default's terms) | path (bell diameters per cycle) "
        "| bending energy | energy loss | contraction share |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    scales = reference_scales(config)
    for name, c, cr in (("default stroke (Aurelia-like)", swim.before, default_creature(config)),
                        ("optimized", swim.after, swim.creature)):
        score = fitness(c.path_m, c.bending_energy, c.energy_loss, config, scales)
        rows.append(f"| {name} | {score:+.3f} | {c.path_m / d:.4f} "
                    f"| {c.bending_energy:.3g} | {c.energy_loss:.3g} | {cr.contraction:.2f} |")
    rendered = 2 * len(travel_shots)
    return rows + [
        "",
        "| step | seconds |",
        "|---|---:|",
        f"| one cycle of the default stroke | {sec['default_s']:.2f} |",
        f"| deformrt.optimize_jellyfish | {sec['optimise_s']:.2f} |",
        f"| deformrt.bake_jellyfish ({swim.last_frame} frames) | {sec['bake_s']:.2f} |",
        f"| Cycles, {rendered} frames {args.width}x{args.height} at {args.samples} spp, denoised | "
        f"{sec['render_s']:.1f} |",
        "",
        f"Bell volume over the baked cycle: largest change {100 * max(volume_err):.3f}% of rest.",
        "",
        "contact_sheet.png: the bell's travel, the start of cycles "
        f"{', '.join(str(1 + swim.every * k) for k in range(TRAVEL_SHOTS))} (frames "
        f"{', '.join(map(str, travel_shots))}), left to right, top to bottom; the orange bars mark where its top "
        f"began. It rises {rise * 1000:.0f} mm ({rise / args.size:.3f} bell diameters) in "
        f"{swim.every * TRAVEL_SHOTS} cycles (the stroke simulated {jellyfish.BAKE_CYCLES} cycles in a row, the last "
        "repeating after).",
        "",
        f"stroke_sheet.png: frames {', '.join(map(str, stroke_shots))} of the first {frames}-frame cycle, the camera "
        "riding along (contraction, then relaxation).",
        "",
        "scene.blend: the sea scene with the baked jellyfish, to open in Blender (it plays without DeformRT).",
    ]


def add_parser(sub):
    p = sub.add_parser("jellyfish", help="optimize, bake and render the jellyfish on the sea scene")
    p.add_argument("--out", default="out/jellyfish",
                   help="folder for frames, contact_sheet.png, stroke_sheet.png and metrics.md")
    p.add_argument("--method", choices=("ga-sa", "de", "random"), default="ga-sa")
    p.add_argument("--goal", choices=("fastest", "efficient"), default="fastest",
                   help="what the stroke search looks for: the farthest swim (the default here, so the travel "
                        "shows), or the farthest for its effort (eq. 3.14's weights)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--particles", type=int, default=60, help="fluid particles per side for the search")
    p.add_argument("--population", type=int, default=8)
    p.add_argument("--generations", type=int, default=4)
    p.add_argument("--size", type=float, default=0.3, help="bell diameter in metres")
    p.add_argument("--cycle-frames", type=int, default=24)
    p.add_argument("--width", type=int, default=240)
    p.add_argument("--height", type=int, default=320)
    p.add_argument("--samples", type=int, default=16)
    p.set_defaults(run=run)

"""DeformRT's command line, for pipelines with or without the Blender binary.

    blender -b [file.blend] --command deformrt info
    python path/to/deformrt info          (the bpy module from a plain Python)
"""

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np

from ...core import __version__, rays
from . import jellyfish_demo

_handle = None


def _cmd_info(_args) -> int:
    import numpy
    import scipy
    import trimesh

    try:
        import embreex

        embree = getattr(embreex, "__version__", "found")
    except ImportError:
        embree = "not found (numpy fallback)"
    rows = [
        ("DeformRT", __version__),
        ("Blender", bpy.app.version_string),
        ("Python", sys.version.split()[0]),
        ("Embree (embreex)", embree),
        ("Ray threads", str(rays.thread_count())),
        ("numpy / scipy / trimesh", f"{numpy.__version__} / {scipy.__version__} / {trimesh.__version__}"),
    ]
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")
    return 0


DEMO_SCENES = ("fig_4_12", "fig_4_13", "tubes", "makehuman", "makehuman_animated")
ANIMATED = {"makehuman_animated"}
SHEET_FRAMES = 5  # an animated scene's frames.png: this many frames, as fitted above, resolved below


@dataclass
class _DemoFigures:
    """What the demo measured: the scene's objects as fitted and resolved, the operator's report,
    and how long each step took (seconds)."""

    scene: object
    objs: list
    arrays: list  # MeshArrays as fitted
    report: object  # the Resolve Layers report
    cross_before: np.ndarray  # crossing edges between each pair of layers
    cross_after: np.ndarray
    poke_before: float
    poke_after: float
    seconds: dict  # build, operator, render before, render after


def _cmd_demo(args) -> int:
    from .. import catalog

    # each scene its own folder unless told: a second demo does not overwrite the first's
    out = Path(args.out or ("out/demo" if args.scene == "fig_4_12" else f"out/demo_{args.scene}")).resolve()
    out.mkdir(parents=True, exist_ok=True)
    progress = _Progress(6 if args.scene in ANIMATED else 5)
    progress(f"building the {args.scene} scene")
    t0 = time.perf_counter()
    catalog.SCENES[args.scene][0](args.seed)
    figures = _resolve_and_render(args, out, progress, build_s=time.perf_counter() - t0)
    lines = _metrics_lines(figures, args)
    if args.scene in ANIMATED:
        scene = figures.scene
        progress(f"playing {scene.frame_end - scene.frame_start + 1} frames with Resolve on Frame Change and "
                 "rendering frames.png")
        lines += ["", *_frames_sheet(scene, figures.objs, out, args)]
    table = "\n".join(lines)
    (out / "metrics.md").write_text(table + "\n")
    progress.done()
    print(table)
    print(f"\nwrote {out / 'before.png'}, {out / 'after.png'}, {out / 'metrics.md'} and {out / 'scene.blend'}")
    return 0


def _resolve_and_render(args, out, progress, build_s) -> _DemoFigures:
    """Render the built scene, resolve it as an artist does (the operator), render it again, save
    it, and measure crossings and poke-through before and after."""
    from ...addon.io import mesh_io
    from ...addon.layers import report as reports
    from ...addon.layers import scene_roles
    from ...core.layering import metrics
    from .. import studio

    scene = bpy.context.scene
    objs = [scene_roles.bodies(scene)[0], *scene_roles.garments(scene)]

    def evaluated_layers():
        depsgraph = bpy.context.evaluated_depsgraph_get()
        arrays = [mesh_io.read_mesh(o, depsgraph) for o in objs]
        return arrays, [(a.vertices, a.triangles) for a in arrays]

    arrays, layers_before = evaluated_layers()
    size = (args.width, args.height)
    progress(f"rendering before.png ({args.width}x{args.height}, {args.samples} samples, denoised)")
    seconds = {"build_s": build_s}
    seconds["render_before_s"] = studio.render_cycles(scene, out / "before.png", resolution=size,
                                                      samples=args.samples, denoise=True, quiet=True)
    # what an artist or a pipeline runs: the operator, which leaves a DeformRT modifier on
    # each garment; the renders and metrics below read what Blender evaluates afterwards
    progress("resolving the layers (deformrt.resolve_layers)")
    t0 = time.perf_counter()
    if bpy.ops.deformrt.resolve_layers() != {"FINISHED"}:
        raise RuntimeError("deformrt.resolve_layers did not finish")
    seconds["operator_s"] = time.perf_counter() - t0
    _, layers_after = evaluated_layers()
    progress("rendering after.png")
    seconds["render_after_s"] = studio.render_cycles(scene, out / "after.png", resolution=size,
                                                     samples=args.samples, denoise=True, quiet=True)
    progress("measuring poke-through and saving scene.blend")
    # the resolved scene, to open in Blender: the result renders there with or without DeformRT
    bpy.ops.wm.save_as_mainfile(filepath=str(out / "scene.blend"), check_existing=False)
    cams = metrics.camera_ring(*metrics.layer_bounds(layers_before), views=8, resolution=96)
    return _DemoFigures(scene, objs, arrays, reports.read(scene), metrics.layer_crossings(layers_before),
                        metrics.layer_crossings(layers_after), metrics.poke_through(layers_before, cameras=cams)[0],
                        metrics.poke_through(layers_after, cameras=cams)[0], seconds)


def _metrics_lines(f: _DemoFigures, args) -> list:
    """metrics.md: poke-through and crossings before and after, per object, and where the time went."""
    report, sec = f.report, f.report.seconds
    lines = [
        f"# DeformRT demo: {f.scene.name}",
        "",
        f"**Poke-through: {100 * f.poke_before:.2f}% before, {100 * f.poke_after:.2f}% after** (of the garments' "
        f"pixels over 8 views round the figure, those where a lower layer shows in front of a higher one). "
        f"Crossing edges between the garments: {int(np.triu(f.cross_before).sum()):,} before, "
        f"{int(np.triu(f.cross_after).sum()):,} after. Resolved in {sec['total_s']:.2f} s "
        f"(body parts from {report.parts}).",
        "",
        "Renders: before.png (as fitted one by one), after.png (resolved; the garments' meshes are unchanged, "
        "a DeformRT modifier shows the result). scene.blend: the resolved scene, to open in Blender.",
        "",
        "Per object (an edge where two garments cross shows in both their rows; the outermost garment is "
        "never cut and moves only where it lay on or in the body):",
        "",
        "| object | role | layer | vertices | triangles | crossing edges before | after | max move (mm) "
        "| faces hidden |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for i, (obj, arr) in enumerate(zip(f.objs, f.arrays, strict=True)):
        move = 1000 * report.max_move[i - 1] if i else 0.0
        hidden = report.faces_hidden[i - 1] if i else 0
        lines.append(
            f"| {obj.name} | {obj.deformrt.role.lower()} | {obj.deformrt.layer} | {len(arr.vertices)} "
            f"| {len(arr.triangles)} | {int(f.cross_before[i].sum())} | {int(f.cross_after[i].sum())} "
            f"| {move:.1f} | {hidden} |"
        )
    st, took = report.stages_s, f.seconds
    return lines + [
        "",
        "Where the time went:",
        "",
        "| step | seconds |",
        "|---|---:|",
        f"| build the scene | {took['build_s']:.3f} |",
        f"| read the evaluated meshes | {sec['read_s']:.3f} |",
        f"| find each garment point's body point | {st['correspondence_s']:.3f} |",
        f"| tuck lower layers under hems | {st['boundary_pass_s']:.3f} |",
        f"| push lower layers behind higher ones | {st['push_behind_s']:.3f} |",
        f"| keep cloth out of the body | {st['body_guard_s']:.3f} |",
        f"| hide what still shows through | {st['hidden_faces_s']:.3f} |",
        f"| the resolve ({'Embree' if rays.HAVE_EMBREE else 'numpy'} rays) | {sec['resolve_s']:.3f} |",
        f"| write the results | {sec['write_s']:.3f} |",
        f"| Resolve Layers end to end | {took['operator_s']:.3f} |",
        f"| Cycles render before, {args.width}x{args.height}, {args.samples} samples | {took['render_before_s']:.2f} |",
        f"| Cycles render after | {took['render_after_s']:.2f} |",
    ]


def _frames_sheet(scene, objs, out, args) -> list:
    """frames.png: SHEET_FRAMES frames of the animation as fitted (top row) and as Resolve on Frame
    Change shows them in playback (bottom row, every frame played in order); returns metrics lines."""
    from ...addon.io import mesh_io
    from ...addon.io.image_io import contact_sheet
    from ...addon.layers import frame_handler
    from ...core.layering import metrics
    from .. import studio

    shown = np.linspace(scene.frame_start, scene.frame_end, SHEET_FRAMES).round().astype(int).tolist()
    size = (max(args.width // 2, 64), max(args.height // 2, 64))
    crossings, paths, seconds = {}, {"fitted": [], "resolved": []}, []

    def grab(kind, frame):
        layers = [(a.vertices, a.triangles) for a in
                  (mesh_io.read_mesh(o, bpy.context.evaluated_depsgraph_get()) for o in objs)]
        crossings[(kind, frame)] = int(np.triu(metrics.layer_crossings(layers[1:])).sum())
        path = out / f"frame_{frame:03d}_{kind}.png"
        studio.render_cycles(scene, path, resolution=size, samples=args.samples, denoise=True, quiet=True)
        paths[kind].append(path)

    frame_handler.switch(scene, False)  # as fitted: no result
    for frame in shown:
        scene.frame_set(frame)
        grab("fitted", frame)
    scene.frame_set(scene.frame_start)
    frame_handler.switch(scene, True)
    for frame in range(scene.frame_start, scene.frame_end + 1):
        t0 = time.perf_counter()
        scene.frame_set(frame)
        seconds.append(time.perf_counter() - t0)
        if frame in shown:
            grab("resolved", frame)
    frame_handler.switch(scene, False)
    contact_sheet(paths["fitted"] + paths["resolved"], out / "frames.png", columns=len(shown))
    for path in paths["fitted"] + paths["resolved"]:
        path.unlink()
    return ["| frame | crossing edges between garments, as fitted | resolved in playback |", "|---:|---:|---:|",
            *[f"| {f} | {crossings[('fitted', f)]} | {crossings[('resolved', f)]} |" for f in shown], "",
            f"Playback with Resolve on Frame Change: {1000 * float(np.median(seconds[1:])):.0f} ms a frame (median, "
            f"frame change and resolve). frames.png: frames {', '.join(map(str, shown))} as fitted (top) and resolved "
            "(bottom)."]


class _Progress:
    """One line that says which step runs, rewritten in place on a terminal (a line per step in a log)."""

    def __init__(self, steps: int):
        self.steps, self.step, self.start = steps, 0, time.perf_counter()
        self.tty = sys.stdout.isatty()

    def __call__(self, what: str) -> None:
        self.step += 1
        line = f"[{self.step}/{self.steps}] {what} ({time.perf_counter() - self.start:.0f} s)"
        print(f"\r\033[K{line}" if self.tty else line, end="" if self.tty else "\n", flush=True)

    def done(self) -> None:
        line = f"done in {time.perf_counter() - self.start:.0f} s"
        print(f"\r\033[K{line}" if self.tty else line, flush=True)


def _cmd_scenes(args) -> int:
    """Build each bundled scene, save it (.blend, and .glb for the figures), render it."""
    from ...addon.io import mesh_io
    from ...addon.layers import scene_roles
    from ...core.layering import metrics
    from .. import catalog, dressed, studio

    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    names = args.names or list(catalog.SCENES)
    unknown = sorted(set(names) - set(catalog.SCENES))
    if unknown:
        raise ValueError(f"unknown scene(s) {unknown}; known: {sorted(catalog.SCENES)}")
    rows = ["| scene | what it holds | objects | triangles | crossing edges between layers | build s |",
            "|---|---|---:|---:|---:|---:|"]
    for name in names:
        build, about = catalog.SCENES[name]
        t0 = time.perf_counter()
        build(args.seed)
        build_s = time.perf_counter() - t0
        scene = bpy.context.scene
        for frame in range(1, catalog.SETTLE_FRAMES.get(name, 0) + 1):
            scene.frame_set(frame)
        dressed.save(out / f"{name}.blend", glb=name in catalog.GLB)
        meshes = [o for o in scene.objects if o.type == "MESH"]
        tris = sum(len(mesh_io.read_mesh(o).triangles) for o in meshes)
        layered = scene_roles.bodies(scene) + scene_roles.garments(scene)
        cross = 0
        if len(layered) > 1:
            arrays = [mesh_io.read_mesh(o) for o in layered]
            cross = int(metrics.layer_crossings([(a.vertices, a.triangles) for a in arrays]).sum() // 2)
        studio.render_cycles(scene, out / f"{name}.png", resolution=(args.width, args.height), samples=args.samples)
        rows.append(f"| {name} | {about} | {len(meshes)} | {tris:,} | {cross:,} | {build_s:.1f} |")
        print(rows[-1], flush=True)
    (out / "scenes.md").write_text("\n".join(rows) + "\n")
    print(f"\nwrote {len(names)} scenes (.blend, .png) and scenes.md to {out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="deformrt", description="DeformRT headless commands")
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("info", help="versions, Embree, threads").set_defaults(run=_cmd_info)
    demo = sub.add_parser("demo", help="build a sample scene, measure it and render it to PNG")
    demo.add_argument("--out", default=None, help="folder for renders and metrics.md (default out/demo, or "
                      "out/demo_<scene> for another scene)")
    demo.add_argument("--seed", type=int, default=0)
    demo.add_argument("--scene", choices=DEMO_SCENES, default="fig_4_12", help="bundled scene to resolve")
    demo.add_argument("--width", type=int, default=360, help="render width in pixels")
    demo.add_argument("--height", type=int, default=480, help="render height in pixels")
    demo.add_argument("--samples", type=int, default=16, help="Cycles samples per pixel")
    demo.set_defaults(run=_cmd_demo)
    scenes = sub.add_parser("scenes", help="build, save and render the bundled sample scenes")
    scenes.add_argument("names", nargs="*", help="scenes to build (default: all)")
    scenes.add_argument("--out", default="out/scenes", help="folder for .blend, .glb, .png and scenes.md")
    scenes.add_argument("--seed", type=int, default=0)
    scenes.add_argument("--width", type=int, default=360)
    scenes.add_argument("--height", type=int, default=480)
    scenes.add_argument("--samples", type=int, default=16, help="Cycles samples per pixel")
    scenes.set_defaults(run=_cmd_scenes)
    jellyfish_demo.add_parser(sub)
    return ap


def main(argv) -> int:
    try:
        args = build_parser().parse_args(list(argv))
    except SystemExit as exc:  # argparse exits on --help and on errors; Blender wants a code
        return int(exc.code or 0)
    try:
        return args.run(args)
    except (ValueError, RuntimeError) as exc:
        print(f"deformrt: error: {exc}", file=sys.stderr)
        return 1


def register():
    global _handle
    _handle = bpy.utils.register_cli_command("deformrt", main)


def unregister():
    global _handle
    if _handle is not None:
        bpy.utils.unregister_cli_command(_handle)
        _handle = None

"""DeformRT's command line, for pipelines with or without the Blender binary.

    blender -b [file.blend] --command deformrt info
    python path/to/deformrt info          (the bpy module from a plain Python)
"""

import argparse
import sys
import time
from pathlib import Path

import bpy

from ..core import __version__, rays

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


def _cmd_demo(args) -> int:
    from ..core import metrics
    from ..sample_scenes import studio, tubes
    from . import mesh_io

    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    body, garments = tubes.build(seed=args.seed)
    build_s = time.perf_counter() - t0
    scene = bpy.context.scene
    depsgraph = bpy.context.evaluated_depsgraph_get()
    objs = [body, *garments]
    arrays = [mesh_io.read_mesh(o, depsgraph) for o in objs]
    t0 = time.perf_counter()
    cross = metrics.layer_crossings([(a.vertices, a.triangles) for a in arrays])
    metrics_s = time.perf_counter() - t0
    render_s = studio.render_cycles(scene, out / "before.png", resolution=(args.size, args.size), samples=args.samples)

    lines = [
        f"# DeformRT demo: {scene.name}",
        "",
        "| object | role | layer | vertices | triangles | crossing edges with other layers |",
        "|---|---|---|---:|---:|---:|",
    ]
    for i, (obj, arr) in enumerate(zip(objs, arrays, strict=True)):
        lines.append(
            f"| {obj.name} | {obj.deformrt.role.lower()} | {obj.deformrt.layer} | {len(arr.vertices)} "
            f"| {len(arr.triangles)} | {int(cross[i].sum())} |"
        )
    lines += [
        "",
        "| stage | seconds |",
        "|---|---:|",
        f"| build scene | {build_s:.3f} |",
        f"| crossings ({'embree' if rays.HAVE_EMBREE else 'numpy'}) | {metrics_s:.3f} |",
        f"| Cycles render {args.size}x{args.size}, {args.samples} spp | {render_s:.2f} |",
        "",
        "Renders: before.png (layer correction lands with the resolve pipeline).",
    ]
    table = "\n".join(lines)
    (out / "metrics.md").write_text(table + "\n")
    print(table)
    print(f"\nwrote {out / 'before.png'} and {out / 'metrics.md'}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="deformrt", description="DeformRT headless commands")
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("info", help="versions, Embree, threads").set_defaults(run=_cmd_info)
    demo = sub.add_parser("demo", help="build a sample scene, measure it and render it to PNG")
    demo.add_argument("--out", default="out/demo", help="folder for renders and metrics.md")
    demo.add_argument("--seed", type=int, default=0)
    demo.add_argument("--size", type=int, default=480, help="render width and height in pixels")
    demo.add_argument("--samples", type=int, default=16, help="Cycles samples per pixel")
    demo.set_defaults(run=_cmd_demo)
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

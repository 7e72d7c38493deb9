"""Resolve on Frame Change in Blender: the rigged MakeHuman character (sample scene makehuman_animated,
Armature modifiers, Subdivision 1/2 as MakeHuman's proxies are meant to be seen) played over the
rest-to-run ramp with the handler off and on: what a frame change costs, and what the handler adds,
with the share of the computing (core's resolve and the covered skin, what a worker thread
could run). The stages the handler runs are timed by the resolve's stats.

    .venv/bin/python -m bench.playback      # writes the section of docs/REPORT.md (~1 min)
"""

import time

import numpy as np

from bench.blender import load_package
from bench.report import machine, table, write_section

FRAMES = range(1, 25)


def play(scene, on: bool, resolve_job):
    import bpy

    scene.deformrt.resolve_on_frame_change = False
    scene.frame_set(FRAMES[0])
    scene.deformrt.resolve_on_frame_change = on
    seconds, core = [], []
    original = resolve_job.compute_resolve

    def timed(job):
        t0 = time.perf_counter()
        out = original(job)
        core.append(time.perf_counter() - t0)
        return out

    resolve_job.compute_resolve = timed
    try:
        for f in FRAMES:
            t0 = time.perf_counter()
            scene.frame_set(f)
            bpy.context.evaluated_depsgraph_get()
            seconds.append(time.perf_counter() - t0)
    finally:
        resolve_job.compute_resolve = original
        scene.deformrt.resolve_on_frame_change = False
    return np.array(seconds[1:]) * 1000, np.array(core[1:]) * 1000


def main():
    import bpy

    pkg = load_package()
    from importlib import import_module

    makehuman = import_module(f"{pkg.__name__}.sample_scenes.makehuman")
    resolve_job = import_module(f"{pkg.__name__}.addon.layers.resolve_job")
    rows = []
    for subdivision in (True, False):
        bpy.ops.wm.read_homefile(use_empty=True)
        makehuman.build_animated(subdivision=subdivision)
        scene = bpy.context.scene
        off, _ = play(scene, False, resolve_job)
        on, core = play(scene, True, resolve_job)
        label = "Subdivision 1/2 on every mesh" if subdivision else "no Subdivision"
        rows.append([label, f"{np.median(off):.0f}", f"{np.median(on):.0f} / {on.max():.0f}",
                     f"{np.median(on) - np.median(off):.0f}", f"{np.median(core):.0f}"])
        print(" | ".join(rows[-1]), flush=True)
    body = table(["scene", "frame change, handler off (ms, median)", "handler on (median / max)",
                  "the handler adds", "of which the computing (core resolve, covered skin)"], rows)
    write_section("playback", "Resolve on Frame Change in Blender: a rigged MakeHuman character",
                  f"{machine()}. {__doc__.split(chr(10) + chr(10))[0]}\n\n{body}")


if __name__ == "__main__":
    main()

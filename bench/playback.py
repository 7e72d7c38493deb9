"""Resolve on Frame Change in Blender: the rigged MakeHuman character (sample scene makehuman_animated,
Armature modifiers, Subdivision 1/2 as MakeHuman's proxies are meant to be seen) played over the
rest-to-run ramp (three times) with the handler off and on: what a frame change costs, and what the handler adds,
with the share of the computing (core's resolve and the covered skin, what a worker thread
could run); and played as the viewport plays (between the playback start and stop handlers) with
While Playing, Resolve Every 2 and 3, where the frames between show the last resolve's correction
(their median is a skipped frame's: the mean says what playback costs); and played in real time,
resolving in the frame change or in the background (While Playing, Resolve in the Background).

    .venv/bin/python -m bench.playback      # writes the section of docs/REPORT.md (~4 min)
"""

import time

import numpy as np

from bench.blender import load_package
from bench.report import machine, table, write_section

FRAMES = range(1, 25)
TIMED = 3  # runs over FRAMES that each row's figures take in


def play(scene, on: bool, resolve_job, handler=None, step=1):
    """Frame changes over FRAMES: (ms each after the first, ms of computing each resolve). With
    ``handler``, as viewport playback resolving every ``step``-th frame."""
    import bpy

    scene.deformrt.resolve_on_frame_change = False
    scene.frame_set(FRAMES[0])
    scene.deformrt.resolve_on_frame_change = on
    scene.deformrt.playback_step = step
    scene.deformrt.playback_in_background = False  # resolved in the frame change (play_dropping: beside it)
    if handler is not None:
        handler.on_playback_start(scene)
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
        if handler is not None:
            handler.on_playback_stop(scene)
        scene.deformrt.resolve_on_frame_change = False
        scene.deformrt.playback_step = 1
        scene.deformrt.playback_in_background = True
    return np.array(seconds[1:]) * 1000, np.array(core[1:]) * 1000


def play_dropping(scene, handler, resolve_job, background, fps=24, frames=range(1, 49)):
    """Played in real time as the viewport plays with Sync: Frame Dropping: a frame starts when the
    clock reaches it or when the last one ends (at least the next frame), and between frames the
    main thread waits as Blender's does (a resolve in the background runs meanwhile). Returns
    (frames shown, ms of each frame change after the first, per resolve shown how many frames old
    it was)."""
    import bpy

    scene.deformrt.resolve_on_frame_change = False
    scene.deformrt.playback_in_background = background
    scene.frame_set(frames[0])
    scene.deformrt.resolve_on_frame_change = True
    handler.on_playback_start(scene)
    shown, seconds, ages, f = [], [], [], frames[0]
    original = resolve_job.finish_resolve

    def aged(scene, job, output):
        ages.append(scene.frame_current - job.frame)
        return original(scene, job, output)

    resolve_job.finish_resolve = aged
    start = time.perf_counter()
    try:
        while f <= frames[-1]:
            t0 = time.perf_counter()
            scene.frame_set(f)
            bpy.context.evaluated_depsgraph_get()
            seconds.append(time.perf_counter() - t0)
            shown.append(f)
            due = start + (f + 1 - frames[0]) / fps
            time.sleep(max(due - time.perf_counter(), 0.0))
            f = max(f + 1, frames[0] + int((time.perf_counter() - start) * fps))
    finally:
        handler.on_playback_stop(scene)
        resolve_job.finish_resolve = original
        scene.deformrt.resolve_on_frame_change = False
        scene.deformrt.playback_in_background = True
    return shown, np.array(seconds[1:]) * 1000, np.array(ages[:-1])  # the last: the stop frame's own


def main():
    import bpy

    pkg = load_package()
    from importlib import import_module

    makehuman = import_module(f"{pkg.__name__}.sample_scenes.makehuman")
    resolve_job = import_module(f"{pkg.__name__}.addon.layers.resolve_job")
    handler = import_module(f"{pkg.__name__}.addon.layers.frame_handler")
    rows = []
    for subdivision in (True, False):
        bpy.ops.wm.read_homefile(use_empty=True)
        makehuman.build_animated(subdivision=subdivision)
        scene = bpy.context.scene
        # this machine drifts by several ms between runs: every figure over TIMED runs of the frames
        off = np.concatenate([play(scene, False, resolve_job)[0] for _ in range(TIMED)])
        label = "Subdivision 1/2 on every mesh" if subdivision else "no Subdivision"
        ways = [("every frame (frame_set)", None, 1)]
        if subdivision:
            ways += [("playing, Resolve Every 2", handler, 2), ("playing, Resolve Every 3", handler, 3)]
        for way, playing, step in ways:
            on, core = (np.concatenate(x) for x in zip(*(play(scene, True, resolve_job, playing, step)
                                                          for _ in range(TIMED)), strict=True))
            rows.append([label, way, f"{np.median(off):.0f}", f"{np.median(on):.0f} / {on.mean():.0f} / {on.max():.0f}",
                         f"{np.median(on) - np.median(off):.0f} / {on.mean() - off.mean():.0f}",
                         f"{np.median(core):.0f}"])
            print(" | ".join(rows[-1]), flush=True)
        if subdivision:
            shown, ms, _ = play_dropping(scene, handler, resolve_job, background=False)
            shown_bg, ms_bg, ages = play_dropping(scene, handler, resolve_job, background=True)
            dropping = (f"Played in real time at 24 fps with Sync set to Frame Dropping (frames 1-48, Subdivision on; "
                        f"the next frame shown is the one the clock has reached). Resolved in the frame change: "
                        f"{len(shown)} of 48 frames shown, {np.median(ms):.0f} ms a shown frame (median), each "
                        f"starting from the last one resolved (frame_handler.PLAYBACK_REACH). Resolved in the "
                        f"background (the default): {len(shown_bg)} of 48 frames shown, a frame change "
                        f"{np.median(ms_bg):.0f} / {ms_bg.mean():.0f} / {ms_bg.max():.0f} ms (median / mean / max); "
                        f"{len(ages)} resolves shown, each first on a frame {np.median(ages):.0f} after its own "
                        f"(median; {ages.min()}-{ages.max()}).")
            print(dropping, flush=True)
    body = table(["scene", "resolved", "frame change, handler off (ms, median)", "handler on (median / mean / max)",
                  "the handler adds (median / mean)", "the computing of a resolve (core resolve, covered skin)"],
                 rows)
    write_section("playback", "Resolve on Frame Change in Blender: a rigged MakeHuman character",
                  f"{machine()}. {__doc__.split(chr(10) + chr(10))[0]}\n\n{body}\n{dropping}")


if __name__ == "__main__":
    main()

"""MakeHuman's outfit (sports suit under casual suit) on its skeleton, every frame of the two 24-frame
ramps resolved in order as Resolve on Frame Change does, for three ways of going from frame to
frame: the first frame's body points kept (what playback did before), a fresh body search every
frame, and the default (body points carried through the pose, searched again where the cloth
drifted off or slid beside them, the last frame's result passed as ``previous``). Per animation:
resolve time per frame (the frames after the first, over three runs), the largest move,
crossings and poke-through of any frame, and the frame-to-frame coherence: one-frame blinks of
hidden faces, the correction's second difference (jitter) and vertices whose correction switches
on and off within three frames (blips).

    .venv/bin/python -m bench.animation      # writes the section of docs/REPORT.md (~1 min)
    .venv/bin/python -m bench.animation beyond   # the motions past the ramps (sample_scenes.motions, ~12 min)
    .venv/bin/python -m bench.animation late     # a correction shown 0-3 frames late (~3 min)
    .venv/bin/python -m bench.animation room     # the outer room stage against its cap (~3 min)
    .venv/bin/python -m bench.animation threads  # what a second core buys the resolve (~1 min)
"""

import os
import sys
import threading
import time

import numpy as np
import trimesh

import core.layering.garment_prep as garment_prep
from bench.report import machine, table, write_section
from core.layering import metrics, resolve_layers
from sample_scenes.motions import Skeleton, motions
from sample_scenes.posed import Rig

BLIP_MM = 1.0
TIMED = 3  # runs of each ramp whose frames the ms columns take in (the other figures are the same each run)


def _mesh(v, f):
    return trimesh.Trimesh(v, f, process=False, validate=False)


def play(rig, frames, way, extra=None):
    """Resolve the frames in order; per frame (result, seconds, layers after). ``extra``: more of
    resolve_layers' keywords."""
    kept, last, out = None, None, []
    for matrices in frames:
        bv, gv = rig.frame(matrices)
        body = _mesh(bv, rig.body.faces)
        garments = [_mesh(v, g.faces) for v, g in zip(gv, rig.garments, strict=True)]
        params = dict(extra or {})
        if way != "fresh" and kept is not None:
            params["correspondence"] = kept
        if way == "default" and last is not None:
            params["previous"] = last
        t0 = time.perf_counter()
        last = resolve_layers(body, garments, **params)
        seconds = time.perf_counter() - t0
        if kept is None and way != "fresh":
            kept = last.found()[1]
        layers = [(bv, rig.body.faces)] + [(g.vertices, g.faces) for g in last.garments]
        out.append((last, seconds, layers, gv))
    return out


def coherence(played):
    """One-frame blinks per frame, jitter p99/max (mm), blips per frame, over all garments."""
    hidden = [np.array([r.removed_faces[k] for r, *_ in played]) for k in range(len(played[0][0].moved))]
    moved = [np.array([r.moved[k] for r, *_ in played]) * 1000 for k in range(len(hidden))]
    pops = sum(int(((h[1:-1] != h[:-2]) & (h[1:-1] != h[2:])).sum()) for h in hidden)
    jitter = np.concatenate([np.linalg.norm(d[2:] - 2 * d[1:-1] + d[:-2], axis=2).ravel() for d in moved])
    blips = 0
    for d in moved:
        on = np.linalg.norm(d, axis=2) > BLIP_MM
        change = on[1:] != on[:-1]
        for col in change.T:
            at = np.flatnonzero(col)
            blips += int((np.diff(at) <= 3).sum())
    n = len(played)
    return pops / n, float(np.percentile(jitter, 99)), float(jitter.max()), blips / n


def frame_figures(played):
    """Largest move (mm), most crossing edges, worst poke-through (%) of any frame."""
    move = max(max(np.linalg.norm(m, axis=1).max(initial=0.0) for m in r.moved) for r, *_ in played) * 1000
    cross = max(int(np.triu(metrics.layer_crossings(layers[1:])).sum()) for _, _, layers, _ in played)
    cams = metrics.camera_ring(*metrics.layer_bounds(played[0][2]), views=8, resolution=96)
    poke = max(metrics.poke_through(layers, cameras=cams)[0] for _, _, layers, _ in played[::4]) * 100
    return move, cross, poke


def eased_figures(played):
    """How far playback's easing left the cloth from where each frame alone put it: the farthest (mm)
    over all frames, and vertices left farther than the gap between layers, per frame."""
    most = max(r.stats.get("eased_most", 0.0) for r, *_ in played) * 1000
    past = sum(r.stats.get("eased_past_gap", 0) for r, *_ in played) / len(played)
    return most, past


WAYS = (("first frame's body points kept blindly (as before)", "kept"), ("fresh body search every frame", "fresh"),
        ("carried, checked, previous frame (default)", "default"))


def main():
    rig = Rig()
    rows = []
    for anim, frames in rig.animations.items():
        for label, way in WAYS:
            saved = garment_prep.DRIFT, garment_prep.ASIDE
            if way == "kept":  # the binding of frame 1 carried blindly, as before
                garment_prep.DRIFT, garment_prep.ASIDE = np.inf, -np.inf
            try:
                play(rig, frames[:2], way)  # warm: imports, the body's first facts
                played = play(rig, frames, way)
                # this machine's speed drifts by several ms between runs: the times over TIMED runs
                again = [play(rig, frames, way) for _ in range(TIMED - 1)]
            finally:
                garment_prep.DRIFT, garment_prep.ASIDE = saved
            ms = np.array([s for run in (played, *again) for _, s, _, _ in run[1:]]) * 1000
            move, cross, poke = frame_figures(played)
            pops, j99, jmax, blips = coherence(played)
            rows.append([anim, label, f"{np.median(ms):.0f} / {ms.max():.0f}", f"{move:.0f}", str(cross),
                         f"{poke:.2f}", f"{pops:.2f}", f"{j99:.2f} / {jmax:.1f}", f"{blips:.2f}"])
            print(" | ".join(rows[-1]), flush=True)
    body = table(["animation", "frame to frame", "ms per frame (median / max)", "max move mm",
                  "crossing edges (worst frame)", "poke-through % (worst of every 4th)", "blinks per frame",
                  "jitter p99 / max mm", "blips per frame"], rows)
    write_section("animation", "Layered garments in motion: MakeHuman's outfit on its skeleton, frame after frame",
                  f"{machine()}. {__doc__.split(chr(10) + chr(10))[0]}\n\n{body}")


def beyond():
    """The default frame to frame on motion past the ramps: a walk in place and travelling, a jog,
    ramps into harder poses."""
    rig = Rig()
    rows = []
    for name, frames in motions(Skeleton(rig)).items():
        play(rig, frames[:2], "default")
        played = play(rig, frames, "default")
        ms = np.array([s for _, s, _, _ in played[1:]]) * 1000
        move, cross, poke = frame_figures(played)
        pops, j99, jmax, blips = coherence(played)
        lag, past = eased_figures(played)
        posed = [np.array([gv[k] for *_, gv in played]) * 1000 for k in range(len(rig.garments))]
        cloth = np.concatenate([np.linalg.norm(x[2:] - 2 * x[1:-1] + x[:-2], axis=2).ravel() for x in posed])
        rows.append([name, str(len(frames)), f"{np.median(ms):.0f} / {ms.max():.0f}", f"{move:.0f}", str(cross),
                     f"{poke:.2f}", f"{pops:.2f}", f"{j99:.2f} / {jmax:.1f}", f"{np.percentile(cloth, 99):.1f}",
                     f"{blips:.2f}", f"{lag:.0f} / {past:.1f}"])
        print(" | ".join(rows[-1]), flush=True)
    body = table(["motion", "frames", "ms per frame (median / max)", "max move mm", "crossing edges (worst frame)",
                  "poke-through % (worst of every 4th)", "blinks per frame", "jitter p99 / max mm",
                  "the cloth's own p99 mm", "blips per frame",
                  "eased: farthest from the frame's own (mm) / vertices past the gap per frame"], rows)
    write_section("animation_beyond", "Layered garments in motion past the ramps: a walk, a jog, harder poses",
                  f"{machine()}. The same outfit and measures as the ramps' table, the default frame to frame, on "
                  "motion made by forward kinematics on MakeHuman's skeleton read back from the rig's matrices "
                  "(sample_scenes.motions): a walk (30 frames a step cycle at 24 fps), the same walk carried "
                  "forward at 1.4 m/s and turning 1.5 degrees a frame as a captured walk is, a jog (18 frames, "
                  "longer strides) and 24-frame ramps from rest into fourteen harder poses. The last column is "
                  "what the smoothness costs: how far easing left the cloth from where each frame alone put it (the "
                  "resolve's stats eased_most and eased_past_gap).\n\n" + body)


LATE = (0, 1, 2, 3)


def late():
    """A correction shown frames late, as playback with the resolve in the background shows it: frame
    m's offsets and hidden faces on frame m + k's pose (every second frame m)."""
    rig = Rig()
    rows = []
    for name, frames in {**rig.animations, **motions(Skeleton(rig))}.items():
        if name not in ("ramp_run01", "ramp_gym01", "walk", "jog"):
            continue
        played = play(rig, frames, "default")
        cams = metrics.camera_ring(*metrics.layer_bounds(played[0][2]), views=8, resolution=96)
        for k in LATE:
            pokes, cross = [], []
            for m in range(2, len(played) - k, 2):
                result, posed = played[m][0], played[m + k][3]
                layers = [(rig.frame(frames[m + k])[0], rig.body.faces)] + [
                    (v + d, g.faces[~h]) for v, d, g, h in zip(posed, result.moved, rig.garments,
                                                                result.removed_faces, strict=True)]
                pokes.append(metrics.poke_through(layers, cameras=cams)[0] * 100)
                cross.append(int(np.triu(metrics.layer_crossings(layers[1:])).sum()))
            rows.append([name, str(k), f"{np.mean(pokes):.3f} / {max(pokes):.3f}",
                         f"{np.mean(cross):.1f} / {max(cross)}"])
            print(" | ".join(rows[-1]), flush=True)
    body = table(["motion", "frames late", "poke-through % (mean / worst)", "crossing edges (mean / worst)"], rows)
    write_section("animation_late", "A correction shown frames late (playback with the resolve in the background)",
                  f"{machine()}. {' '.join(late.__doc__.split())} The outfit and measures of the tables "
                  f"above.\n\n{body}")


CAPS = (None, 0.75, 1.0, 2.0)  # the outer room's most lift in gaps (None: the stage off)


def room():
    """The outer room stage against its cap: on the rig's still poses, resolved afresh, the lower
    layer's faces hidden, the crossing edges left and the largest move; on the walk, frame after
    frame, the jitter and the worst frame's crossing edges; and the stage's time a frame."""
    import core.layering.outer_room as outer_room

    rig = Rig()
    walk = motions(Skeleton(rig))["walk"]
    rows, saved = [], outer_room.MOST
    try:
        for cap in CAPS:
            outer_room.MOST = cap or saved
            kw = {"outer_room": cap is not None}
            hidden, cross, move = [], [], []
            for pose in ("tpose", "run01", "gym01"):
                bv, gv = rig.frame(rig.poses[pose])
                garments = [_mesh(v, g.faces) for v, g in zip(gv, rig.garments, strict=True)]
                r = resolve_layers(_mesh(bv, rig.body.faces), garments, **kw)
                layers = [(g.vertices, g.faces) for g in r.garments]
                hidden.append(int(r.removed_faces[0].sum()))
                cross.append(int(np.triu(metrics.layer_crossings(layers)).sum()))
                move.append(max(float(np.linalg.norm(m, axis=1).max()) for m in r.moved) * 1000)
            played = play(rig, walk, "default", kw)
            secs = [r.stats.get("outer_room_s", 0.0) for r, *_ in played[1:]]
            _, j99, jmax, blips = coherence(played)
            _, wcross, _ = frame_figures(played)
            rows.append(["off" if cap is None else f"{cap:g} gap", " / ".join(map(str, hidden)),
                         " / ".join(map(str, cross)), " / ".join(f"{m:.0f}" for m in move),
                         f"{j99:.2f} / {jmax:.1f}", f"{blips:.2f}", str(wcross), f"{np.median(secs) * 1000:.1f}"])
            print(" | ".join(rows[-1]), flush=True)
    finally:
        outer_room.MOST = saved
    body = table(["outer room", "lower faces hidden (tpose / run01 / gym01)", "crossing edges left",
                  "largest move mm", "walk: jitter p99 / max mm", "walk: blips a frame",
                  "walk: crossing edges (worst frame)", "ms a frame (walk, median)"], rows)
    write_section("animation_room", "The outer room stage against its cap",
                  f"{machine()}. {' '.join(room.__doc__.split())}\n\n{body}")


def threads():
    """What the second core can buy a frame's resolve: two playbacks of the rest-to-run ramp that
    share nothing, one after the other and on two threads at once, with the resolve's own ray
    threads off (DEFORMRT_THREADS=1) so that only the two playbacks compete for the cores. Run
    together they take the fraction of the time in turn that the Python interpreter's lock leaves
    them: 0.5 if nothing held it, 1 if everything did. Splitting one frame's stages over two threads
    can do no better than two whole playbacks that never wait on each other."""
    saved = os.environ.get("DEFORMRT_THREADS")
    os.environ["DEFORMRT_THREADS"] = "1"
    rig = Rig()
    frames = rig.animations["ramp_run01"]
    rows = []
    try:
        play(rig, frames[:2], "default")
        for run in range(TIMED):
            t0 = time.perf_counter()
            play(rig, frames, "default")
            play(rig, frames, "default")
            in_turn = time.perf_counter() - t0
            both = [threading.Thread(target=play, args=(rig, frames, "default")) for _ in range(2)]
            t0, c0 = time.perf_counter(), time.process_time()
            for t in both:
                t.start()
            for t in both:
                t.join()
            together, cpu = time.perf_counter() - t0, time.process_time() - c0
            rows.append([str(run + 1), f"{in_turn:.2f}", f"{together:.2f}", f"{together / in_turn:.2f}",
                         f"{cpu / together:.2f}"])
            print(" | ".join(rows[-1]), flush=True)
    finally:
        if saved is None:
            os.environ.pop("DEFORMRT_THREADS")
        else:
            os.environ["DEFORMRT_THREADS"] = saved
    body = table(["run", "two playbacks in turn (s)", "on two threads at once (s)", "together / in turn",
                  "cores busy while together"], rows)
    write_section("animation_threads", "What a second core buys the resolve",
                  f"{machine()}. {' '.join(threads.__doc__.split())}\n\n{body}")


if __name__ == "__main__":
    ways = {"beyond": beyond, "late": late, "room": room, "threads": threads}
    ways.get(sys.argv[1] if len(sys.argv) > 1 else "", main)()

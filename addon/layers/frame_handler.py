"""Resolve on frame change: keeps the layering right through playback, animation renders and
frame bakes when ``scene.deformrt.resolve_on_frame_change`` is on."""


from contextlib import contextmanager

import bpy
from bpy.app.handlers import persistent

from ..io import blender_versions
from . import background_resolve, frame_memory, report, resolve_job, result_stack, results, staleness
from .scene_read import LayeringInputError, layered_objects

_busy = False
_seen = {}  # scene name: resolve_on_frame_change as last acted on
_resolved = {}  # scene name: the frame the results shown were resolved for (with their cages)
_replay = None  # while a frame bake writes its cache: (frame: writes, the bake's signals)
# Viewport playback (between animation_playback_pre and _post): frames since the last resolve, and
# whether the frame shown now needs resolving when playback stops (left to the last resolve, or
# resolved without the cage check that keeps a result off a mesh it was not made for).
_playback = {"playing": False, "since": None, "redo": False, "last": None, "uncaged": False}
# Playing, Blender drops the frames it has no time to show (Sync: Frame Dropping or Sync to Audio), so
# the next frame comes 2 or more after the last: it still starts from the last resolve (its body points
# carried and checked, its faces held, its correction eased) up to this many frames back. Started
# afresh, a frame after a drop searched the body again (1.6x the time: more frames dropped) and showed
# the hidden faces and corrections of a first frame. A loop's jump back to its start is farther.
PLAYBACK_REACH = 8
# Scenes whose render job runs (render_init to render_complete or render_cancel): an animation rendered
# every n-th frame (Frame Step) starts each frame from the one rendered before it, as playback does.
_rendering = set()


@contextmanager
def replaying(kept: dict, signals):
    """Frame changes write the results ``kept`` for each frame (``results.recording``) instead of
    resolving; nothing more once ``signals`` caught one."""
    global _replay
    _replay = (kept, signals)
    try:
        yield
    finally:
        _replay = None


def _write_kept(scene):
    kept, signals = _replay
    if signals.caught:
        return
    for obj, shown in kept.get(scene.frame_current, ()):
        results.write(scene, obj, shown)


def switched(scene):
    """Resolve on Frame Change was switched. Off: show the garments as simulated or posed
    again (a correction kept from one frame would be wrong on every other). On: the next frame
    change corrects."""
    _seen[scene.name] = scene.deformrt.resolve_on_frame_change
    _resolved.pop(scene.name, None)
    background_resolve.drop()
    frame_memory.forget()
    if not scene.deformrt.resolve_on_frame_change:
        resolve_job.clear_scene(scene)


def switch(scene, on: bool):
    """Switch Resolve on Frame Change, with what switching it does in every Blender version."""
    scene.deformrt.resolve_on_frame_change = on
    if not blender_versions.PROPERTY_CALLBACKS:
        switched(scene)


def _notice_switch(scene):
    """Where the property cannot call back (blender_versions), act on a switch when it is seen."""
    if not blender_versions.PROPERTY_CALLBACKS and _seen.get(scene.name, False) != \
            scene.deformrt.resolve_on_frame_change:
        switched(scene)


@persistent
def on_depsgraph_update(scene, depsgraph):
    """After an edit: act on a switch the property could not call back for, and with Resolve on
    Frame Change on, resolve again what the edit put out of date."""
    if _busy:
        return
    _notice_switch(scene)
    if (scene.deformrt.resolve_on_frame_change and bpy.context.mode == "OBJECT"
            and staleness.touched(scene, depsgraph) and staleness.check_scene(scene, depsgraph)):
        resolve_frame(scene)


@persistent
def on_frame_change(scene, _depsgraph=None):
    if _replay is not None:
        _write_kept(scene)
        return
    _notice_switch(scene)
    if _busy or not scene.deformrt.resolve_on_frame_change or _shown_already(scene):
        return
    resolve_frame(scene)


def _shown_already(scene) -> bool:
    """Whether this frame change needs no resolve: a render's motion blur steps (a fraction of a frame
    before and after the frame rendered, which was resolved first) show that frame's result on their
    poses, so the mesh keeps its faces and deforms in between; and the frame the results were
    resolved for, seen again (a render starting and ending on it, the centre of its motion blur),
    keeps them while they still fit and none was marked stale. Resolved again instead, the centre
    started afresh (its last resolve was for the same frame): the steps had other faces hidden
    than the centre, so Cycles blurred no garment, and a render's frames lost the holds and easing
    of frame after frame."""
    global _busy
    frame, step = _resolved.get(scene.name), scene.frame_subframe != 0.0
    # playback and stepping come here every frame: another frame is decided before looking at objects
    if frame is None or (abs(frame - scene.frame_current - scene.frame_subframe) >= 1.0 if step
                         else scene.frame_current != frame):
        return False
    try:
        body, garments = layered_objects(scene)
    except LayeringInputError:
        return False  # resolving says what is wrong
    objects = [o for o in (body, *garments) if results.result_modifier(o) is not None]
    if not objects:
        return False
    if step:
        for o in objects:
            results.check_cage(o, False)
        return True
    if not all([results.check_cage(o, True) for o in objects]):
        return False
    if staleness.stale_garments(scene):  # an edit made where the depsgraph handler leaves it (Pose Mode)
        return False
    _busy = True  # evaluating calls the depsgraph handler: not to resolve from there
    try:
        depsgraph = bpy.context.evaluated_depsgraph_get()
        return all(results.fits_now(o, depsgraph) for o in objects)
    finally:
        _busy = False


def resolve_frame(scene):
    """Resolve the frame shown now (frame after frame: from the last resolve, frame_memory)."""
    global _busy
    _resolved.pop(scene.name, None)
    # a render started while the viewport plays resolves every frame it renders, whole
    playing = _playback["playing"] and scene.name not in _rendering
    background = playing and scene.deformrt.playback_in_background
    step = scene.deformrt.playback_step if playing and not background else 1
    since = _playback["since"]
    if step > 1 and since is not None and since + 1 < step:
        # the modifier shows the last resolve's offsets on this frame's pose (docs/REPORT.md: poke-through
        # under 0.02% a frame after on the ramps and a walk)
        _playback["since"] += 1
        _playback["redo"] = True
        return
    _busy = True  # reading the scene re-evaluates it; never re-enter
    try:
        if background:
            _play_in_background(scene)
            return
        frame, last = scene.frame_current, _playback["last"]
        rendered_every = scene.frame_step if scene.name in _rendering and scene.frame_step > 1 else None
        if _playback["playing"]:
            background_resolve.settle()  # a render's frame: not beside a resolve playback started
        correct_frame(scene, step, PLAYBACK_REACH if playing else rendered_every)
        # the frame playback stops on is resolved again as stepping to it would (on_playback_stop) where
        # this one was left frames to, or started from a resolve more than a frame away
        dropped = playing and last is not None and abs(frame - last) > 1
        if playing == _playback["playing"]:  # a render's frame leaves what playback keeps as it was
            _playback["since"], _playback["redo"] = (0, True) if step > 1 else (None, dropped)
            _playback["last"] = frame if playing else None
        if step == 1:  # written with their cages
            _resolved[scene.name] = frame
    except (ValueError, RuntimeError) as exc:
        # a handler cannot report to the user: say it once in the panel and the console
        message = f"Resolve on frame change stopped at frame {scene.frame_current}: {exc}"
        print(f"DeformRT: {message}")
        switch(scene, False)
        report.write(scene, report.LayersReport(kind="stopped", message=message))
    finally:
        _busy = False


def _play_in_background(scene):
    """A frame of viewport playback with the resolve on a worker thread: the resolve that ended since
    the last frame is shown (on this frame's pose: no cage check), and the next one starts from this
    frame. The frame playback stops on is resolved whole (on_playback_stop)."""
    if not _playback["uncaged"]:
        # what the frame playback started from shows until the first resolve in the background ends
        # (with its cage the garments would show as fitted for the frames the first resolve takes)
        _playback["uncaged"] = True
        body, garments = layered_objects(scene)
        for o in (body, *garments):
            results.check_cage(o, False)
    done = background_resolve.take()
    # one from far off (a loop's wrap back to the start) would show another pose's correction
    if done is not None and abs(done[0].frame - scene.frame_current) <= PLAYBACK_REACH:
        try:
            resolve_job.finish_resolve(scene, *done)
        except ReferenceError:  # an object it read was deleted while it ran: the next one reads anew
            pass
    if not background_resolve.busy():
        _check_cloth(scene)
        # step 0: frames the resolve has not reached show it, so it is written without its cages
        background_resolve.start(resolve_job.prepare_resolve(scene, playing=True, step=0, reach=PLAYBACK_REACH))
    _playback["since"], _playback["redo"], _playback["last"] = None, True, scene.frame_current


def restarting_cloth(scene, objects):
    """Names of garments whose unbaked cloth would start over if DeformRT's result were added
    (or shown again, or moved to its place in the stack) now: changing a garment's modifiers
    resets an unbaked cache. Reading the simulated shape and writing new corrections later do
    not, so a simulation played from its first frame is corrected live."""
    out = []
    for o in objects:
        mod = results.result_modifier(o)
        if mod is not None and mod.show_viewport and mod.show_render and result_stack.in_place(o, mod):
            continue
        for m in o.modifiers:
            if (m.type == "CLOTH" and m.show_viewport and not m.point_cache.is_baked
                    and scene.frame_current > m.point_cache.frame_start):
                out.append(o.name)
    return out


@persistent
def on_playback_start(scene, _depsgraph=None):
    _playback.update(playing=True, since=None, redo=False, last=None, uncaged=False)


@persistent
def on_playback_stop(scene, _depsgraph=None):
    """Playback stopped: the frame it stopped on is resolved as stepping to it would, if playback
    left it to the last resolve or resolved it without the cage check."""
    redo = _playback["redo"]
    _playback.update(playing=False, since=None, redo=False, last=None, uncaged=False)
    background_resolve.settle()
    if redo and scene.deformrt.resolve_on_frame_change and not _busy:
        resolve_frame(scene)


@persistent
def on_render_init(scene, _depsgraph=None):
    _rendering.add(scene.name)


@persistent
def on_render_end(scene, _depsgraph=None):
    _rendering.discard(scene.name)


def correct_frame(scene, step=1, reach=None):
    """The layering of the current frame (what the handler runs); returns its summary. ``step`` > 1:
    playback resolves every ``step``-th frame (the last resolve is ``step`` frames back or nearer).
    ``reach``: how far back the last resolve may be for this frame to start from it (playback)."""
    _check_cloth(scene)
    return resolve_job.resolve_scene(scene, playing=True, step=step, reach=reach)


def _check_cloth(scene):
    _, garments = layered_objects(scene)
    restarting = restarting_cloth(scene, garments)
    if restarting:
        raise LayeringInputError(
            f"{', '.join(restarting)}: bake the cloth first (Physics > Cache > Bake All Dynamics) or turn this "
            "on at the simulation's first frame; adding DeformRT's result restarts an unbaked simulation")


_RENDER_HANDLERS = (("render_init", on_render_init), ("render_complete", on_render_end),
                    ("render_cancel", on_render_end))


def register():
    if on_frame_change not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(on_frame_change)
    if on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.append(on_depsgraph_update)
    if on_playback_start not in bpy.app.handlers.animation_playback_pre:
        bpy.app.handlers.animation_playback_pre.append(on_playback_start)
    if on_playback_stop not in bpy.app.handlers.animation_playback_post:
        bpy.app.handlers.animation_playback_post.append(on_playback_stop)
    for name, fn in _RENDER_HANDLERS:
        if fn not in getattr(bpy.app.handlers, name):
            getattr(bpy.app.handlers, name).append(fn)


def unregister():
    while on_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(on_frame_change)
    while on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(on_depsgraph_update)
    while on_playback_start in bpy.app.handlers.animation_playback_pre:
        bpy.app.handlers.animation_playback_pre.remove(on_playback_start)
    while on_playback_stop in bpy.app.handlers.animation_playback_post:
        bpy.app.handlers.animation_playback_post.remove(on_playback_stop)
    for name, fn in _RENDER_HANDLERS:
        while fn in getattr(bpy.app.handlers, name):
            getattr(bpy.app.handlers, name).remove(fn)
    _rendering.clear()
    background_resolve.drop()
    _playback.update(playing=False, since=None, redo=False, last=None, uncaged=False)
    frame_memory.forget()
    _seen.clear()
    _resolved.clear()

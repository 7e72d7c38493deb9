"""Bake Frames: every frame of a range is resolved first, one at a time, with what each frame
writes kept; then Blender's Alembic exporter steps the frames while the frame handler writes the
kept results again. The long part is ours and stops between frames (Esc in the UI, Ctrl+C or
SIGTERM headless): a signal only raises a flag, so no handler Blender calls can swallow it. A
stopped bake writes nothing, leaves an earlier cache at the path as it was, and puts the scene
back (frame, Resolve on Frame Change, a still resolve shown before)."""

import os
import shutil
import signal
import sys

import bpy

from ..io import blender_versions
from . import frame_handler, frame_memory, resolve_job, results
from .scene_read import layered_objects

PARTIAL_SUFFIX = ".deformrt-partial.abc"


class BakeStopped(RuntimeError):
    """The bake ended before its cache was written; the message says why."""


def partial_path(path: str) -> str:
    """Where the cache is written before it is whole: ours by its name."""
    return (path[:-4] if path.lower().endswith(".abc") else path) + PARTIAL_SUFFIX


class _Signals:
    """Ctrl+C and SIGTERM raise a flag for the duration (main thread only; a handler installed
    by C code, which Python cannot put back, is left alone)."""

    def __init__(self):
        self.caught = None
        self._old = {}

    def __enter__(self):
        for sig in (signal.SIGINT, signal.SIGTERM):
            old = signal.getsignal(sig)
            if old is None:
                continue
            try:
                signal.signal(sig, self._catch)
            except ValueError:  # not the main thread
                return self
            self._old[sig] = old
        return self

    def _catch(self, sig, _frame):
        self.caught = self.caught or sig

    def __exit__(self, *_exc):
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()

    def pass_on(self, message: str):
        """After the clean-up: a SIGTERM goes on to do what it was sent for (end the process),
        saying first what it stopped (the operator's report would never be printed)."""
        if self.caught == signal.SIGTERM:
            print(f"DeformRT: {message}", file=sys.stderr, flush=True)
            signal.raise_signal(signal.SIGTERM)


def _render_vertices(obj, depsgraph) -> tuple:
    """(vertices, corners) the Alembic export writes per frame for ``obj``: what the viewport
    evaluates, times four per level its subdivision modifiers add in the render."""
    mesh = obj.evaluated_get(depsgraph).data
    extra = sum(max(getattr(m, "render_levels", 0) - getattr(m, "levels", 0), 0)
                for m in obj.modifiers if m.type in ("SUBSURF", "MULTIRES") and m.show_render)
    return len(mesh.vertices) * 4 ** extra, len(mesh.loops) * 4 ** extra


def cache_fits(path, objs, depsgraph, frames) -> None:
    """Refuse, with what to do, a cache path that is a folder, or a disk that cannot take the cache
    (Blender's Alembic writer aborts the whole program when its disk fills, unsaved work and all).
    A missing folder is made."""
    if os.path.isdir(path):
        raise ValueError(f"{path} is a folder: give a file name for the cache (for example {path.rstrip(os.sep)}"
                         f"{os.sep}layers.abc)")
    folder = os.path.dirname(path) or "."
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"Cannot make the folder {folder} for the cache: {exc.strerror}") from exc
    # positions and normals per vertex, a UV per corner, each frame (measured files are smaller)
    per_frame = sum(24 * v + 8 * c for v, c in (_render_vertices(o, depsgraph) for o in objs))
    needed = 2 * per_frame * frames + (64 << 20)
    free = shutil.disk_usage(folder).free
    if free < needed:
        raise ValueError(f"The disk of {folder} has {free / 2**20:.0f} MB free and the cache of {frames} frames may "
                         f"need {needed / 2**20:.0f} MB: free some space or bake fewer frames; nothing was written")


def start_bake(scene, frame_start, frame_end, filepath, depsgraph) -> "FrameBake":
    """A FrameBake of frames ``frame_start``..``frame_end`` to ``filepath`` (Blender's // allowed),
    after checking what it needs; raises ValueError with what to change."""
    if frame_end < frame_start:
        raise ValueError(f"End frame {frame_end} is before start frame {frame_start}")
    body, garments = layered_objects(scene)
    if filepath.startswith("//") and not bpy.data.filepath:
        raise ValueError("Save the file first or give an absolute path for the cache")
    path = bpy.path.abspath(filepath)
    frames = range(frame_start, frame_end + 1)
    cache_fits(path, [body, *garments], depsgraph, len(frames))
    return FrameBake(scene, body, garments, frames, path)


class FrameBake:
    """One bake of ``frames`` (a range) of the scene's tagged figure to ``path``. ``step``
    resolves the next frame (True while frames are left), ``write`` exports, ``restore``
    puts the scene back; ``abandon`` does that for a bake that will not be written.
    As a stepped job (operators.base.SteppedOperator): ``advance`` steps and keeps a failure,
    ``end`` writes (unless stopped), puts the scene back and says how it went."""

    def __init__(self, scene, body, garments, frames, path):
        self.scene, self.body, self.garments = scene, body, garments
        self.frames, self.path = frames, path
        self.partial = partial_path(path)
        self._left = iter(frames)
        self.done = 0
        self.total = len(frames)
        self.failure = None
        self.kept = {}  # frame: the results.write calls it made
        self.signals = _Signals().__enter__()  # until end()
        self.was_on = scene.deformrt.resolve_on_frame_change
        self.frame = scene.frame_current
        self.shown = any(results.data_object(o) is not None for o in (body, *garments))
        correspondence = frame_memory.kept_correspondence() if self.was_on else {}
        # the results shown now go (switching the handler off clears them); the correspondence
        # playback found stays, so the cache holds what was shown
        frame_handler.switch(scene, False)
        frame_memory.keep_correspondence(correspondence)

    @property
    def stop_reason(self) -> str | None:
        caught = self.signals.caught
        return None if caught is None else f"stopped by {signal.Signals(caught).name}"

    def step(self) -> bool:
        """Resolve the next frame; False when none is left. Raises ValueError (a frame that
        cannot be resolved) or BakeStopped (a signal came)."""
        frame = next(self._left, None)
        if frame is None:
            return False
        self.scene.frame_set(frame)
        with results.recording() as writes:
            frame_handler.correct_frame(self.scene)
        self.kept[frame] = writes
        self.done += 1
        if self.stop_reason:
            raise BakeStopped(self.stop_reason)
        return True

    def write(self) -> None:
        """Export the kept frames to a file beside the path, then move it onto the path."""
        scene, objs = self.scene, (self.body, *self.garments)
        if os.path.isfile(self.partial):  # left by a bake that was killed: ours, by its name; never the cache
            os.remove(self.partial)
        frame_handler.switch(scene, False)  # Blender's exporter crashes on result objects made before it
        selection = [o for o in scene.objects if o.select_get()]
        failure = None
        try:
            with frame_handler.replaying(self.kept, self.signals):
                scene.frame_set(self.frames[0])
                for o in selection:
                    o.select_set(False)
                for o in objs:
                    o.select_set(True)
                failure = _export(self.partial, self.frames[0], self.frames[-1])
        finally:
            for o in objs:
                o.select_set(False)
            for o in selection:
                o.select_set(True)
        if failure is None and self.stop_reason:
            failure = self.stop_reason
        if failure is None and not os.path.isfile(self.partial):
            failure = "the Alembic export wrote no file"
        if failure is not None:
            if os.path.isfile(self.partial):
                os.remove(self.partial)
            raise BakeStopped(failure)
        os.replace(self.partial, self.path)

    def restore(self) -> None:
        """The frame shown before, and what was shown on it: Resolve on Frame Change as it was
        (resolving this frame now), or the still resolve made again."""
        scene = self.scene
        correspondence = frame_memory.kept_correspondence()
        frame_handler.switch(scene, False)  # changing frames with it on right after an export crashes Blender
        scene.frame_set(self.frame)
        if self.was_on:
            frame_handler.switch(scene, True)
            frame_memory.keep_correspondence(correspondence)
            frame_handler.on_frame_change(scene)
        elif self.shown:
            resolve_job.resolve_scene(scene)

    def abandon(self) -> None:
        """Put the scene back for a bake that will not be written."""
        self.restore()
        self.signals.__exit__(None, None, None)

    def advance(self) -> bool:
        """``step``, a frame that cannot be resolved or a signal kept as the failure (False)."""
        try:
            return self.step()
        except (ValueError, RuntimeError) as exc:
            self.failure = str(exc)
            return False

    def end(self, cancelled: str | None = None) -> tuple:
        """Write the cache (unless stopped: ``cancelled`` says by what) and put the scene back;
        (whether it was written, the one message to report)."""
        failure = cancelled or self.failure
        try:
            if failure is None:
                self.write()
        except BakeStopped as exc:
            failure = str(exc)
        finally:
            self.restore()
            self.signals.__exit__(None, None, None)
        if failure is not None:
            message = (f"Bake stopped after {self.done} of {len(self.frames)} frames, nothing written "
                       f"(a cache already at the path is as it was): {failure}")
            self.signals.pass_on(message)
            return False, message
        return True, f"Baked {len(self.frames)} frames of {len(self.garments)} garments to {self.path}"


def _export(path, start, end) -> str | None:
    """Blender's Alembic export of the selected objects; None, or why it failed."""
    export = bpy.ops.wm.alembic_export
    try:
        done = export(**blender_versions.operator_arguments(
            export, filepath=path, start=start, end=end, selected=True, visible_objects_only=False, uvs=True,
            apply_subdiv=True, as_background_job=False))
    except RuntimeError as exc:
        return f"the Alembic export failed: {exc}"
    return None if done == {"FINISHED"} else "the Alembic export was cancelled"

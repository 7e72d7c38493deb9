"""The per-frame numbers of a baked swim: where in its stroke the bell is (the contraction's
phase), a slow wobble, the offset along the normals that keeps the bell's volume, and how far it
has risen, cycle after cycle of the simulated stroke."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bell3d
from .bell import phase


@dataclass
class SwimFrame:
    frame: int
    tau: float  # where in its cycle, 0..1
    contraction: float  # the stroke's phase s (0 rest, 1 contracted)
    wobble: float  # 0..1
    volume: float  # the volume-keeping offset, in bell thicknesses
    rise_m: float  # along the axis since frame_start


@dataclass(frozen=True)
class FrameRange:
    """Frames ``start`` to ``end`` (inclusive), one stroke cycle every ``cycle_frames``."""

    start: int
    end: int
    cycle_frames: int


@dataclass(frozen=True)
class BellPose:
    """The bell's ``rest`` vertices with their ``moved`` (contracted) and ``wobbled`` offsets, its
    ``faces`` and ``normals``, and ``thickness``, the volume offset's unit (the bell's model units)."""

    rest: np.ndarray
    moved: np.ndarray
    wobbled: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    thickness: float


def swim_frames(cycle, creature, frames: FrameRange, bell: BellPose, seed=0) -> list[SwimFrame]:
    """One SwimFrame a frame: ``cycle`` the simulated CycleResult (one cycle or several in a row),
    ``creature`` its stroke, ``seed`` the wobble's phase. The bell rises by the simulated path,
    cycle after cycle; past the cycles simulated, the last one repeats."""
    rest_volume = bell3d.volume(bell.rest, bell.faces)
    per_cycle = cycle.path_per_cycle_m if cycle.path_per_cycle_m is not None else np.array([cycle.path_m])
    simulated = len(per_cycle)
    substeps = len(cycle.speed) // simulated
    travelled = np.concatenate([[0.0], cycle.swum])
    times = np.arange(len(travelled)) / substeps  # in cycles
    last = travelled[-substeps - 1:] - travelled[-substeps - 1]

    def rise(t):
        if t <= simulated:
            return float(np.interp(t, times, travelled))
        whole, tau = divmod(t - simulated, 1.0)
        return float(travelled[-1] + whole * per_cycle[-1] + np.interp(tau, times[: substeps + 1], last))

    out = []
    start, cycle_frames = frames.start, frames.cycle_frames
    for frame in range(start, frames.end + 1):
        cycles, tau = divmod((frame - start) / cycle_frames, 1.0)
        s = float(phase(tau, creature.contraction))
        w = 0.5 * (np.sin(2 * np.pi * (frame - start) / (1.7 * cycle_frames) + seed) + 1.0)
        now = bell.rest + s * bell.moved + w * bell.wobbled
        offset = bell3d.volume_offset(now, bell.faces, bell.normals, rest_volume) / bell.thickness
        y = rise((frame - start) / cycle_frames)
        out.append(SwimFrame(frame, tau, s, w, offset, y))
    return out


__all__ = ["BellPose", "FrameRange", "SwimFrame", "swim_frames"]

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


def swim_frames(cycle, creature, frame_start, frame_end, cycle_frames, seed, rest, moved, wobbled, faces, normals,
                thickness) -> list[SwimFrame]:
    """One SwimFrame a frame: ``cycle`` the simulated CycleResult (one cycle or several in a row),
    ``creature`` its stroke; the bell's ``rest`` vertices with their ``moved`` (contracted) and
    ``wobbled`` offsets, its ``faces`` and ``normals``, ``thickness`` the offset's unit (metres,
    the bell's model units). The bell rises by the simulated path, cycle after cycle; past the
    cycles simulated, the last one repeats."""
    rest_volume = bell3d.volume(rest, faces)
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
    for frame in range(frame_start, frame_end + 1):
        cycles, tau = divmod((frame - frame_start) / cycle_frames, 1.0)
        s = float(phase(tau, creature.contraction))
        w = 0.5 * (np.sin(2 * np.pi * (frame - frame_start) / (1.7 * cycle_frames) + seed) + 1.0)
        now = rest + s * moved + w * wobbled
        offset = bell3d.volume_offset(now, faces, normals, rest_volume) / thickness
        y = rise((frame - frame_start) / cycle_frames)
        out.append(SwimFrame(frame, tau, s, w, offset, y))
    return out


__all__ = ["SwimFrame", "swim_frames"]

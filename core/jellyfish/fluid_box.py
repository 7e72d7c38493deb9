"""The fluid's box and its sides: walls (no-slip, moving along themselves), mirrors and periodic
sides, made of ghost particles outside the box; and the error a simulation raises when its
numbers stop meaning anything."""

from dataclasses import dataclass, field

import numpy as np

SIDES = ("left", "right", "bottom", "top")


class FluidBlowUp(RuntimeError):
    """The simulation left the range where its numbers mean anything."""


@dataclass
class Box:
    """A rectangle [0, width] x [0, height]. ``periodic`` = (x, y); a side that is not periodic
    is a no-slip wall moving along itself at ``wall_velocity[side]`` (default at rest), or a
    mirror (a symmetry axis or a free-slip wall) if it is among ``mirrors``."""

    width: float
    height: float
    periodic: tuple = (False, False)
    wall_velocity: dict = field(default_factory=dict)
    mirrors: tuple = ()

    def __post_init__(self):
        if not (np.isfinite([self.width, self.height]).all() and self.width > 0 and self.height > 0):
            raise ValueError(f"the box needs a finite size > 0, got {self.width} x {self.height}")
        unknown = (set(self.wall_velocity) | set(self.mirrors)) - set(SIDES)
        if unknown:
            raise ValueError(f"wall_velocity and mirrors sides must be among {SIDES}, got {sorted(unknown)}")
        wrapped = {side for axis in (0, 1) if self.periodic[axis] for side in SIDES[2 * axis:2 * axis + 2]}
        if wrapped & set(self.mirrors):
            raise ValueError(f"a periodic side cannot be a mirror: {sorted(wrapped & set(self.mirrors))}")


def ghosts(points, box: Box, reach):
    """Ghost particles within ``reach`` outside the box: (positions, source index, velocity
    sign (g, 2), velocity offset (g, 2)). Periodic copies are made first, so walls mirror them too."""
    n = len(points)
    pos, src = points.copy(), np.arange(n)
    sign, offset = np.ones((n, 2)), np.zeros((n, 2))
    sizes = (box.width, box.height)
    for axis in (0, 1):
        lo, hi = SIDES[2 * axis], SIDES[2 * axis + 1]
        x = pos[:, axis]
        new = []
        if box.periodic[axis]:
            for sel, shift in ((x < reach, sizes[axis]), (x > sizes[axis] - reach, -sizes[axis])):
                p = pos[sel].copy()
                p[:, axis] += shift
                new.append((p, src[sel], sign[sel], offset[sel]))
        else:
            for sel, plane, side in ((x < reach, 0.0, lo), (x > sizes[axis] - reach, sizes[axis], hi)):
                p = pos[sel].copy()
                p[:, axis] = 2 * plane - p[:, axis]
                if side in box.mirrors:  # the normal component turns, the tangential one is kept
                    flip = np.ones(2)
                    flip[axis] = -1.0
                    new.append((p, src[sel], flip * sign[sel], flip * offset[sel]))
                    continue
                wall = np.zeros(2)
                wall[1 - axis] = box.wall_velocity.get(side, 0.0)
                # no-slip: both components mirrored about the wall's own velocity
                new.append((p, src[sel], -sign[sel], 2 * wall - offset[sel]))
        for p, s, g, o in new:
            pos, src = np.vstack([pos, p]), np.concatenate([src, s])
            sign, offset = np.vstack([sign, g]), np.vstack([offset, o])
    return pos[n:], src[n:], sign[n:], offset[n:]


__all__ = ["SIDES", "Box", "FluidBlowUp", "ghosts"]

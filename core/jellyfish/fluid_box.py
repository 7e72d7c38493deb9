"""What a lattice fluid is set up with: its box and the box's sides (walls, no-slip and moving
along themselves, mirrors and periodic sides, made of ghost particles outside the box), the
liquid in it, how it steps; and the error a simulation raises when its numbers stop meaning
anything."""

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

SIDES = ("left", "right", "bottom", "top")


class FluidBlowUp(RuntimeError):
    """The simulation left the range where its numbers mean anything."""


@dataclass(frozen=True)
class Liquid:
    """What fills the box: kinematic viscosity (m^2/s), density (kg/m^3) and a body force per unit
    mass (m/s^2, along x and y)."""

    viscosity: float = 1e-6
    density: float = 1000.0
    body_force: tuple = (0.0, 0.0)

    def __post_init__(self):
        if not (np.isfinite(self.viscosity) and self.viscosity >= 0):
            raise ValueError(f"viscosity must be finite and >= 0, got {self.viscosity}")
        if not (np.isfinite(self.density) and self.density > 0):
            raise ValueError(f"density must be finite and > 0, got {self.density}")


@dataclass(frozen=True)
class Stepping:
    """How the lattice fluid steps: its kernel's reach in spacings (``re_factor``), the largest
    Courant number of an inner step (``cfl``), how the pressure and a viscous step are solved
    ("auto": "spectral" on a box periodic both ways, "modes" (``axial_modes``) on one periodic
    along y only, else "direct", a sparse LU; or "krylov"), and how a forced body's velocity is
    imposed: GMRES corrections after each projection, a fixed count, or until the field on the
    body meets its velocity to ``forcing_tolerance`` (a share of its fastest speed)."""

    re_factor: float = 2.1
    cfl: float = 1.0
    pressure_solver: str = "auto"
    forcing_corrections: int = 1
    forcing_tolerance: float | None = None

    def __post_init__(self):
        if not (0 < self.cfl <= 5):
            raise ValueError(f"cfl must be in (0, 5], got {self.cfl}")
        if int(self.forcing_corrections) != self.forcing_corrections or self.forcing_corrections < 0:
            raise ValueError(f"forcing_corrections must be a whole number >= 0, got {self.forcing_corrections}")
        tol = self.forcing_tolerance
        if tol is not None and not (np.isfinite(tol) and tol > 0):
            raise ValueError(f"forcing_tolerance must be a share > 0 of the body's speed (or None), got {tol}")
        if self.pressure_solver not in ("auto", "spectral", "modes", "direct", "krylov"):
            raise ValueError("pressure_solver is 'auto', 'spectral', 'modes', 'direct' or 'krylov'")


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


class Ghosts(NamedTuple):
    """Particles mirrored or copied across the box's sides: where they are, which particle each
    copies, and how its velocity follows that particle's (times ``sign``, plus ``offset``)."""

    positions: np.ndarray
    source: np.ndarray
    sign: np.ndarray
    offset: np.ndarray


def ghosts(points, box: Box, reach) -> Ghosts:
    """The Ghosts within ``reach`` outside the box. Periodic copies are made first, so walls
    mirror them too."""
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
    return Ghosts(pos[n:], src[n:], sign[n:], offset[n:])


__all__ = ["SIDES", "Box", "FluidBlowUp", "Ghosts", "Liquid", "Stepping", "ghosts"]

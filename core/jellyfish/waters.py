"""The waters a bell can swim in, one class each: the particle lattice it is, where the bell's axis
sits in it, and how the bell's section turns into the volume its tissue keeps. One registry
(``WATERS``): the config, the operator's menu and a stored stroke all name a water by its key."""

import numpy as np

from .axisymmetric_fluid import AxisymmetricFluid
from .fluid_box import Box, Liquid, Stepping
from .particle_fluid import LatticeFluid


class Water:
    key = ""
    label = ""
    description = ""
    dimensions = 2  # the tissue's volume scales as the bell's size to this power

    def check(self, config) -> None:
        """Raise ValueError for a config this water cannot be made from."""

    def lattice(self, config, liquid: Liquid, stepping: Stepping) -> LatticeFluid:
        raise NotImplementedError

    def axis_x(self, config) -> float:
        """Where the bell's axis lies across the lattice, m."""
        raise NotImplementedError

    def section_volume(self, points, left: int):
        """(The volume a closed bell section like ``bell.contour``'s stands for, its centroid's
        height); ``left`` the index of the section's leftmost point."""
        raise NotImplementedError


def _shoelace(x, y):
    x2, y2 = np.roll(x, -1), np.roll(y, -1)
    return x2, y2, x * y2 - x2 * y


class RoundTheAxis(Water):
    """The section turned about the axis: the bell of revolution the 3D animal is, in a cylinder of
    water whose lattice fills the half-plane out from the axis."""

    key = "axisymmetric"
    label = "Round the Axis"
    description = "The water round a bell of revolution, as the 3D jellyfish swims in it"
    dimensions = 3

    def check(self, config) -> None:
        if config.particles % 2:
            raise ValueError(f"particles must be even round the axis (half on each side), got {config.particles}")

    def lattice(self, config, liquid: Liquid, stepping: Stepping) -> LatticeFluid:
        return AxisymmetricFluid(0.5 * config.box, config.height, config.particles // 2, config.rows, liquid, stepping)

    def axis_x(self, config) -> float:
        return 0.0  # the lattice starts at the axis

    def section_volume(self, points, left: int):
        # the right half (over the exumbrella to the axis, back under the subumbrella) by Pappus
        quarter = left // 2
        p = np.vstack([points[:quarter + 1], points[left + quarter:]])
        x, y = p[:, 0], p[:, 1]
        x2, y2, cross = _shoelace(x, y)
        moment = ((x + x2) * cross).sum() / 6.0  # the integral of r over the half-section
        lever = ((x * (2 * y + y2) + x2 * (y + 2 * y2)) * cross).sum() / 24.0  # of r z
        return 2.0 * np.pi * moment, lever / moment


class Planar(Water):
    """The thesis' 2D water: a trough infinitely long out of the plane, periodic both ways, which
    carries more water along for its volume (the same stroke swims about half as far)."""

    key = "planar"
    label = "Planar"
    description = "A bell as long as the water is deep (flat 2D water): the same stroke swims about half as far"

    def lattice(self, config, liquid: Liquid, stepping: Stepping) -> LatticeFluid:
        return LatticeFluid(Box(config.box, config.height, periodic=(True, True)), nx=config.particles,
                            ny=config.rows, liquid=liquid, stepping=stepping)

    def axis_x(self, config) -> float:
        return 0.5 * config.box

    def section_volume(self, points, left: int):
        x, y = points[:, 0], points[:, 1]
        _, y2, cross = _shoelace(x, y)
        area = 0.5 * cross.sum()
        return area, ((y + y2) * cross).sum() / (6.0 * area)


WATERS = {w.key: w for w in (RoundTheAxis(), Planar())}


def water(key: str) -> Water:
    """The registered water named ``key``."""
    if key not in WATERS:
        raise ValueError(f"fluid is one of {', '.join(repr(k) for k in WATERS)}, got {key!r}")
    return WATERS[key]


def lattice_for(config) -> LatticeFluid:
    """The config's water as a particle lattice, with its viscosity, density and forcing."""
    return water(config.fluid).lattice(
        config, Liquid(viscosity=config.viscosity, density=config.density),
        Stepping(cfl=config.cfl, forcing_corrections=config.forcing_corrections,
                 forcing_tolerance=config.forcing_tolerance, pressure_solver=config.solver))

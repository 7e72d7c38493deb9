"""The velocity on a fluid's lattice as cubic B-splines, for the semi-Lagrangian step: each
component's coefficients, padded past the box's sides with the ghost rows they call for (wrapped,
mirrored, or mirrored about a wall's velocity), and its values anywhere in the box."""

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import map_coordinates, spline_filter

from .fluid_box import SIDES, Box

# ghost rows the splines are padded with past each side that is not periodic
PAD = 4


@dataclass(frozen=True)
class LatticeSpline:
    """Splines on an nx x ny lattice of spacing ``h`` filling ``box``."""

    box: Box
    nx: int
    ny: int
    h: float

    def coefficients(self, values, component):
        """Cubic B-spline coefficients of one velocity component on the lattice, padded with
        the ghost rows the sides call for (wrapped or mirrored about the wall's velocity)."""
        if all(self.box.periodic):  # exact periodic splines: no side, no padding, the flow's mirror symmetry kept
            return spline_filter(values.reshape(self.ny, self.nx), order=3, mode="grid-wrap")
        pad = PAD
        out = np.empty((self.ny + 2 * pad, self.nx + 2 * pad))
        out[pad:-pad, pad:-pad] = values.reshape(self.ny, self.nx)
        for axis, n in ((1, self.nx), (0, self.ny)):  # array axis 1 runs along x
            space = 1 - axis
            lo_side, hi_side = SIDES[2 * space], SIDES[2 * space + 1]
            for k in range(pad):
                if self.box.periodic[space]:
                    lo_val = np.take(out, pad + n - 1 - k, axis=axis)
                    hi_val = np.take(out, pad + k, axis=axis)
                else:
                    lo_val = self._mirror(np.take(out, pad + k, axis=axis), lo_side, space, component)
                    hi_val = self._mirror(np.take(out, pad + n - 1 - k, axis=axis), hi_side, space, component)
                lo, hi = pad - 1 - k, pad + n + k
                if axis == 1:
                    out[:, lo], out[:, hi] = lo_val, hi_val
                else:
                    out[lo, :], out[hi, :] = lo_val, hi_val
        return spline_filter(out, order=3, mode="nearest")

    def _mirror(self, row, side, normal_axis, component):
        if side in self.box.mirrors:
            return -row if component == normal_axis else row
        wall = self.box.wall_velocity.get(side, 0.0) if component != normal_axis else 0.0
        return 2.0 * wall - row

    def sample(self, coeffs, points):
        """The spline's values at ``points`` (m, 2)."""
        if all(self.box.periodic):
            return map_coordinates(coeffs, [points[:, 1] / self.h - 0.5, points[:, 0] / self.h - 0.5], order=3,
                                   mode="grid-wrap", prefilter=False)
        pad = PAD
        rows = points[:, 1] / self.h - 0.5 + pad
        cols = points[:, 0] / self.h - 0.5 + pad
        if self.box.periodic[0]:
            cols = (cols - pad) % self.nx + pad
        if self.box.periodic[1]:
            rows = (rows - pad) % self.ny + pad
        return map_coordinates(coeffs, [rows, cols], order=3, mode="nearest", prefilter=False)


__all__ = ["PAD", "LatticeSpline"]

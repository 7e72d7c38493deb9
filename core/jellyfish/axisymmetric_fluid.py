"""The particle fluid of particle_fluid.py round an axis: a body of revolution in open water.

The lattice fills the meridional half-plane, x the distance r from the axis and y along it;
with no swirl the flow there is the 3D flow round the axis. The planar operators gain the
terms of cylindrical coordinates (u_r the x component):

    div u   = du_r/dr + u_r / r + du_z/dz
    lap u_z = lap2 u_z + (1/r) du_z/dr
    lap u_r = lap2 u_r + (1/r) du_r/dr - u_r / r^2
    lap p   = lap2 p + (1/r) dp/dr          (div grad, for the projection)

and each particle stands for the ring of water 2 pi r h^2 it sweeps. The axis is a mirror
(u_r odd, u_z even); the outer side is a free-slip wall, which takes no momentum along the
axis, and the axis is periodic, as the planar box is both ways. The pressure is solved
directly: the operator is unsymmetric, and its left null vector (not the constant it is
in the plane) makes the right-hand side solvable.
"""


import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .fluid_box import Box, Liquid, Stepping
from .particle_fluid import LatticeFluid


class AxisymmetricFluid(LatticeFluid):
    """Velocity (u_r, u_z) on an nr x nz lattice filling [0, radius] x [0, height]."""

    def __init__(self, radius: float, height: float, nr: int, nz: int, liquid: Liquid | None = None,
                 stepping: Stepping | None = None):
        stepping = stepping or Stepping()
        if stepping.pressure_solver not in ("auto", "modes", "direct"):
            raise ValueError("the axisymmetric fluid solves its pressure directly (by modes, or a sparse LU)")
        super().__init__(Box(radius, height, periodic=(False, True), mirrors=("left", "right")), nr, nz, liquid,
                         stepping)
        self.radius = self.points[:, 0]
        self.volume = 2.0 * np.pi * self.radius * self.h**2
        self._dr = None

    def whole_section(self, values, odd=False):
        """Per-particle values on the full section through the axis (2 nr x nz, the planar
        lattice's order): the half-plane and its mirror image, negated if ``odd`` (u_r, the
        vorticity)."""
        v = np.asarray(values).reshape(self.ny, self.nx, *np.shape(values)[1:])
        return np.concatenate([-v[:, ::-1] if odd else v[:, ::-1], v], axis=1).reshape(-1, *np.shape(values)[1:])

    # --- operators ------------------------------------------------------------------
    def _radial_gradient(self):
        """d/dr as an (n, points) matrix on the particles and their ghosts."""
        if self._dr is None:
            self._dr = 2.0 / self.n0 * self._nb._gradient_matrices()[0]
        return self._dr

    def _unknowns(self, sign):
        """(points, n) matrix taking each particle's unknown to it and its ghosts (times ``sign``)."""
        points = self.n + len(self._src)
        values = np.concatenate([np.ones(self.n), sign])
        return sp.csr_matrix((values, (np.arange(points), self._column)), shape=(points, self.n))

    def divergence(self, u=None):
        u = self.u if u is None else u
        return super().divergence(u) + u[:, 0] / self.radius

    def viscous_operator(self, k):
        key = ("operator", k)
        if key not in self._viscous:
            lap, const = super().viscous_operator(k)
            inv_r = sp.diags(1.0 / self.radius)
            lap = lap + inv_r @ self._radial_gradient() @ self._unknowns(self._sign[:, k])
            if k == 0:
                lap = lap - sp.diags(1.0 / self.radius**2)
            const = const + self._radial_gradient() @ np.concatenate([np.zeros(self.n), self._offset[:, k]]) / \
                self.radius
            self._viscous[key] = (lap.tocsr(), const)
        return self._viscous[key]

    def pressure_operator(self):
        return (super().pressure_operator() +
                sp.diags(1.0 / self.radius) @ self._radial_gradient() @ self._unknowns(np.ones(len(self._src)))).tocsr()

    _pin = -1  # the outer top corner, far from the body

    def left_null(self, lap, pin):
        """lap^T y = 0 but at the pin (which follows: lap's columns sum to zero), y at the pin 1."""
        transposed = lap.T.tolil()
        transposed[pin, :] = 0.0
        transposed[pin, pin] = 1.0
        unit = np.zeros(self.n)
        unit[pin] = 1.0
        return spla.splu(transposed.tocsc()).solve(unit)

    def _uniform_momentum(self, change):
        # only along the axis: a uniform u_r is neither divergence-free nor without vorticity here
        return np.array([0.0, float(change[:, 1] @ self.volume / self.volume.sum())])

"""A 2D incompressible particle-gridless hybrid fluid (thesis 3.4, after Yoon, Koshizuka and Oka).

Particles start each step on a regular lattice. The Lagrangian phase traces where each
lattice particle's fluid came from (a midpoint back-trace) and takes the velocity there
from a cubic spline through the lattice; the particles are thus returned to the lattice
every step (the thesis' step 6), which keeps the MPS operators accurate. Viscosity and body
forces are implicit (backward Euler with the MPS Laplacian, eq. 3.5), so a stiff viscosity
costs no extra steps; the pressure Poisson equation (3.9) with the MPS divergence (3.7) is
solved directly and its gradient (3.4) makes the velocity divergence-free. On a regular lattice
periodic along an axis every operator is the same at each row, so these solves go by Fourier
modes (``axial_modes``; both ways periodic, divisions); else by a sparse LU.

Walls and periodic sides are ghost particles: a periodic ghost copies its source, a wall
ghost mirrors it (velocity 2 U_wall - u for no-slip, the pressure copied). Inner steps keep
the Courant number at most ``cfl``, so any step is stable; a blow-up raises FluidBlowUp.
"""

import time
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..geometry.cache import Cache, nbytes
from .axial_modes import AxialModes
from .body_projection import project_with_body
from .fluid_box import Box, FluidBlowUp, Liquid, Stepping, ghosts
from .lattice_spline import LatticeSpline
from .mps import Neighbours, lattice

# Factored pressure and viscous matrices by lattice (and viscosity and step): an optimisation
# simulates many creatures on one. A lattice's by modes take about 2 MB at 100 particles a side,
# 16 MB at 200.
FACTORS = Cache(max_entries=8, max_bytes=256 * 2**20)


class LatticeFluid:
    """Velocity on an nx x ny lattice of particles filling ``box``; ``step(dt)`` advances it."""

    def __init__(self, box: Box, nx: int, ny: int | None = None, liquid: Liquid | None = None,
                 stepping: Stepping | None = None):
        """``liquid`` and ``stepping``: what fills the box and how it steps (their defaults: water)."""
        liquid, stepping = liquid or Liquid(), stepping or Stepping()
        ny = nx if ny is None else ny
        if nx < 4 or ny < 4:
            raise ValueError(f"the lattice needs at least 4 x 4 particles, got {nx} x {ny}")
        hx, hy = box.width / nx, box.height / ny
        if not np.isclose(hx, hy, rtol=1e-9):
            raise ValueError(f"the lattice must be square: {box.width}/{nx} != {box.height}/{ny}")
        pressure_solver, re_factor = stepping.pressure_solver, stepping.re_factor
        if pressure_solver == "spectral" and not all(box.periodic):
            raise ValueError("the spectral solves need a box periodic on both axes")
        if pressure_solver == "modes" and tuple(box.periodic) != (False, True):
            raise ValueError("the solves by modes need a box periodic along y only")
        self.forcing_corrections, self.forcing_tolerance = int(stepping.forcing_corrections), stepping.forcing_tolerance
        self.box, self.nx, self.ny, self.h = box, nx, ny, hx
        self.nu, self.rho, self.cfl = float(liquid.viscosity), float(liquid.density), float(stepping.cfl)
        self.body_force = np.asarray(liquid.body_force, float)
        # On a lattice periodic both ways every operator is the same stencil at every particle (a
        # circulant): the Fourier transform makes the pressure and viscous solves divisions.
        # Periodic along y only, every operator is the same at every row: a dense solve per Fourier
        # mode along y (axial_modes) instead of a sparse LU of the whole lattice.
        if pressure_solver == "auto":
            pressure_solver = ("spectral" if all(box.periodic) else "modes" if tuple(box.periodic) == (False, True)
                               else "direct")
        self.pressure_solver = pressure_solver
        self._symbols = None
        self.points = lattice(nx, ny, self.h)
        self.n = len(self.points)
        self.re = re_factor * self.h
        ghost = ghosts(self.points, box, self.re)
        self._src, self._sign, self._offset = ghost.source, ghost.sign, ghost.offset
        self._nb = Neighbours.build(np.vstack([self.points, ghost.positions]), self.re, n_rows=self.n)
        # the constants of a full lattice: exact Laplacian of quadratics, exact linear gradients
        full = Neighbours.build(lattice(9, 9, self.h), self.re)
        self.n0, self.lam = float(full.density()[40]), float(full.lam()[40])
        self._column = np.concatenate([np.arange(self.n), self._src])
        self.u = np.zeros((self.n, 2))
        self.volume = np.full(self.n, self.h**2)  # per unit depth: the water each particle stands for
        self.p = np.zeros(self.n)
        self.time = 0.0
        self.steps = 0
        self._viscous = {}
        self._pressure = None
        self.forcing_miss = 0.0  # the last step's largest |u - body velocity| on a forced body, m/s
        self.forcing_taken = 0  # the last step's GMRES corrections on a forced body
        self.timings = {"advect_s": 0.0, "viscous_s": 0.0, "pressure_s": 0.0}

    def move_walls(self, wall_velocity: dict) -> None:
        """The walls' velocities along themselves (m/s by side, as Box takes them) from the next step
        on: a wall oscillating in its own plane is one moved before every step."""
        self.box = replace(self.box, wall_velocity=dict(wall_velocity))
        self._offset = ghosts(self.points, self.box, self.re).offset
        # the viscous matrices do not see the walls' speed: only their constant parts change
        for key, (matrix, _) in self._viscous.items():
            self._viscous[key] = (matrix, self._wall_constant(key[1]))

    # --- values at ghosts -------------------------------------------------------------
    def _extended(self, u):
        return np.vstack([u, self._sign * u[self._src] + self._offset])

    def _extended_scalar(self, p):
        return np.concatenate([p, p[self._src]])

    # --- operators ------------------------------------------------------------------
    def divergence(self, u=None):
        return self._nb.divergence(self._extended(self.u if u is None else u), self.n0)

    def gradient(self, p):
        return self._nb.gradient(self._extended_scalar(p), self.n0)

    def vorticity(self, u=None):
        """dv/dx - du/dy per particle."""
        u = self.u if u is None else u
        ext = self._extended(u)
        return (self._nb.gradient(ext[:, 1], self.n0)[:, 0] - self._nb.gradient(ext[:, 0], self.n0)[:, 1])

    # --- one step -------------------------------------------------------------------
    def stable_dt(self) -> float:
        speed = float(np.abs(self.u).max(initial=0.0))
        return self.cfl * self.h / speed if speed > 0 else np.inf

    def step(self, dt: float, forcing=None, max_inner: int | None = None) -> int:
        """Advance by ``dt`` in as many equal inner steps as the Courant limit needs; returns
        how many. dt = 0 does nothing. ``forcing.body(t)`` gives the body's ``ImposedBody`` at the
        end of each inner step, imposed inside its projection with ``forcing_corrections`` GMRES
        corrections (body_projection); ``forcing.moved(u, dt)`` is then told the field kept.
        A step that would need more than ``max_inner`` inner steps raises FluidBlowUp."""
        if not (np.isfinite(dt) and dt >= 0):
            raise ValueError(f"dt must be finite and >= 0, got {dt}")
        if forcing is not None and any(self.box.wall_velocity.values()):
            # the corrections combine projected fields, which needs the projection linear
            raise ValueError("a forced body needs walls at rest: the projection with moving walls is not linear")
        left, inner = float(dt), 0
        while left > 0.0:
            # equal inner steps under the Courant limit (no sliver of a step at the end)
            count = max(1, int(np.ceil(left / self.stable_dt() * (1 - 1e-9))))
            if max_inner is not None and inner + count > max_inner:
                raise FluidBlowUp(f"the flow got too fast: {inner + count} inner steps for one step of {dt:.3g} s, "
                                  f"at most {max_inner} (peak speed {np.abs(self.u).max():.3g} m/s)")
            h = left / count
            self._substep(h, forcing)
            left = 0.0 if count == 1 else left - h
            inner += 1
        return inner

    def _substep(self, dt, forcing=None):
        if not np.isfinite(self.u).all():
            raise FluidBlowUp(f"non-finite velocity before step {self.steps + 1} (t = {self.time:.4g} s)")
        t0 = time.perf_counter()
        # Half the last pressure push acts where the fluid was, half where it arrives: the
        # pressure then acts along the path, and advection-projection splitting is second order.
        # Not with a forced body: there the projection's pressure is mostly the impulse that sets the
        # particles the body has just covered to its velocity, once; carried into the next step it
        # pushes the fluid again (the first stroke's path then depends on the rounds: 0.0078 D at one,
        # 0.0132 at sixteen, against 0.0137 and 0.0152 without it).
        if forcing is not None:
            self.p = np.zeros(self.n)
        half = 0.5 * dt / self.rho * self.gradient(self.p)
        u = self._advect(self.u - half, dt, self.u) - half
        t1 = time.perf_counter()
        u = self._viscous_step(u, dt)
        t2 = time.perf_counter()
        if forcing is None:
            u, dp = self.project(u, dt)
            self.p = self.p + dp
        else:
            # the body's velocity imposed inside the projection; the field kept is the projected one:
            # imposing the body once more after it would leave a divergence at the body's surface,
            # from which the next advection makes momentum that a free body's momentum balance then
            # takes from the body (a bell swimming backwards)
            body = forcing.body(self.time + dt)
            out = project_with_body(lambda f: self.project(f, dt), u, body, self.volume, self.forcing_corrections,
                                    self.forcing_tolerance)
            u, self.p, self.forcing_miss = out.u, out.p, out.miss
            self.forcing_taken = out.corrections
            forcing.moved(u, dt)
        self.u = u
        t3 = time.perf_counter()
        self.timings["advect_s"] += t1 - t0
        self.timings["viscous_s"] += t2 - t1
        self.timings["pressure_s"] += t3 - t2
        self.time += dt
        self.steps += 1
        if not np.isfinite(self.u).all():
            raise FluidBlowUp(f"non-finite velocity after step {self.steps} (t = {self.time:.4g} s)")

    def _advect(self, u, dt, carrier):
        """``u`` carried from where each particle's fluid was dt ago (midpoint back-trace in
        the ``carrier`` velocity), its momentum kept.

        Carrying momentum about makes none: the integral of (u . grad) u over the box is the flux
        of u (u . n) through its sides, zero where the sides wrap or are walls (u . n = 0), once
        the field is divergence-free. The semi-Lagrangian scheme is not conservative: next to a
        body's sharp velocity it makes a net momentum of about 3 mm/s x the body's mass a cycle,
        which a free body's momentum balance would take from the body. It is taken back as a
        uniform velocity, which has neither divergence nor vorticity: the flow is otherwise untouched."""
        spline = LatticeSpline(self.box, self.nx, self.ny, self.h)
        coeffs = [spline.coefficients(u[:, k], k) for k in (0, 1)]
        carry = coeffs if carrier is u else [spline.coefficients(carrier[:, k], k) for k in (0, 1)]
        mid = self.points - 0.5 * dt * carrier
        u_mid = np.column_stack([spline.sample(c, mid) for c in carry])
        start = self.points - dt * u_mid
        out = np.column_stack([spline.sample(c, start) for c in coeffs])
        return out - self._uniform_momentum(out - u)

    def _uniform_momentum(self, change):
        """The uniform velocity that carries the momentum of ``change``."""
        return change.mean(0)

    def _viscous_matrix(self, dt, k):
        key = (dt, k)
        if key not in self._viscous:
            if len(self._viscous) > 8:
                self._viscous = {c: v for c, v in self._viscous.items() if c[0] == "operator"}
            lap, const = self.viscous_operator(k)
            shared = (*self._lattice_key(), "viscous", self.nu, dt, k)
            solver = FACTORS.get(shared)
            if solver is None:
                a = sp.identity(self.n, format="csc") - dt * self.nu * lap.tocsc()
                solver = AxialModes(a.tocsr(), self.nx, self.ny) if self.pressure_solver == "modes" else spla.splu(a)
                FACTORS.put(shared, solver, nbytes(solver))
            self._viscous[key] = (solver, const)
        return self._viscous[key]

    def _spectral_symbols(self):
        """The Fourier symbols of the gradient (x, y), the pressure Laplacian and the viscous
        Laplacian (x, y): each operator applied to a unit value at particle 0 is its stencil."""
        if self._symbols is None:
            unit = np.zeros(self.n)
            unit[0] = 1.0
            fft = lambda column: np.fft.rfft2(np.asarray(column).reshape(self.ny, self.nx))  # noqa: E731
            grad = self.gradient(unit)
            lap = self.pressure_operator() @ unit
            viscous = [self.viscous_operator(k)[0] @ unit for k in (0, 1)]
            self._symbols = (fft(grad[:, 0]), fft(grad[:, 1]), fft(lap), [fft(v) for v in viscous])
        return self._symbols

    def _field(self, values):
        return np.fft.rfft2(values.reshape(self.ny, self.nx))

    def _values(self, spectrum):
        return np.fft.irfft2(spectrum, s=(self.ny, self.nx)).ravel()

    def _viscous_step(self, u, dt):
        out = np.empty_like(u)
        if self.pressure_solver == "spectral":
            viscous = self._spectral_symbols()[3]
            for k in (0, 1):
                rhs = u[:, k] + dt * self.body_force[k]
                out[:, k] = rhs if self.nu == 0 else self._values(self._field(rhs) / (1.0 - dt * self.nu * viscous[k]))
            return out
        # a weak viscous step (water on a fine lattice) is a few Krylov iterations; a stiff one
        # is factored once per step size and reused; by modes, each is a direct solve, made once
        # per step size
        stiff = self.pressure_solver == "modes" or dt * self.nu / self.h**2 > 0.5
        for k in (0, 1):
            rhs = u[:, k] + dt * self.body_force[k]
            if self.nu == 0:
                out[:, k] = rhs
                continue
            if stiff:
                lu, const = self._viscous_matrix(dt, k)
                out[:, k] = lu.solve(rhs + dt * self.nu * const)
                continue
            lap, const = self.viscous_operator(k)
            a = spla.LinearOperator((self.n, self.n), matvec=lambda x, lap=lap: x - dt * self.nu * (lap @ x))
            b = rhs + dt * self.nu * const
            # tolerance on the scale of the whole flow: a component that is only round-off
            # (or already diffused) is done, where bicgstab would break down on it
            tol = 1e-12 * (np.linalg.norm(u) + np.linalg.norm(b) + 1e-300)
            if np.linalg.norm(a @ rhs - b) <= tol:
                out[:, k] = rhs
                continue
            out[:, k], info = spla.bicgstab(a, b, x0=rhs, rtol=0.0, atol=tol, maxiter=500)
            if info:
                raise FluidBlowUp(f"the viscous solve did not converge (info {info}) at step {self.steps}")
        return out

    def viscous_operator(self, k):
        """(The viscous Laplacian of velocity component k as an (n, n) sparse matrix over the
        particles, the constant the moving walls add to it), kept."""
        key = ("operator", k)
        if key not in self._viscous:
            lap = self._nb.laplacian_matrix(self.n0, self.lam, self._column,
                                            np.concatenate([np.ones(self.n), self._sign[:, k]]))
            self._viscous[key] = (lap, self._wall_constant(k))
        return self._viscous[key]

    def _wall_constant(self, k):
        """The part of component k's viscous Laplacian the moving walls' ghosts add (zero at rest)."""
        return self._nb.laplacian(np.concatenate([np.zeros(self.n), self._offset[:, k]]), self.n0, self.lam)

    def pressure_operator(self):
        """The pressure Poisson operator (div grad) as an (n, n) sparse matrix over the particles."""
        return self._nb.laplacian_matrix(self.n0, self.lam, self._column)

    # the pressure is pinned at this particle (the walls and periodic sides fix it only up to a
    # constant; a bordered system would fill the factor densely), then shifted to mean zero
    _pin = 0

    def left_null(self, lap, pin):
        """The vector the Poisson right-hand side must be orthogonal to; None: the constant (the
        planar operator is symmetric)."""
        return None

    def _lattice_key(self) -> tuple:
        """What this lattice's operators are made from (the walls' speeds aside)."""
        return (type(self).__name__, self.box.width, self.box.height, tuple(self.box.periodic), self.box.mirrors,
                self.nx, self.ny, self.re, self.pressure_solver)

    def _pressure_system(self):
        key = self._lattice_key()
        if self._pressure is None:
            self._pressure = FACTORS.get(key)
        if self._pressure is None:
            lap = self.pressure_operator().tocsr()
            pin = self._pin if self._pin >= 0 else self.n + self._pin
            solver = self.pressure_solver
            factor = (spla.splu(self._pinned(lap, pin)) if solver == "direct"
                      else AxialModes(lap, self.nx, self.ny, pin=pin % self.nx) if solver == "modes" else None)
            self._pressure = (lap, factor, self.left_null(lap, pin) if factor is not None else None, pin)
            FACTORS.put(key, self._pressure, nbytes(self._pressure))
        return self._pressure

    @staticmethod
    def _pinned(lap, pin):
        """``lap`` with its row ``pin`` made the identity's, for the sparse LU (csc)."""
        pinned = lap.tolil()
        pinned[pin, :] = 0.0
        pinned[pin, pin] = 1.0
        return pinned.tocsc()

    def project(self, u, dt):
        """(``u`` made divergence-free, the pressure that does it over a step ``dt``)."""
        if self.pressure_solver == "spectral":
            gx, gy, lap, _ = self._spectral_symbols()
            div = gx * self._field(u[:, 0]) + gy * self._field(u[:, 1])
            # the constant pressure (the zero mode) is left at zero: mean zero, as the direct solve's
            phi = np.divide(div, lap, out=np.zeros_like(div), where=lap != 0)
            phi[0, 0] = 0.0  # its symbol is zero but for round-off
            return (u - np.column_stack([self._values(gx * phi), self._values(gy * phi)]),
                    self.rho / dt * self._values(phi))
        lap, lu, null, pin = self._pressure_system()
        rhs = self.rho / dt * self.divergence(u)
        if lu is not None:
            # a uniform source takes what the sides cannot carry: the system is then solvable exactly
            b = rhs - (rhs.mean() if null is None else null @ rhs / null.sum())
            if self.pressure_solver == "direct":
                b[pin] = 0.0  # the pinned row's (by modes, the row mean's column is pinned inside)
            p = lu.solve(b)
            p -= p.mean()
        else:
            p, info = spla.bicgstab(lap, rhs - rhs.mean(), rtol=1e-10, atol=0.0, maxiter=2000)
            if info:
                raise FluidBlowUp(f"the pressure solve did not converge (info {info}) at step {self.steps}")
            p -= p.mean()
        return u - dt / self.rho * self.gradient(p), p

    def whole_section(self, values, odd=False):
        """The lattice is the whole section already."""
        return np.asarray(values)

    # --- measures -------------------------------------------------------------------
    def kinetic_energy(self) -> float:
        """1/2 rho sum |u|^2 V (per unit depth in the plane)."""
        return 0.5 * self.rho * float(((self.u**2).sum(1) * self.volume).sum())

    def momentum(self) -> np.ndarray:
        return self.rho * (self.u * self.volume[:, None]).sum(0)

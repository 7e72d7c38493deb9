"""Solves by Fourier modes along the axis (core.jellyfish.axial_modes) against scipy's sparse
solves of the whole lattice, on the water round the axis and on a planar box periodic along y."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from core.jellyfish.axial_modes import AxialModes
from core.jellyfish.axisymmetric_fluid import AxisymmetricFluid
from core.jellyfish.fluid_box import Box, Liquid, Stepping
from core.jellyfish.particle_fluid import LatticeFluid


def _round(nr=12, nz=20, **stepping):
    return AxisymmetricFluid(0.1, 0.1 * nz / nr, nr, nz, Liquid(viscosity=1e-5), Stepping(**stepping))


@pytest.mark.parametrize("k", [0, 1])
@pytest.mark.parametrize("stiffness", [1e-3, 1.0, 1e4])
def test_a_viscous_step_by_modes_is_scipys_sparse_solve(k, stiffness):
    """I - s L for u_r (odd at the axis, with its -u_r/r^2) and u_z, from a weak step to one ten
    thousand times stiffer than the lattice's diffusion limit."""
    f = _round()
    lap, _ = f.viscous_operator(k)
    a = (sp.identity(f.n) - stiffness * f.h**2 * lap).tocsr()
    b = np.random.default_rng(k).normal(size=f.n)
    ref = spla.spsolve(a.tocsc(), b)
    got = AxialModes(a, f.nx, f.ny).solve(b)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-10 * np.abs(ref).max())


def test_an_operator_leaning_one_way_along_the_axis_is_solved():
    """Rows coupled to the row above unlike the row below (as an upwind term would): the modes'
    sign convention matters here, where a stencil symmetric in y would hide it."""
    nx, ny = 7, 10
    rng = np.random.default_rng(1)
    couple = {d: rng.normal(scale=0.3, size=(nx, nx)) for d in (-2, 1, 3)}
    couple[0] = 4.0 * np.eye(nx) + rng.normal(scale=0.3, size=(nx, nx))
    a = sp.lil_matrix((nx * ny, nx * ny))
    for iy in range(ny):
        for d, block in couple.items():
            jy = (iy + d) % ny
            a[iy * nx:(iy + 1) * nx, jy * nx:(jy + 1) * nx] = block
    b = rng.normal(size=nx * ny)
    ref = spla.spsolve(a.tocsc(), b)
    np.testing.assert_allclose(AxialModes(a.tocsr(), nx, ny).solve(b), ref, rtol=0, atol=1e-10 * np.abs(ref).max())


def test_the_pressure_by_modes_is_the_sparse_lus_up_to_the_constant():
    """The pressure Laplacian round the axis is singular (constants) and unsymmetric: on a
    right-hand side made solvable with its left null vector, modes and scipy's LU of the pinned
    system give the same pressure once both are shifted to mean zero."""
    f = _round()
    lap = f.pressure_operator().tocsr()
    null = f.left_null(lap, f.n - 1)
    rhs = np.random.default_rng(5).normal(size=f.n)
    b = rhs - null @ rhs / null.sum()
    pinned = lap.tolil()
    pinned[f.n - 1, :] = 0.0
    pinned[f.n - 1, f.n - 1] = 1.0
    fixed = b.copy()
    fixed[-1] = 0.0
    ref = spla.spsolve(pinned.tocsc(), fixed)
    got = AxialModes(lap, f.nx, f.ny, pin=f.nx - 1).solve(b)
    ref, got = ref - ref.mean(), got - got.mean()
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9 * np.abs(ref).max())
    np.testing.assert_allclose(lap @ got, b, rtol=0, atol=1e-8 * np.abs(b).max())


def test_modes_are_the_default_round_the_axis_and_step_as_the_sparse_lu_does():
    """Whole steps (advection, viscosity, projection) by modes and by the sparse LU agree to
    round-off, round the axis and in a planar box periodic along y only."""
    def run(make, solver):
        f = make(solver)
        x, y = f.points.T
        rng = np.random.default_rng(2)
        f.u = np.column_stack([np.sin(np.pi * x / x.max()) * np.cos(2 * np.pi * y / y.max()),
                               np.cos(2 * np.pi * y / y.max())]) * 0.01 + 1e-4 * rng.normal(size=(f.n, 2))
        for _ in range(3):
            f.step(0.05)
        return f

    def planar(solver):
        return LatticeFluid(Box(0.8, 1.0, periodic=(False, True)), nx=16, ny=20, liquid=Liquid(1e-3, 1.0),
                            stepping=Stepping(pressure_solver=solver))

    for make in (lambda s: _round(pressure_solver=s), planar):
        by_modes, direct = run(make, "auto"), run(make, "direct")
        assert by_modes.pressure_solver == "modes"
        np.testing.assert_allclose(by_modes.u, direct.u, rtol=0, atol=1e-10 * np.abs(direct.u).max())
        np.testing.assert_allclose(by_modes.p, direct.p, rtol=0, atol=1e-8 * np.abs(direct.p).max())


def test_an_operator_not_the_same_at_every_row_is_refused():
    f = _round()
    lap = f.pressure_operator().tolil()
    lap[3 * f.nx + 2, 3 * f.nx + 2] += 1.0  # one particle unlike its row's neighbours above and below
    with pytest.raises(ValueError, match="not the same at every row"):
        AxialModes(lap.tocsr(), f.nx, f.ny)
    with pytest.raises(ValueError, match="12 x 10 particles"):
        AxialModes(lap.tocsr(), 12, 10)
    with pytest.raises(ValueError, match="periodic along y only"):
        LatticeFluid(Box(1.0, 1.0), nx=8, stepping=Stepping(pressure_solver="modes"))

"""The fluid round an axis against cylindrical-coordinate analytic flows: divergence-free fields,
Stokes modes that decay at the rate Bessel functions give, a projection that keeps the axial
momentum, and the bell of revolution's volume against the solid of revolution's."""

import numpy as np
import pytest
from scipy.special import j0, j1, jn_zeros

from core.jellyfish.axisymmetric_fluid import AxisymmetricFluid
from core.jellyfish.bell import BellMap, BellShape, SolidBell
from core.jellyfish.fluid_box import Liquid, Stepping
from core.jellyfish.mps import lattice
from core.jellyfish.swimming import default_config, default_creature, simulate_cycles
from core.jellyfish.waters import WATERS

RADIUS, HEIGHT = 0.1, 0.2


def _fluid(n=40, viscosity=1e-6):
    return AxisymmetricFluid(RADIUS, HEIGHT, n, 2 * n, Liquid(viscosity=viscosity))


def test_a_divergence_free_field_of_revolution_has_none_and_the_error_falls_with_the_spacing():
    """u_z = f(z), u_r = -r f'(z) / 2: du_r/dr + u_r/r + du_z/dz = -f'/2 - f'/2 + f' = 0, which the
    planar divergence alone misses by f'/2."""
    errors = []
    for n in (20, 40):
        f = _fluid(n)
        r, z = f.points.T
        k = 2 * np.pi / HEIGHT
        u = np.column_stack([-0.5 * r * k * np.cos(k * z), np.sin(k * z)])
        inner = r < 0.8 * RADIUS  # the outer mirror wants u_r odd about it, which this field is not
        errors.append(np.abs(f.divergence(u)[inner]).max() / k)
        planar = np.abs(super(AxisymmetricFluid, f).divergence(u)[inner]).max() / k
        assert planar > 0.45  # without the u_r / r term: wrong by f'/2
    assert errors[1] < 0.3 * errors[0] and errors[1] < 2e-3


@pytest.mark.parametrize("k_waves", [0, 1])
def test_a_stokes_mode_of_the_cylinder_decays_at_its_bessel_rate(k_waves):
    """u_r = J1(a r) cos(k z), u_z = -(a/k) J0(a r) sin(k z) (k = 0: u_z = J0(a r) alone) with
    J1(a R) = 0 is divergence-free, slips freely along the wall and is an eigenfunction of the
    vector Laplacian, -u_r / r^2 term included: it decays as exp(-nu (a^2 + k^2) t). Backward Euler
    per step: 1 / (1 + nu (a^2 + k^2) dt)."""
    nu, dt, steps = 1e-3, 0.05, 10
    f = _fluid(32, viscosity=nu)
    r, z = f.points.T
    a = jn_zeros(1, 1)[0] / RADIUS
    k = 2 * np.pi * k_waves / HEIGHT
    if k_waves:
        mode = np.column_stack([j1(a * r) * np.cos(k * z), -(a / k) * j0(a * r) * np.sin(k * z)])
    else:
        mode = np.column_stack([np.zeros_like(r), j0(a * r)])
    amplitude = 1e-6  # m/s: advection is then nothing against the viscous decay
    f.u = amplitude * mode
    for _ in range(steps):
        f.step(dt)
    expected = (1 + nu * (a * a + k * k) * dt) ** -steps
    measured = (f.u * mode).sum() / (amplitude * (mode * mode).sum())
    assert measured == pytest.approx(expected, rel=0.01)
    assert 1 - expected > 0.3  # the decay is large enough to tell
    residue = f.u - measured * amplitude * mode
    assert np.abs(residue).max() < 0.02 * amplitude


def test_the_projection_removes_the_divergence_and_keeps_the_axial_momentum():
    """(The projection is approximate, as in the plane: the compact Laplacian is not the divergence
    of the gradient; a second projection takes the rest down by as much again.)"""
    f = _fluid(32)
    r, z = f.points.T
    k = 2 * np.pi / HEIGHT
    u = np.column_stack([np.sin(np.pi * r / RADIUS) * np.cos(k * z),
                         np.cos(np.pi * r / RADIUS) + np.sin(2 * k * z) + 0.3 * np.cos(3 * k * z)])
    before = (u[:, 1] * f.volume).sum()
    projected, _ = f.project(u, 0.01)
    assert (projected[:, 1] * f.volume).sum() == pytest.approx(before, rel=1e-10)
    divergence = np.abs(f.divergence(u)).max()
    assert np.abs(f.divergence(projected)).max() < 0.01 * divergence
    twice, _ = f.project(projected, 0.01)
    assert np.abs(f.divergence(twice)).max() < 1e-3 * divergence
    # no net source: what flows out of the lattice's rings flows into others
    assert abs((f.divergence(projected) * f.volume).sum()) < 1e-9 * divergence * f.volume.sum()


def test_advection_keeps_the_axial_momentum_of_the_rings():
    """The semi-Lagrangian step is not conservative; the fluid takes its net momentum back as a
    uniform axial velocity. Each particle stands for a ring of volume 2 pi r h^2, so the momentum
    kept is sum u_z 2 pi r h^2 (against the rings' own volumes, computed here), not the plain sum."""
    f = _fluid(24)
    r, z = f.points.T
    np.testing.assert_allclose(f.volume, 2 * np.pi * r * f.h ** 2, rtol=1e-12)
    k = 2 * np.pi / HEIGHT
    u = np.column_stack([np.sin(np.pi * r / RADIUS) * np.cos(k * z), 0.2 + np.cos(np.pi * r / RADIUS) * np.sin(k * z)])
    before = u[:, 1] @ (2 * np.pi * r * f.h ** 2)
    out = f._advect(u, 0.01, u)
    assert out[:, 1] @ (2 * np.pi * r * f.h ** 2) == pytest.approx(before, rel=1e-12)
    assert np.abs(out - u).max() > 1e-3  # it did carry the field


def test_the_whole_section_is_the_half_and_its_mirror_image():
    f = _fluid(10)
    width = 2 * RADIUS
    planar = lattice(20, 20, f.h)
    np.testing.assert_allclose(f.whole_section(f.points[:, 0]), np.abs(planar[:, 0] - 0.5 * width), atol=1e-15)
    np.testing.assert_allclose(f.whole_section(f.points[:, 0], odd=True), planar[:, 0] - 0.5 * width, atol=1e-15)
    np.testing.assert_allclose(f.whole_section(f.points[:, 1]), planar[:, 1], atol=1e-15)


def test_the_rest_bell_holds_the_volume_between_its_two_half_ellipsoids():
    """(2/3) pi a^2 (H - h): the exumbrella's half-ellipsoid less the subumbrella's, its centroid
    at 3/8 (H^2 - h^2) / (H - h); the polygon's error falls as the nodes square."""
    errors = []
    for nodes in (40, 160):
        shape = BellShape(nodes=nodes)
        a = 0.5 * shape.diameter
        cfg = default_config(bell=shape)
        bell = SolidBell(shape, BellMap(shape, default_creature(cfg), 0.5 * cfg.box), WATERS["axisymmetric"])
        volume = 2 / 3 * np.pi * a * a * (shape.height - shape.inner_height)
        centroid = 3 / 8 * (shape.height**2 - shape.inner_height**2) / (shape.height - shape.inner_height)
        errors.append(abs(bell.volume0 / volume - 1))
        assert bell.centre[1] == pytest.approx(centroid, rel=5 * errors[-1] + 1e-9)
    assert errors[0] < 0.01 and errors[1] < errors[0] / 10


@pytest.mark.parametrize("water", ["planar", "axisymmetric"])
def test_the_solid_bell_keeps_its_volume_where_the_map_alone_loses_it(water):
    cfg = default_config()
    bell = SolidBell(cfg.bell, BellMap(cfg.bell, default_creature(cfg), 0.5 * cfg.box), WATERS[water])
    mapped = bell.volume(bell.rest + bell.map.displacement_at(bell.rest, 1.0))[0]
    assert mapped < (0.85 if water == "axisymmetric" else 0.95) * bell.volume0  # what the thin-plate map does alone
    for s in np.linspace(0, 1, 9):
        assert bell.volume(bell.at(bell.rest, s))[0] == pytest.approx(bell.volume0, rel=1e-12)


def test_the_axisymmetric_fluid_refuses_what_it_cannot_do():
    with pytest.raises(ValueError, match="directly"):
        AxisymmetricFluid(RADIUS, HEIGHT, 8, 16, stepping=Stepping(pressure_solver="spectral"))
    with pytest.raises(ValueError, match="even"):
        default_config(particles=51)
    with pytest.raises(ValueError, match="fluid"):
        default_config(fluid="spherical")


def test_in_stokes_flow_the_reciprocal_stroke_swims_nowhere():
    """The scallop theorem: with inertia gone (viscosity 1e-2 m^2/s, a Reynolds number near 0.05)
    a stroke that retraces itself cannot swim; at the default's it swims. The stiff viscous
    step (nu dt / h^2 in the hundreds) is solved implicitly and stays bounded."""
    cfg = default_config(particles=40)
    swims = simulate_cycles(default_creature(cfg), cfg, 2).path_m
    stokes = simulate_cycles(default_creature(cfg), default_config(particles=40, viscosity=1e-2), 2)
    assert swims > 0.02 * cfg.bell.diameter
    assert np.isfinite(stokes.path_m) and abs(stokes.path_m) < 0.05 * swims

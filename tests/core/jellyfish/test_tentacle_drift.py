import numpy as np
import pytest
from scipy.integrate import solve_ivp

from core.jellyfish import CycleResult, default_config, default_creature, simulate_cycle
from core.jellyfish.mps import lattice
from core.jellyfish.tentacle_drift import DriftSettings, periodic_drift, water_drift


def _cycle(config, velocity, speed, swum=None):
    """A cycle whose sampled water is ``velocity(points, t)`` on the lattice."""
    t = config.period * np.arange(1, config.substeps + 1) / config.substeps
    pts = lattice(config.particles, config.particles, config.box / config.particles)
    speed = np.broadcast_to(np.asarray(speed, float), t.shape).copy()
    swum = np.zeros_like(t) if swum is None else swum
    fields = [(tk, velocity(pts, tk), None, None) for tk in t]
    return CycleResult(0.0, 0.0, 0.0, 0.0, speed=speed, swum=swum, fields=fields)


def test_periodic_drift_matches_integrating_many_cycles():
    rng = np.random.default_rng(3)
    f = rng.standard_normal((9, 2))
    dt, tau = 0.1, 0.35
    got = periodic_drift(f, dt, tau)
    d = np.zeros(2)
    for _ in range(12):  # the start is forgotten as exp(-12 * 0.9 / 0.35) ~ 1e-13
        ends = []
        for k in range(len(f)):
            sol = solve_ivp(lambda t, y, k=k: f[k] - y / tau, (0, dt), d, rtol=1e-11, atol=1e-13)
            d = sol.y[:, -1]
            ends.append(d)
    np.testing.assert_allclose(got, np.array(ends), atol=1e-9)


def test_uniform_water_gives_the_tethered_offset_and_no_sideways_drift():
    cfg = default_config(particles=32, substeps=10)
    water = np.array([0.004, -0.01])  # a sideways stream and a downward one
    cycle = _cycle(cfg, lambda p, t: np.broadcast_to(water, p.shape).copy(), speed=0.02)
    rz = np.column_stack([np.full(6, 0.05), np.linspace(-0.12, -0.03, 6)])
    tether = 0.3
    w = water_drift(cycle, cfg, rz, DriftSettings(tether_time=tether))
    ramp = -np.expm1(rz[:, 1] / (0.1 * cfg.bell.diameter))  # depth below the margin is -z
    expect = np.column_stack([np.zeros(6), tether * cfg.period * (water[1] - 0.02) * ramp])
    for k in range(cfg.substeps):
        np.testing.assert_allclose(w.drift[k], expect, atol=1e-12)
    assert w.shapes.shape[0] == 1 and w.captured == pytest.approx(1.0)


def test_water_is_read_where_the_point_is_in_the_bell_frame():
    """A periodic flow u_y(x, y) and a bell that swims: each point reads the water at its own
    place, moved with the bell."""
    cfg = default_config(particles=64, substeps=6)
    k = 2 * np.pi / cfg.box
    swum = np.linspace(0.002, 0.03, cfg.substeps)

    def flow(p):
        return 0.01 * np.cos(k * p[:, 0]) * np.cos(k * p[:, 1]) + 0.004

    cycle = _cycle(cfg, lambda p, t: np.column_stack([np.zeros(len(p)), flow(p)]), speed=0.0, swum=swum)
    rz = np.column_stack([np.linspace(0.01, 0.07, 5), np.full(5, -0.05)])
    tether = 1e3  # so long that each step's drift is the velocity times the step
    w = water_drift(cycle, cfg, rz, DriftSettings(tether_time=tether, reach=10.0))
    dt = cfg.period / cfg.substeps
    ramp = -np.expm1(-0.05 / (0.1 * cfg.bell.diameter))
    origin = np.array([0.5 * cfg.box, 0.5 * cfg.box - 0.5 * cfg.bell.height])
    for j in range(1, cfg.substeps):
        y = origin[1] + swum[j] + rz[:, 1]
        both = [flow(np.column_stack([origin[0] + side * rz[:, 0], y])) for side in (1, -1)]
        expect = 0.5 * (both[0] + both[1]) * ramp
        step = (w.drift[j, :, 1] - w.drift[j - 1, :, 1] * np.exp(-dt / tether)) / (tether * -np.expm1(-dt / tether))
        np.testing.assert_allclose(step, expect, atol=2e-3 * 0.01)


def test_shapes_replay_the_drift_of_a_simulated_cycle():
    cfg = default_config(particles=40)
    cycle = simulate_cycle(default_creature(cfg), cfg, sample_fields=True)
    rz = np.column_stack([np.full(12, 0.048), np.linspace(0.0, -0.15, 12)])
    w = water_drift(cycle, cfg, rz, DriftSettings(modes=3, keep=0.999))
    replay = np.array([w.at(t) for t in w.times])
    err = np.linalg.norm(replay - w.drift) / np.linalg.norm(w.drift)
    # the shapes are the drift's best rank-k fit (Eckart-Young): what they miss is exactly the
    # share of its sum of squares they leave out, neither more nor less
    assert err == pytest.approx(np.sqrt(1 - w.captured), rel=1e-6, abs=1e-12)
    assert w.captured >= 0.99
    one = water_drift(cycle, cfg, rz, DriftSettings(modes=1, keep=0.999))
    assert np.linalg.norm(np.array([one.at(t) for t in one.times]) - w.drift) == pytest.approx(
        np.sqrt(1 - one.captured) * np.linalg.norm(w.drift), rel=1e-6)
    assert one.captured < w.captured
    assert np.all(w.drift[:, 0] == 0.0)  # the root sits on the margin: the bell holds it
    # the bell swims up as it contracts, so its tentacles trail below rest then
    fastest = int(np.argmax(cycle.speed))
    assert w.drift[fastest, -1, 1] < 0 < cycle.speed[fastest]


@pytest.mark.parametrize("bad", [dict(tether_time=0.0), dict(tether_time=np.inf), dict(modes=0)])
def test_bad_parameters_are_refused(bad):
    cfg = default_config(particles=16, substeps=4)
    cycle = _cycle(cfg, lambda p, t: np.zeros_like(p), speed=0.0)
    with pytest.raises(ValueError):
        water_drift(cycle, cfg, [[0.05, -0.02]], DriftSettings(**bad))


def test_a_cycle_without_sampled_water_is_refused():
    cfg = default_config(particles=16, substeps=4)
    cycle = _cycle(cfg, lambda p, t: np.zeros_like(p), speed=0.0)
    cycle.fields = []
    with pytest.raises(ValueError, match="sample_fields"):
        water_drift(cycle, cfg, [[0.05, -0.02]])
    with pytest.raises(ValueError, match="finite"):
        water_drift(_cycle(cfg, lambda p, t: np.zeros_like(p), 0.0), cfg, [[np.nan, -0.02]])


def test_water_is_read_in_a_taller_box_as_in_a_square_one():
    """A uniform stream in a box twice as tall reads as in the square box (the lattice's rows
    are not its columns)."""
    water = np.array([0.0, -0.01])
    rz = np.column_stack([np.full(4, 0.05), np.linspace(-0.1, -0.02, 4)])
    got = []
    for height in (None, 0.4):
        cfg = default_config(particles=20, substeps=4, box_height=height)
        t = cfg.period * np.arange(1, cfg.substeps + 1) / cfg.substeps
        pts = lattice(cfg.particles, cfg.rows, cfg.box / cfg.particles)
        fields = [(tk, np.broadcast_to(water, pts.shape).copy(), None, None) for tk in t]
        cycle = CycleResult(0.0, 0.0, 0.0, 0.0, speed=np.zeros(4), swum=np.zeros(4), fields=fields)
        got.append(water_drift(cycle, cfg, rz).drift)
    np.testing.assert_allclose(got[1], got[0], atol=1e-15)
    assert np.abs(got[0][..., 1]).max() > 1e-4

"""One swimming cycle against physics that does not depend on the code: mirror symmetry, the
scallop theorem at low Reynolds number, dynamic similarity across scales; refusals."""

import numpy as np
import pytest

from core.jellyfish import default_config, default_creature, simulate_cycle
from core.jellyfish.bell import BellShape, Creature

N = 40  # particles per side: coarse, but every check below holds at any resolution


def test_a_bell_that_does_not_deform_does_not_swim():
    cfg = default_config(particles=N)
    cr = default_creature(cfg)
    r = simulate_cycle(Creature(cr.controls, cr.controls, cr.contraction), cfg)
    assert r.path_m == 0.0 and r.energy_loss == 0.0 and abs(r.bending_energy) < 1e-15


def test_the_default_stroke_swims_forward_and_the_flow_stays_mirror_symmetric():
    cfg = default_config(particles=N)
    r = simulate_cycle(default_creature(cfg), cfg, sample_fields=True)
    assert r.path_m > 0 and np.isfinite(r.fitness)
    assert r.speed[:3].min() > 0  # the contraction drives it forward
    for _, u, vort, mask in r.fields:
        grid = u.reshape(N, N, 2)
        scale = np.abs(grid).max()
        assert np.abs(grid[:, :, 0] + grid[:, ::-1, 0]).max() < 1e-5 * scale
        assert np.abs(grid[:, :, 1] - grid[:, ::-1, 1]).max() < 1e-5 * scale
        w = vort.reshape(N, N)
        assert np.abs(w + w[:, ::-1]).max() < 1e-4 * np.abs(w).max()
        assert mask.reshape(N, N).sum() > 0


def test_scallop_theorem_a_reciprocal_stroke_does_not_swim_in_syrup():
    # at low Reynolds number a stroke that retraces itself gets nowhere (Purcell 1977)
    # (56 substeps: at 14 on this coarse lattice the time steps alone break reversibility by 10%)
    water = simulate_cycle(default_creature(default_config()), default_config(particles=N, substeps=56)).path_m
    syrup_cfg = default_config(particles=N, viscosity=0.1, substeps=56)
    syrup = simulate_cycle(default_creature(syrup_cfg), syrup_cfg).path_m
    assert abs(syrup) < 0.02 * water


@pytest.mark.parametrize("scale", [0.01, 10.0])
def test_bells_of_a_millimetre_and_a_metre_swim_alike_at_the_same_reynolds_number(scale):
    unit = default_config(particles=N)
    ref = simulate_cycle(default_creature(unit), unit)
    b = BellShape(0.10 * scale, 0.035 * scale, 0.022 * scale)
    cfg = default_config(particles=N, bell=b, box=0.2 * scale, viscosity=unit.viscosity * scale**2)
    r = simulate_cycle(default_creature(cfg), cfg)
    assert r.path_m / b.diameter == pytest.approx(ref.path_m / 0.10, rel=1e-8)
    assert r.bending_energy == pytest.approx(ref.bending_energy, rel=1e-8)


def test_a_bell_folded_through_itself_is_refused_with_a_reason():
    cfg = default_config(particles=N)
    cr = default_creature(cfg)
    bad = Creature(cr.controls, cr.controls + [[-0.005, 0.05], [0.0, 0.0]], 0.3)
    r = simulate_cycle(bad, cfg)
    assert r.fitness == -np.inf and ("folds" in r.reason or "inside out" in r.reason)


def test_an_almost_instant_contraction_is_split_into_small_steps():
    cfg = default_config(particles=N)
    cr = default_creature(cfg)
    r = simulate_cycle(Creature(cr.controls, cr.destinations, 0.01), cfg)
    assert np.isfinite(r.path_m)
    # the margin moves 1.25 cm in 10 ms: the fluid needs more than one step per particle crossed
    assert r.timings["inner_steps"] > 0.0125 / (cfg.box / N) * (cfg.substeps > 0)


@pytest.mark.parametrize("bad, match", [(dict(substeps=0), "substeps"), (dict(period=0.0), "period"),
                                        (dict(box=0.05), "wider"), (dict(margin_thickness=0.0), "margin"),
                                        (dict(margin_thickness=float("nan")), "margin")])
def test_bad_configurations_are_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        default_config(**bad)

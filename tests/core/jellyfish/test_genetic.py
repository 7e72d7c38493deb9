"""The search methods against answers that do not depend on them: the Boltzmann acceptance
probability exp(dF / T) measured by counting, the known optimum of analytic functions, and
random search on the same budget as the bar to clear."""

import math

import numpy as np
import pytest

from core.jellyfish import genetic

CENTRE = np.array([0.3, 0.7, 0.2, 0.9, 0.5])


def sphere(points):
    return [-float(np.sum((p - CENTRE) ** 2)) for p in points]


def bumpy(points):
    # many local optima around one global one at CENTRE
    return [-float(np.sum((p - CENTRE) ** 2)) + 0.02 * float(np.cos(30 * (p - CENTRE)).sum()) for p in points]


@pytest.mark.parametrize("generation", [1, 10, 1000])
def test_a_worse_child_is_accepted_with_the_boltzmann_probability_of_the_seeds_temperature(generation):
    offset, loss = 2.0, 0.3
    t = 1.0 / (offset + math.log(1 + generation))  # eq. 3.15
    assert genetic.temperature(generation, offset) == pytest.approx(t, rel=1e-12)
    n = 40000
    rng = np.random.default_rng(generation)
    won = genetic.accept(np.full(n, 1.0 - loss), np.full(n, 1.0), t, rng).mean()
    expected = math.exp(-loss / t)
    assert abs(won - expected) < 4 * math.sqrt(expected * (1 - expected) / n)


def test_acceptance_of_worse_children_falls_as_the_temperature_falls_and_better_ones_always_win():
    rng = np.random.default_rng(0)
    rates = [genetic.accept(np.zeros(20000), np.full(20000, 0.5), genetic.temperature(g, 1.0), rng).mean()
             for g in (1, 10, 100, 10000)]
    assert all(a > b for a, b in zip(rates[:-1], rates[1:], strict=True))
    assert genetic.accept(np.full(100, 2.0), np.ones(100), 1e-9, rng).all()
    # an infeasible child (a folded bell) never replaces anything
    assert not genetic.accept(np.full(100, -np.inf), np.ones(100), 1e9, rng).any()
    assert not genetic.accept(np.full(100, -np.inf), np.full(100, -np.inf), 1e9, rng).any()
    assert genetic.accept(np.zeros(100), np.full(100, -np.inf), 1e-9, rng).all()


@pytest.mark.parametrize("objective", [sphere, bumpy])
def test_ga_sa_and_differential_evolution_beat_random_search_on_the_same_budget(objective):
    seeds = range(6)
    ga = [genetic.ga_sa(objective, np.full(5, 0.5), np.random.default_rng(s), genetic.GaSa(10, 30)) for s in seeds]
    budget = ga[0].evaluations
    de = [genetic.differential_evolution(objective, 5, np.random.default_rng(s), budget) for s in seeds]
    rs = [genetic.random_search(objective, 5, np.random.default_rng(s), budget) for s in seeds]
    assert all(r.evaluations <= budget for r in de + rs)
    med = {k: np.median([r.best_fitness for r in v]) for k, v in (("ga", ga), ("de", de), ("rs", rs))}
    # "clearly": at least twice as close to the optimum (all fitnesses are <= the optimum)
    top = objective([CENTRE])[0]
    assert top - med["ga"] < 0.5 * (top - med["rs"])
    assert top - med["de"] < 0.5 * (top - med["rs"])
    best = ga[int(np.argmax([r.best_fitness for r in ga]))]
    assert best.best_fitness == pytest.approx(objective([best.best_x])[0])


def test_the_same_seed_gives_the_same_search_and_another_seed_another():
    a = genetic.ga_sa(bumpy, np.full(5, 0.5), np.random.default_rng(7), genetic.GaSa(6, 5))
    b = genetic.ga_sa(bumpy, np.full(5, 0.5), np.random.default_rng(7), genetic.GaSa(6, 5))
    c = genetic.ga_sa(bumpy, np.full(5, 0.5), np.random.default_rng(8), genetic.GaSa(6, 5))
    assert np.array_equal(a.best_x, b.best_x) and a.history == b.history
    assert not np.array_equal(a.best_x, c.best_x)


def test_a_population_that_agrees_within_ten_percent_stops():
    flat = genetic.ga_sa(lambda pts: [1.0 + 0.01 * p[0] for p in pts], np.full(3, 0.5), np.random.default_rng(0),
                         genetic.GaSa(6, 30))
    assert flat.stopped == "agreement" and flat.evaluations == 6
    steep = genetic.ga_sa(sphere, np.full(5, 0.5), np.random.default_rng(0), genetic.GaSa(6, 3))
    assert steep.stopped == "generations" and steep.evaluations == 6 * 4


def test_a_stop_keeps_the_best_of_what_was_evaluated():
    seen = []

    def objective(points):
        seen.extend(points)
        return sphere(points)

    ga = genetic.GaSa(10, 30)
    for run in (lambda s: genetic.ga_sa(objective, np.full(5, 0.5), np.random.default_rng(0), ga, stop=s),
                lambda s: genetic.differential_evolution(objective, 5, np.random.default_rng(0), 300, stop=s),
                lambda s: genetic.random_search(objective, 5, np.random.default_rng(0), 300, stop=s)):
        seen.clear()
        r = run(lambda: len(seen) >= 30)
        assert r.stopped == "cancelled" and r.evaluations == len(seen) == 30
        assert r.best_fitness == max(sphere(seen))


def test_bad_input_is_refused_clearly():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="even"):
        genetic.ga_sa(sphere, np.full(5, 0.5), rng, genetic.GaSa(population=5))
    with pytest.raises(ValueError, match="generations"):
        genetic.ga_sa(sphere, np.full(5, 0.5), rng, genetic.GaSa(generations=0))
    with pytest.raises(ValueError, match="finite fitness"):
        genetic.random_search(lambda pts: [np.nan] * len(pts), 2, rng, 4)
    with pytest.raises(ValueError, match="finite fitness"):
        genetic.random_search(lambda pts: [1.0], 2, rng, 4)

"""Maximisers over the unit cube for expensive, batched objectives (thesis 3.5).

``ga_sa`` is the thesis' genetic algorithm with simulated-annealing selection (Mahfoud and
Goldberg's parallel recombinative simulated annealing): real-valued chromosomes, blend
crossover, replace-by-random mutation, and each child competes with its parent in a
Boltzmann trial at temperature T = 1 / (G_offset + log(1 + G)). ``random_search`` is the
baseline every method must beat; ``differential_evolution`` wraps scipy's on the same budget.

Objectives take a list of points and return their fitness (higher is better, -inf for an
infeasible point), so a caller can evaluate a generation in parallel. ``stop()`` is polled
between batches; whatever has been evaluated so far is kept.
"""

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import differential_evolution as _scipy_de


@dataclass
class SearchResult:
    best_x: np.ndarray
    best_fitness: float
    evaluations: int
    history: list = field(default_factory=list)  # per generation: (evaluations, best so far, population mean)
    stopped: str = "generations"  # "agreement", "generations", "budget" or "cancelled"


class Stop(Exception):  # noqa: N818 - a request, not an error
    """Raised by stop() polling or by an objective: end the search, keep what was evaluated."""


class _Tracker:
    """Counts evaluations, remembers the best point ever seen and honours stop()."""

    def __init__(self, objective, stop):
        self.objective, self.stop = objective, stop or (lambda: False)
        self.evaluations, self.best_x, self.best_f = 0, None, -np.inf

    def __call__(self, points):
        points = np.array(points, float, ndmin=2)  # a copy: the caller goes on changing its population
        if self.stop():
            raise Stop
        f = np.asarray(self.objective(list(points)), float)
        if f.shape != (len(points),) or np.isnan(f).any() or np.isposinf(f).any():
            raise ValueError("the objective must return one finite fitness (or -inf) per point")
        self.evaluations += len(points)
        k = int(np.argmax(f))
        if self.best_x is None or f[k] > self.best_f:
            self.best_x, self.best_f = points[k].copy(), float(f[k])
        return f

    def result(self, history, stopped):
        # a search stopped before its first batch finished has no best point (best_x None)
        return SearchResult(self.best_x, self.best_f, self.evaluations, history, stopped)


def temperature(generation, offset, scale=1.0):
    """Eq. 3.15, T = 1 / (G_offset + log(1 + G)), in units of ``scale``."""
    return scale / (offset + np.log1p(generation))


def accept(child, parent, t, rng):
    """Boltzmann trial for a maximiser: a better child always wins; a worse one wins with
    probability exp((child - parent) / T). An infeasible child never beats a feasible parent."""
    child, parent = np.asarray(child, float), np.asarray(parent, float)
    with np.errstate(invalid="ignore", over="ignore"):
        p = np.where(child >= parent, 1.0, np.exp(np.minimum(child - parent, 0.0) / t))
    p = np.where(np.isneginf(child) & np.isneginf(parent), 0.0, np.nan_to_num(p, nan=0.0))
    return rng.random(np.shape(p)) < p


def agreed(fitness, tolerance):
    """The population agrees within ``tolerance`` of its best (the thesis' 10 % stop)."""
    f = np.asarray(fitness, float)
    if not np.isfinite(f).all():
        return False
    spread = f.max() - f.min()
    return spread <= tolerance * max(abs(f.max()), abs(f.min()), 1e-12)


@dataclass(frozen=True)
class GaSa:
    """The genetic algorithm with simulated-annealing selection: ``population`` creatures (even),
    at most ``generations``; the temperature's ``g_offset``, the ``crossover`` and ``mutation``
    rates, the first population's ``spread`` about the start, and the ``tolerance`` within which
    an agreeing population stops the search."""

    population: int = 10
    generations: int = 30
    g_offset: float = 5.0
    crossover: float = 0.9
    mutation: float = 0.2
    spread: float = 0.5
    tolerance: float = 0.1


def ga_sa(objective, x0, rng, settings: GaSa = GaSa(), stop=None):
    """Maximise ``objective`` over [0, 1]^d from the start point ``x0``: the first population
    is x0 and random distortions of it (normal, ``settings.spread`` wide, clipped to the cube)."""
    population, generations, g_offset = settings.population, settings.generations, settings.g_offset
    crossover, mutation, spread, tolerance = settings.crossover, settings.mutation, settings.spread, settings.tolerance
    x0 = np.clip(np.asarray(x0, float), 0.0, 1.0)
    if population < 2 or population % 2:
        raise ValueError(f"the population must be an even number >= 2, got {population}")
    if generations < 1:
        raise ValueError(f"generations must be >= 1, got {generations}")
    track = _Tracker(objective, stop)
    d = len(x0)
    pop = np.clip(x0 + spread * rng.standard_normal((population, d)), 0.0, 1.0)
    pop[0] = x0
    history = []
    try:
        fit = track(pop)
        # the thesis' temperature is in fitness units; measured in the first population's
        # fitness spread it means the same whatever the weights and scales of eq. 3.14
        finite = fit[np.isfinite(fit)]
        scale = float(finite.std()) if len(finite) > 1 and finite.std() > 0 else 1.0
        history.append((track.evaluations, track.best_f, _mean(fit)))
        for g in range(1, generations + 1):
            if agreed(fit, tolerance):
                return track.result(history, "agreement")
            t = temperature(g, g_offset, scale)
            # parents by Boltzmann selection at the same temperature: fitter creatures breed
            # more, more so as T falls (pairing at random gave no pressure towards the best)
            a, b = _boltzmann_pairs(fit, t, population // 2, rng)
            mix = rng.random((len(a), d))
            blend = rng.random((len(a), 1)) < crossover
            lo, hi = np.minimum(pop[a], pop[b]), np.maximum(pop[a], pop[b])
            # crossover: a value drawn between the parents' (the thesis' real-valued variant)
            child_a = np.where(blend, lo + mix * (hi - lo), pop[a])
            child_b = np.where(blend, lo + (1 - mix) * (hi - lo), pop[b])
            children = np.vstack([child_a, child_b])
            # mutation: a gene replaced by a fresh random value
            mutate = rng.random(children.shape) < mutation
            children[mutate] = rng.random(int(mutate.sum()))
            # each child then meets one member (a random order) in a Boltzmann trial
            slots = rng.permutation(population)
            f_child = track(children)
            win = accept(f_child, fit[slots], t, rng)
            pop[slots[win]] = children[win]
            fit[slots[win]] = f_child[win]
            history.append((track.evaluations, track.best_f, _mean(fit)))
    except Stop:
        return track.result(history, "cancelled")
    return track.result(history, "generations")


def _boltzmann_pairs(fit, t, pairs, rng):
    """Parent pairs drawn with probability proportional to exp(f / T); infeasible never."""
    f = np.asarray(fit, float)
    finite = np.isfinite(f)
    if not finite.any():
        p = np.full(len(f), 1.0 / len(f))
    else:
        w = np.where(finite, np.exp(np.minimum((f - f[finite].max()) / t, 0.0)), 0.0)
        p = w / w.sum()
    a = rng.choice(len(f), pairs, p=p)
    b = rng.choice(len(f), pairs, p=p)
    return a, b


def random_search(objective, dim, rng, budget, batch=10, stop=None):
    """Uniform samples of the cube, ``batch`` at a time (the baseline)."""
    track = _Tracker(objective, stop)
    history = []
    try:
        while track.evaluations < budget:
            n = min(batch, budget - track.evaluations)
            f = track(rng.random((n, dim)))
            history.append((track.evaluations, track.best_f, _mean(f)))
    except Stop:
        return track.result(history, "cancelled")
    return track.result(history, "budget")


# what an infeasible creature scores in scipy's minimisation (it needs a finite number)
_INFEASIBLE = 1e3


def differential_evolution(objective, dim, rng, budget, population=10, stop=None):
    """scipy's differential evolution (best1bin, deferred updating so a generation is one
    batch) with maxiter set so it spends about ``budget`` evaluations, no polishing."""
    track = _Tracker(objective, stop)
    history = []
    popsize = max(1, int(np.ceil(population / dim)))
    members = popsize * dim
    maxiter = max(0, budget // members - 1)

    def minimise(points):
        # scipy hands (dim, S) arrays to a vectorised objective
        f = track(np.asarray(points).T)
        history.append((track.evaluations, track.best_f, _mean(f)))
        return np.where(np.isfinite(f), -f, _INFEASIBLE)

    try:
        _scipy_de(minimise, [(0.0, 1.0)] * dim, popsize=popsize, maxiter=maxiter, rng=rng, polish=False,
                  init="latinhypercube", updating="deferred", vectorized=True, tol=0.0)
    except Stop:
        return track.result(history, "cancelled")
    return track.result(history, "budget")


def _mean(f):
    f = np.asarray(f, float)
    finite = f[np.isfinite(f)]
    return float(finite.mean()) if len(finite) else -np.inf

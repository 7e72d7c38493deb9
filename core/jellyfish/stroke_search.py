"""The search for a stroke (thesis 3.5): creatures as genes in a stroke space, each swum from rest
and scored by its fitness against the default creature's, bred by the genetic algorithm with
simulated annealing (or differential evolution, or at random), in worker processes."""

import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields

import numpy as np

from .bell import Creature
from .fitness import FitnessScales
from .swimming import CycleResult, JellyfishConfig, default_config, default_creature, simulate_cycles

# what a stroke search looks for, as eq. 3.14's weights (w_d, w_b, w_e): the farthest swim for its
# bending and wake energy (the dissertation's), or the farthest swim whatever it costs
GOAL_WEIGHTS = {"EFFICIENT": JellyfishConfig.weights, "FASTEST": (1.0, 0.0, 0.0)}


def reference_scales(config, creature=None, cycles: int | None = None) -> FitnessScales:
    """Scales from ``cycles`` (default ``config.cycles``) cycles of ``creature`` (default: the
    default creature)."""
    r = simulate_cycles(creature or default_creature(config), config, cycles or config.cycles)
    if r.reason is not None:
        raise ValueError(f"the reference creature is refused: {r.reason}")
    tiny = 1e-3 * config.bell.diameter
    return FitnessScales(max(abs(r.path_m), tiny), max(r.bending_energy, 1e-300), max(r.energy_loss, 1e-300))


@dataclass(frozen=True)
class StrokeSpace:
    """Where a search looks: each control point's destination as an offset from its rest
    place, in bell radii, between ``low`` and ``high``; the contraction share in between its
    bounds (the thesis keeps the search to strokes that are not "definitely too much")."""

    low: tuple = ((-0.5, -0.4), (-0.2, -0.1))
    high: tuple = ((0.1, 0.15), (0.05, 0.05))
    contraction: tuple = (0.15, 0.6)

    def _box(self, config):
        a = 0.5 * config.bell.diameter
        lo = np.append(a * np.ravel(self.low), self.contraction[0])
        hi = np.append(a * np.ravel(self.high), self.contraction[1])
        if not (lo < hi).all() or not 0 < self.contraction[0] < self.contraction[1] < 1:
            raise ValueError("every bound of the stroke space must be below its upper bound, contraction in (0, 1)")
        return lo, hi

    @property
    def dim(self) -> int:
        return int(np.size(self.low)) + 1

    def creature(self, genes, config) -> Creature:
        """Genes in [0, 1]^dim -> a creature on the default creature's control points."""
        lo, hi = self._box(config)
        v = lo + np.clip(np.asarray(genes, float), 0.0, 1.0) * (hi - lo)
        controls = default_creature(config).controls
        if controls.size != self.dim - 1:
            raise ValueError(f"the stroke space has {self.dim - 1} offsets, the creature {controls.size}")
        return Creature(controls, controls + v[:-1].reshape(controls.shape), float(v[-1]))

    def genes(self, creature, config) -> np.ndarray:
        lo, hi = self._box(config)
        v = np.append(np.ravel(creature.destinations - creature.controls), creature.contraction)
        return np.clip((v - lo) / (hi - lo), 0.0, 1.0)


@dataclass
class OptimizeResult:
    creature: Creature
    fitness: float
    cycle: CycleResult  # the best creature's swimming cycle
    history: list  # per batch: dicts of evaluations, seconds, best and mean fitness
    evaluations: int
    seconds: float
    stopped: str  # "agreement", "generations", "budget" or "cancelled"
    method: str
    backend: str
    scales: FitnessScales


def _evaluate(job):
    """One creature's ``config.cycles`` cycles in a worker: (genes, config, space, scales) -> CycleResult."""
    genes, config, space, scales = job
    return simulate_cycles(space.creature(genes, config), config, config.cycles, scales=scales)


@dataclass(frozen=True)
class Search:
    """How ``optimize`` searches. ``method``: "ga-sa" (the thesis'; ``population`` creatures, at
    most ``generations``, stops when the population agrees within 10 %; ``options``: further
    genetic.GaSa settings), "de" (scipy differential evolution) or "random"; the last two spend
    ``budget`` evaluations (default what ga-sa may spend at most). Same seed, same result.
    ``space``: the genes searched (default StrokeSpace()); ``start``: the stroke ga-sa starts from
    (default the default creature's)."""

    method: str = "ga-sa"
    seed: int = 0
    population: int = 10
    generations: int = 30
    budget: int | None = None
    options: dict = field(default_factory=dict)
    space: StrokeSpace | None = None
    start: Creature | None = None


@dataclass(frozen=True)
class Running:
    """Where ``optimize`` runs: ``workers`` processes (default every core; 1 runs here), or a Dask
    ``scheduler`` address instead; ``progress(evaluations, expected, best_fitness)`` is called as
    each cycle finishes; ``stop()`` is polled, and a stop keeps the best creature so far."""

    workers: int | None = None
    scheduler: str | None = None
    progress: Callable | None = None
    stop: Callable | None = None


def _records(method, seed, search, running, settings):
    """(Search, Running) from optimize's arguments: the records as given, or made from the names."""
    names = {name: {f.name for f in fields(kind)} for name, kind in (("search", Search), ("running", Running))}
    for_search = {k: v for k, v in settings.items() if k in names["search"]}
    for_running = {k: v for k, v in settings.items() if k in names["running"]}
    options = {k: v for k, v in settings.items() if k not in for_search and k not in for_running}
    if search is not None and (for_search or options or (method, seed) != ("ga-sa", 0)):
        raise ValueError("give the search's settings in the Search, not beside it")
    if running is not None and for_running:
        raise ValueError("give the run's settings in the Running, not beside it")
    given = for_search.pop("options", {})
    search = search or Search(method, seed, **for_search, options={**given, **options})
    return search, running or Running(**for_running)


def optimize(config: JellyfishConfig | None = None, method="ga-sa", seed=0, search: Search | None = None,
             running: Running | None = None, **settings) -> OptimizeResult:
    """The creature with the best fitness (eq. 3.14, scaled by the default creature's), each
    creature swimming ``config.cycles`` cycles from rest, found as ``search`` says, run as
    ``running`` says. Without them, ``method``, ``seed`` and ``settings`` (any field of Search or
    Running by name, e.g. population=4, workers=1, and genetic.GaSa's for ga-sa) make them."""
    search, running = _records(method, seed, search, running, settings)
    from . import genetic
    from .evaluation import Cancelled, Evaluator

    method, seed, population, generations, budget = (search.method, search.seed, search.population,
                                                     search.generations, search.budget)
    workers, scheduler, progress, stop = running.workers, running.scheduler, running.progress, running.stop
    config = config or default_config()
    space = search.space or StrokeSpace()
    if method not in ("ga-sa", "de", "random"):
        raise ValueError(f"unknown method {method!r}: choose 'ga-sa', 'de' or 'random'")
    if budget is not None and not (int(budget) == budget and budget >= 1):
        raise ValueError(f"budget must be a whole number of evaluations >= 1 (None: what ga-sa may spend), "
                         f"got {budget}")
    t0 = time.perf_counter()
    budget = int(budget if budget is not None else population * (generations + 1))
    expected = population * (generations + 1) if method == "ga-sa" else budget
    scales = reference_scales(config)
    rng = np.random.default_rng(seed)
    best = {"f": -np.inf, "genes": None, "cycle": None, "count": 0}
    batches = []

    with Evaluator(workers, scheduler) as evaluator:

        def objective(points):
            jobs = [(np.array(p, float), config, space, scales) for p in points]  # copies: the search reuses its arrays

            def done(k, cycle):
                best["count"] += 1
                if cycle.fitness > best["f"] or best["genes"] is None:
                    best.update(f=cycle.fitness, genes=jobs[k][0], cycle=cycle)
                if progress:
                    progress(best["count"], expected, best["f"])

            try:
                cycles = evaluator.map(_evaluate, jobs, on_done=done, stop=stop)
            except Cancelled:
                raise genetic.Stop from None
            batches.append(time.perf_counter() - t0)
            return [c.fitness for c in cycles]

        if method == "ga-sa":
            x0 = space.genes(search.start or default_creature(config), config)
            found = genetic.ga_sa(objective, x0, rng, genetic.GaSa(population, generations, **search.options), stop)
        elif method == "de":
            found = genetic.differential_evolution(objective, space.dim, rng, budget, population, stop=stop,
                                                   **search.options)
        else:
            found = genetic.random_search(objective, space.dim, rng, budget, population, stop=stop, **search.options)
        backend = evaluator.backend
    if best["genes"] is None:
        raise RuntimeError("stopped before any creature was evaluated")
    history = [{"evaluations": e, "seconds": s, "best": b, "mean": m}
               for (e, b, m), s in zip(found.history, batches, strict=False)]
    return OptimizeResult(space.creature(best["genes"], config), best["f"], best["cycle"], history, best["count"],
                          time.perf_counter() - t0, found.stopped, method, backend, scales)

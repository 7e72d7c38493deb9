"""Best fitness against evaluations and seconds for each search method on the jellyfish
(the thesis' GA with simulated annealing, differential evolution, random search on the same
budget), the process pool's speed-up, and the thesis-resolution optimum.

    .venv/bin/python -m bench.jellyfish_optimize    # writes its section of docs/REPORT.md (~5 min)
"""

import time

import numpy as np

from bench.report import machine, table, write_section
from core.jellyfish import Running, Search, default_config, default_creature, optimize, simulate_cycle

POPULATION, GENERATIONS = 10, 12
BUDGET = POPULATION * (GENERATIONS + 1)
CHECKPOINTS = (10, 30, 60, 90, BUDGET)
SEEDS = (0, 1, 2)


def best_at(history, n):
    seen = [h["best"] for h in history if h["evaluations"] <= n]
    return seen[-1] if seen else np.nan


def describe(creature, config):
    a = 0.5 * config.bell.diameter
    move = (creature.destinations - creature.controls) / a
    return f"margin ({move[0, 0]:+.2f}, {move[0, 1]:+.2f}) r, contracting {creature.contraction:.2f} of the cycle"


def main():
    cfg = default_config(particles=60)
    rows, runs = [], {}
    for method in ("ga-sa", "de", "random"):
        runs[method] = [optimize(cfg, search=Search(method, s, POPULATION, GENERATIONS, BUDGET))
                        for s in SEEDS]
        rs = runs[method]
        cells = [f"{np.median([best_at(r.history, n) for r in rs]):+.3f}" for n in CHECKPOINTS]
        top = max(rs, key=lambda r: r.fitness)
        rows.append([method, *cells, f"{np.median([r.evaluations for r in rs]):.0f}",
                     f"{np.median([r.seconds for r in rs]):.1f}", f"{top.cycle.path_m / cfg.bell.diameter:.4f}"])
        print(rows[-1], flush=True)
    serial = optimize(cfg, search=Search("ga-sa", 0, POPULATION, GENERATIONS), running=Running(workers=1))
    pooled = runs["ga-sa"][0]
    assert serial.creature.destinations.tolist() == pooled.creature.destinations.tolist()

    seed_cfg = default_config()
    t0 = time.perf_counter()
    full = optimize(seed_cfg, search=Search("ga-sa", 0, POPULATION, GENERATIONS))
    full_s = time.perf_counter() - t0
    ref = simulate_cycle(default_creature(seed_cfg), seed_cfg, scales=full.scales)
    print(full.fitness, full.cycle.path_m, full_s, flush=True)

    text = "\n".join([
        f"Machine: {machine()}. core.jellyfish.optimize on the default configuration at 60 x 60 particles "
        f"(0.2 s per cycle), {POPULATION} creatures, at most {GENERATIONS} generations ({BUDGET} cycles); "
        "differential evolution and random search get the same budget. Fitness is eq. 3.14 with the thesis' "
        "lazy-mode weights (0.4, 0.3, 0.3), each term over the default creature's (which scores -0.2). "
        f"Median of {len(SEEDS)} seeds; evaluations run in a pool of 2 processes.",
        "",
        table(["method", *[f"best after {n}" for n in CHECKPOINTS], "cycles", "seconds", "path / diameter of best"],
              rows),
        "",
        f"The pool against one process (ga-sa, seed 0, identical result): {serial.seconds:.1f} s -> "
        f"{pooled.seconds:.1f} s ({serial.seconds / pooled.seconds:.2f}x on 2 cores).",
        "",
        f"At the thesis' resolution (100 x 100, 14 substeps) ga-sa seed 0 took {full_s:.0f} s for "
        f"{full.evaluations} cycles ({full.stopped}); the thesis: about 10 minutes on one 2008 core for its "
        f"whole optimisation. Best: fitness {full.fitness:+.3f}, {describe(full.creature, seed_cfg)}, path "
        f"{full.cycle.path_m / seed_cfg.bell.diameter:.4f} diameters per cycle "
        f"(default creature: {ref.fitness:+.3f}, {describe(default_creature(seed_cfg), seed_cfg)}, "
        f"{ref.path_m / seed_cfg.bell.diameter:.4f}).",
    ])
    write_section("jellyfish_optimize", "Jellyfish: search methods, best fitness against cycles and seconds", text)


if __name__ == "__main__":
    main()

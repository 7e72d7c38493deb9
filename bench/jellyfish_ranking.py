"""How many cycles a stroke search must swim each creature for: random strokes of the search space
ranked by their first k cycles against their 8 (Spearman), path and fitness, with the seconds.

    .venv/bin/python -m bench.jellyfish_ranking      # writes the section of docs/REPORT.md (~1 min)
"""

import time

import numpy as np
from scipy.stats import spearmanr

from bench.report import machine, table, write_section
from core.jellyfish import StrokeSpace, default_config, fitness, reference_scales, simulate_cycles

CREATURES, LONG = 16, 8


def main():
    cfg = default_config(particles=60)
    space, rng = StrokeSpace(), np.random.default_rng(0)
    runs, seconds = [], []
    for _ in range(CREATURES):
        t = time.perf_counter()
        r = simulate_cycles(space.creature(rng.uniform(size=space.dim), cfg), cfg, LONG)
        seconds.append((time.perf_counter() - t) / LONG)
        if r.reason is None:
            runs.append(r)
    per_cycle = np.array([r.path_per_cycle_m for r in runs])
    loss = np.array([r.energy_loss_per_cycle for r in runs])
    bend = np.array([r.bending_energy for r in runs])
    rows = []
    long_scales = reference_scales(cfg, cycles=LONG)
    for k in (1, 2, 3, 4, 6, LONG):
        scales = reference_scales(cfg, cycles=k)
        both = list(zip(per_cycle, bend, loss, strict=True))
        fit_k = [fitness(p[:k].sum(), b, e[:k].sum(), cfg, scales) for p, b, e in both]
        fit_long = [fitness(p.sum(), b, e.sum(), cfg, long_scales) for p, b, e in both]
        rows.append([k, f"{spearmanr(per_cycle[:, :k].sum(1), per_cycle.sum(1)).statistic:.3f}",
                     f"{spearmanr(fit_k, fit_long).statistic:.3f}", f"{k * np.median(seconds):.2f}"])
        print(rows[-1], flush=True)
    body = (f"{len(runs)} random strokes of the search space (StrokeSpace, seed 0), 60 x 60 particles, each swum "
            f"{LONG} cycles from rest; Spearman rank correlation of the first k cycles with all {LONG}. "
            f"{machine()}.\n\n" + table(["cycles k", "path rank vs 8", "fitness rank vs 8", "s per creature"], rows))
    write_section("jellyfish_ranking", "Jellyfish: how many cycles a stroke search needs", body)
    print(body)


if __name__ == "__main__":
    main()

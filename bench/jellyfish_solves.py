"""The water's linear solves (pressure and viscous steps) round the axis, by Fourier modes along
the axis (core.jellyfish.axial_modes) against a sparse LU of the whole lattice (SuperLU): the
default creature's first cycles at each lattice, how far apart the two paths are, and seconds
a cycle (each the better of two runs, the factors built in the first).

    .venv/bin/python -m bench.jellyfish_solves     # writes the section of docs/REPORT.md (~3 min)
"""

import time

from bench.report import machine, table, write_section
from core.jellyfish import default_config, default_creature, simulate_cycles

CYCLES = 2


def run(particles, solver):
    config = default_config(particles=particles, solver=solver)
    creature = default_creature(config)
    best, path = float("inf"), None
    for _ in range(2):
        t0 = time.perf_counter()
        result = simulate_cycles(creature, config, CYCLES)
        best = min(best, (time.perf_counter() - t0) / CYCLES)
        path = result.path_m / config.bell.diameter
    return path, best


def main():
    rows = []
    for particles in (50, 100, 150, 200):
        lu_path, lu_s = run(particles, "direct")
        modes_path, modes_s = run(particles, "modes")
        rows.append([f"{particles} x {particles}", f"{lu_path:.6f}", f"{modes_path:.6f}",
                     f"{abs(modes_path - lu_path) / lu_path:.1e}", f"{lu_s:.2f}", f"{modes_s:.2f}",
                     f"{lu_s / modes_s:.2f}"])
        print(" | ".join(rows[-1]), flush=True)
    body = table(["lattice", f"path in {CYCLES} cycles, sparse LU (D)", "by modes (D)", "relative difference",
                  "s / cycle, sparse LU", "s / cycle, by modes", "faster"], rows)
    write_section("jellyfish_solves", "Jellyfish: the water's solves by modes along the axis",
                  f"{machine()}. {__doc__.split(chr(10) + chr(10))[0]}\n\n{body}")


if __name__ == "__main__":
    main()

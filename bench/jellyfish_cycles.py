"""Swimming over many cycles (core.jellyfish.simulate_cycles): the path of each cycle against the
lattice (particles per side), the Courant number of the inner steps and the GMRES corrections of
the bell's velocity after each projection, with seconds per cycle; error against the finest run.

    .venv/bin/python -m bench.jellyfish_cycles      # writes the section of docs/REPORT.md (~15 min)
"""

import sys
import time

import numpy as np

from bench.report import machine, table, write_section
from core.jellyfish import default_config, default_creature, simulate_cycles

CYCLES = 8
DEFAULT = default_config()
# (label, changes): the default, one knob at a time, the three, then the finest run
FIXED = {"forcing_tolerance": None}  # a fixed count of corrections, not until a tolerance
SETTINGS = [
    ("default", {}),
    ("no correction (imposed and projected once)", {"forcing_corrections": 0, **FIXED}),
    ("1 correction", {"forcing_corrections": 1, **FIXED}),
    ("2 corrections (the default before stop 62)", {"forcing_corrections": 2, **FIXED}),
    ("4 corrections", {"forcing_corrections": 4, **FIXED}),
    ("16 corrections", {"forcing_corrections": 16, **FIXED}),
    ("to 5%", {"forcing_tolerance": 0.05}),
    ("to 0.1%", {"forcing_tolerance": 0.001, "forcing_corrections": 64}),
    ("Courant 0.5", {"cfl": 0.5}),
    ("Courant 0.25", {"cfl": 0.25}),
    ("28 substeps", {"substeps": 28}),
    ("no correction, Courant 0.25", {"forcing_corrections": 0, **FIXED, "cfl": 0.25}),
    ("4 corrections, Courant 0.5", {"forcing_corrections": 4, **FIXED, "cfl": 0.5}),
    ("8 corrections, Courant 0.25", {"forcing_corrections": 8, **FIXED, "cfl": 0.25}),
    ("8 corrections, Courant 0.125", {"forcing_corrections": 8, **FIXED, "cfl": 0.125}),
    ("50 x 50", {"particles": 50}),
    ("150 x 150", {"particles": 150}),
    ("200 x 200", {"particles": 200}),
    ("box twice as tall", {"box_height": 2 * DEFAULT.box}),
    ("box twice as wide (200 x 200)", {"box": 2 * DEFAULT.box, "particles": 2 * DEFAULT.particles}),
    # water's viscosity, which the lattice does not resolve: the path is then set by the steps
    ("water", {"viscosity": 1e-6}),
    ("water, 4 corrections, Courant 0.5", {"viscosity": 1e-6, "forcing_corrections": 4, **FIXED, "cfl": 0.5}),
    ("water, 8 corrections, Courant 0.25", {"viscosity": 1e-6, "forcing_corrections": 8, **FIXED, "cfl": 0.25}),
    # the thesis' 2D water: the same stroke, a trough instead of a bell of revolution
    ("planar", {"fluid": "planar"}),
    ("planar, 8 corrections, Courant 0.25", {"fluid": "planar", "forcing_corrections": 8, **FIXED, "cfl": 0.25}),
    ("finest: 150 x 150, Courant 0.25, 4 corrections",
     {"particles": 150, "cfl": 0.25, "forcing_corrections": 4, **FIXED}),
]


def run(changes):
    cfg = default_config(**changes)
    t = time.perf_counter()
    r = simulate_cycles(default_creature(cfg), cfg, CYCLES)
    return r.path_per_cycle_m / cfg.bell.diameter, (time.perf_counter() - t) / CYCLES


def main():
    only = sys.argv[1:]
    results = []
    for label, changes in SETTINGS:
        if only and label not in only:
            continue
        per_cycle, seconds = run(changes)
        results.append((label, changes, per_cycle, seconds))
        print(label, np.round(per_cycle, 4), f"{seconds:.2f} s/cycle", flush=True)
    finest = results[-1][2]
    rows = []
    for label, _, per_cycle, seconds in results:
        err_first = (per_cycle[0] - finest[0]) / finest[0] * 100
        err_total = (per_cycle.sum() - finest.sum()) / finest.sum() * 100
        rows.append([label, " ".join(f"{p:.4f}" for p in per_cycle), f"{per_cycle[0]:.4f}", f"{err_first:+.0f}",
                     f"{per_cycle[5:].mean():.4f}", f"{per_cycle[:6].sum():.4f}", f"{per_cycle.sum():.4f}",
                     f"{err_total:+.0f}", f"{seconds:.2f}"])
    body = (f"Machine: {machine()}. The default creature from rest, {CYCLES} cycles in a row; paths in bell "
            f"diameters D. Default: {DEFAULT.particles} x {DEFAULT.particles} particles, {DEFAULT.substeps} "
            f"substeps, viscosity {DEFAULT.viscosity:g} m^2/s, Courant {DEFAULT.cfl:g}, "
            f"{DEFAULT.forcing_corrections} correction(s), {DEFAULT.fluid} water. Error against the last row.\n\n"
            + table(["setting", "path per cycle (D)", "cycle 1 (D)", "cycle 1 err %", "cycles 6-8 mean (D)",
                     "6 cycles (D)", f"{CYCLES} cycles (D)", f"{CYCLES} cycles err %", "s / cycle"], rows))
    if not only:
        write_section("jellyfish_cycles",
                      "Jellyfish: swimming cycle after cycle, against lattice, steps and corrections", body)
    print(body)


if __name__ == "__main__":
    main()

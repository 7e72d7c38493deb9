"""The thesis' Table 3.1 done properly: path per cycle and seconds of the default creature
against substeps, particle resolution, the Courant number that sets the inner time step and
the GMRES corrections of the bell's velocity after each projection, each with its error against
the finest run; and
the vorticity through one cycle (the thesis' Fig. 3.3) as a PNG.

    .venv/bin/python -m bench.jellyfish     # writes its section of docs/REPORT.md (~1 min)
"""

import struct
import time
import zlib
from pathlib import Path

import numpy as np

from bench.report import machine, table, write_section
from core.jellyfish import default_config, default_creature, simulate_cycle

IMG = Path(__file__).resolve().parent.parent / "docs" / "img"
SUBSTEPS = (6, 10, 14, 20, 40)
PARTICLES = (50, 76, 100, 150, 200)  # even: half of them out from the axis
COURANT = (2.0, 1.0, 0.5, 0.25, 0.125)
FORCING = (0, 1, 2, 4, 8, 16)  # a fixed count (no tolerance)
TOLERANCES = (0.05, 0.02, 0.01, 0.005, 0.001)  # corrections until the bell's velocity is met to this share


def run(**changes):
    cfg = default_config(**changes)
    t0 = time.perf_counter()
    r = simulate_cycle(default_creature(cfg), cfg)
    return r, time.perf_counter() - t0


def sweep(name, values, fixed):
    runs = [run(**{name: v}, **fixed) for v in values]
    best = runs[-1][0].path_m
    rows = []
    for v, (r, sec) in zip(values, runs, strict=True):
        rows.append([v, f"{sec:.2f}", f"{1000 * r.path_m:.3f}", f"{r.path_m / 0.10:.4f}",
                     "-" if v == values[-1] else f"{abs(r.path_m - best) / abs(best):.3f}",
                     r.timings["inner_steps"]])
    return rows


def write_png(path, rgb):
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].astype(np.uint8).tobytes() for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def vorticity_sheet(n=100, frames=8):
    """Vorticity (red clockwise, blue anticlockwise) and the bell (black) at ``frames`` times."""
    cfg = default_config(particles=n, substeps=frames * 2)
    r = simulate_cycle(default_creature(cfg), cfg, sample_fields=True)
    shots = r.fields[1::2]
    scale = max(np.percentile(np.abs(w), 99.5) for _, _, w, _ in shots) or 1.0
    tiles = []
    for _, _, w, mask in shots:
        v = np.clip(w.reshape(n, n) / scale, -1, 1)[::-1]  # image rows run downwards
        m = mask.reshape(n, n)[::-1]
        rgb = np.stack([255 * (1 - np.clip(-v, 0, 1)), 255 * (1 - np.abs(v)), 255 * (1 - np.clip(v, 0, 1))], -1)
        rgb[m] = 0
        tiles.append(np.pad(rgb, ((2, 2), (2, 2), (0, 0)), constant_values=255))
    sheet = np.concatenate(tiles, axis=1).repeat(2, 0).repeat(2, 1)
    IMG.mkdir(exist_ok=True)
    write_png(IMG / "jellyfish_vorticity.png", sheet)
    return r


def main():
    head = ["", "seconds", "path mm", "path / diameter", "error vs finest", "inner steps"]
    by_steps = sweep("substeps", SUBSTEPS, {"particles": 100})
    by_res = sweep("particles", PARTICLES, {"substeps": 14})
    by_cfl = sweep("cfl", COURANT, {"particles": 100, "substeps": 14})
    by_forcing = sweep("forcing_corrections", FORCING, {"particles": 100, "substeps": 14, "forcing_tolerance": None})
    by_tolerance = sweep("forcing_tolerance", TOLERANCES, {"particles": 100, "substeps": 14, "forcing_corrections": 64})
    for r in by_steps + by_res + by_cfl + by_forcing + by_tolerance:
        print(r, flush=True)
    vorticity_sheet()
    text = "\n".join([
        f"Machine: {machine()}. core.jellyfish.simulate_cycle on the default creature (the thesis' Aurelia case: "
        "10 cm bell in water round its axis: a cylinder 20 cm across and 20 cm tall, periodic along the axis, "
        "viscosity 1e-5 m^2/s, one 1 s cycle, a third of it contracting). "
        "The thesis' Table 3.1 gave 7-27 s per cycle and 0.020-0.038 m of path for 6-20 substeps on one 2008 core.",
        "", "### Against substeps (100 x 100 particles)", "",
        table(["substeps", *head[1:]], by_steps), "",
        "### Against particles per side (14 substeps)", "",
        table(["particles", *head[1:]], by_res), "",
        "### Against the Courant number of the inner steps (100 x 100 particles, 14 substeps; 1 is the default)",
        "", table(["Courant number", *head[1:]], by_cfl), "",
        "### Against a fixed count of GMRES corrections of the bell's velocity after each inner step's projection "
        "(100 x 100, Courant 1; 0 imposes and projects once)", "",
        table(["corrections", *head[1:]], by_forcing), "",
        "### Against the tolerance the corrections meet the bell's velocity to (root mean square, a share of its "
        f"fastest speed; 100 x 100, Courant 1; {default_config().forcing_tolerance} is the default)", "",
        table(["tolerance", *head[1:]], by_tolerance), "",
        "![vorticity through one cycle](img/jellyfish_vorticity.png)", "",
        "Vorticity through one cycle (8 frames, left to right; red clockwise, blue anticlockwise, the bell "
        "black), 100 x 100 particles.",
    ])
    write_section("jellyfish", "Jellyfish: one swimming cycle against substeps and resolution", text)


if __name__ == "__main__":
    main()

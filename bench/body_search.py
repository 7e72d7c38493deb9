"""The nearest body point of each garment point (core.layering.correspondence): fcpw's exact BVH
against the candidate search that stands in without it (the triangles round the k nearest body
vertices), on the bundled MakeHuman body and on Fig 4.12's, error against a search over every
triangle that could be nearest (tests.core.brute.nearest_distances).

    .venv/bin/python -m bench.body_search      # writes the section of docs/REPORT.md (~1 min)
"""

import time
from pathlib import Path

import numpy as np
import trimesh

from bench.report import machine, table, write_section
from core.layering.correspondence import nearest_on_surface, surface_search
from tests.core.brute import nearest_distances

ROOT = Path(__file__).resolve().parent.parent
POINTS = 100_000
CHECKED = 30_000  # the reference is slow: the first points are checked


def bodies():
    z = np.load(ROOT / "sample_scenes" / "assets" / "makehuman" / "body_female.npz")
    yield "MakeHuman female", z["vertices"].astype(np.float64), z["faces"].astype(np.int64)
    from bench.figures import scene_arrays

    body = scene_arrays("fig_4_12")[0]
    yield "Fig 4.12", np.asarray(body.vertices), np.asarray(body.faces, dtype=np.int64)


def near_points(vertices, faces, seed=1):
    """Points from 1 cm inside to 5 cm outside the skin, where garment vertices lie."""
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    rng = np.random.default_rng(seed)
    s, face = trimesh.sample.sample_surface(mesh, POINTS, seed=seed)
    return s + mesh.face_normals[face] * rng.uniform(-0.01, 0.05, POINTS)[:, None]


def main():
    rows = []
    for name, vertices, faces in bodies():
        points = near_points(vertices, faces)
        reference = nearest_distances(points[:CHECKED], vertices, faces)
        t = time.perf_counter()
        search = surface_search(vertices, faces)
        built = time.perf_counter() - t
        cases = [("fcpw BVH (bundled)", search, 2)] if search.bvh is not None else []
        cases += [(f"candidates, k = {k}", search._replace(bvh=None), k) for k in (2, 4, 8)]
        for method, s, k in cases:
            nearest_on_surface(points[:1000], vertices, faces, k=k, search=s)  # warm
            t = time.perf_counter()
            found = nearest_on_surface(points, vertices, faces, k=k, search=s)
            dt = time.perf_counter() - t
            err = found.distance[:CHECKED] - reference
            rows.append([name, f"{len(faces):,}", method, f"{dt * 1000:.0f}", f"{np.mean(err > 1e-6) * 100:.3f}",
                         f"{max(err.max(), 0) * 1000:.4f}"])
            print(rows[-1], flush=True)
        rows.append([name, "", "(building the search)", f"{built * 1000:.0f}", "", ""])
    body = (f"{POINTS:,} points from 1 cm inside to 5 cm outside the skin; error over the first {CHECKED:,} "
            f"against every triangle that could be nearest. Misses: points whose answer is more than 1 µm "
            f"farther than the nearest. {machine()}.\n\n"
            + table(["body", "triangles", "search", "ms", "misses %", "max error mm"], rows))
    write_section("body_search", "Layered garments: the nearest body point, exact against approximate", body)
    print(body)


if __name__ == "__main__":
    main()

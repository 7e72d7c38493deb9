"""How wrong a set of garment layers looks: one metrics module for tests, benchmarks and the UI."""

from __future__ import annotations

import numpy as np

from .rays import RayScene


def unique_edges(faces) -> np.ndarray:
    f = np.asarray(faces, dtype=np.int64)
    if not len(f):
        return np.zeros((0, 2), dtype=np.int64)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    e = e[e[:, 0] != e[:, 1]]
    return np.unique(e, axis=0)


def crossing_edges(vertices_a, faces_a, scene_b: RayScene) -> np.ndarray:
    """Bool mask over ``unique_edges(faces_a)``: True where the edge passes through a triangle of B.

    Exact segment-triangle tests: a ray from each edge's start, limited to the edge's length.
    """
    v = np.asarray(vertices_a, dtype=np.float64)
    e = unique_edges(faces_a)
    if not len(e):
        return np.zeros(0, dtype=bool)
    start, vec = v[e[:, 0]], v[e[:, 1]] - v[e[:, 0]]
    length = np.linalg.norm(vec, axis=1)
    ok = length > 0
    out = np.zeros(len(e), dtype=bool)
    out[ok] = scene_b.occluded(start[ok], vec[ok], max_dist=length[ok])
    return out


def crossings(vertices_a, faces_a, vertices_b, faces_b) -> int:
    """Edges of either mesh that pass through a triangle of the other (counted once per edge)."""
    scene_a = RayScene(vertices_a, faces_a)
    scene_b = RayScene(vertices_b, faces_b)
    return int(crossing_edges(vertices_a, faces_a, scene_b).sum() + crossing_edges(vertices_b, faces_b, scene_a).sum())


def layer_crossings(layers) -> np.ndarray:
    """Pairwise crossings between a list of (vertices, faces) layers: symmetric (k, k) int matrix."""
    scenes = [RayScene(v, f) for v, f in layers]
    k = len(layers)
    out = np.zeros((k, k), dtype=np.int64)
    for i in range(k):
        for j in range(i + 1, k):
            n = crossing_edges(*layers[i], scenes[j]).sum() + crossing_edges(*layers[j], scenes[i]).sum()
            out[i, j] = out[j, i] = n
    return out

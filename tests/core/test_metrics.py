"""core.metrics crossings against brute-force segment-triangle tests."""

import numpy as np
import trimesh

from core.metrics import crossings, layer_crossings, unique_edges
from tests.core.brute import moller_trumbore


def brute_crossings(va, fa, vb, fb):
    total = 0
    for (v1, f1), (v2, f2) in (((va, fa), (vb, fb)), ((vb, fb), (va, fa))):
        e = unique_edges(f1)
        vec = v1[e[:, 1]] - v1[e[:, 0]]
        t, face = moller_trumbore(v1[e[:, 0]], vec, v2, f2, 0.0, np.linalg.norm(vec, axis=1))
        total += int((face >= 0).sum())
    return total


def test_two_spheres_cross_on_a_circle():
    a = trimesh.creation.icosphere(subdivisions=3)
    b = trimesh.creation.icosphere(subdivisions=3)
    b.apply_translation([1.0, 0.2, 0.1])
    n = crossings(a.vertices, a.faces, b.vertices, b.faces)
    assert n == brute_crossings(a.vertices, a.faces, b.vertices, b.faces)
    assert n > 20


def test_nested_spheres_do_not_cross():
    a = trimesh.creation.icosphere(subdivisions=3)
    b = trimesh.creation.icosphere(subdivisions=3, radius=1.05)
    assert crossings(a.vertices, a.faces, b.vertices, b.faces) == 0


def test_layer_matrix_is_symmetric_and_matches_pairs():
    rng = np.random.default_rng(3)
    layers = []
    for k in range(3):
        m = trimesh.creation.icosphere(subdivisions=2, radius=1.0 + 0.01 * k)
        layers.append((m.vertices + rng.normal(scale=0.02, size=m.vertices.shape), m.faces))
    mat = layer_crossings(layers)
    assert (mat == mat.T).all() and (np.diag(mat) == 0).all()
    assert mat[0, 1] == brute_crossings(*layers[0], *layers[1])
    assert mat[0, 1] > 0


def test_empty_and_degenerate_meshes():
    a = trimesh.creation.icosphere(subdivisions=1)
    assert crossings(a.vertices, a.faces, np.zeros((0, 3)), np.zeros((0, 3), int)) == 0
    # zero-length edges (a collapsed triangle) are skipped, not crossing
    v = np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0]], float)
    assert crossings(a.vertices, a.faces, v, [[0, 1, 2]]) == 0

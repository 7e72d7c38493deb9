"""Hidden-face removal against every edge tested with every triangle in float64."""

import numpy as np
import pytest

from core.geometry.topology import edges_with_counts
from core.layering.hidden_faces import crossing_faces
from tests.core.layered_cases import sheet


def _pierces(start, end, tri):
    """(edges, triangles) bool: the segment passes through the triangle's interior."""
    d = end - start
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d[:, None], e2[None])
    det = np.einsum("rmk,mk->rm", p, e1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = start[:, None] - tri[None, :, 0]
        u = np.einsum("rmk,rmk->rm", s, p) / det
        q = np.cross(s, e1[None])
        v = np.einsum("rk,rmk->rm", d, q) / det
        t = np.einsum("mk,rmk->rm", e2, q) / det
        return (np.abs(det) > 1e-14) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


def brute_hidden(vertices, faces):
    out = [np.zeros(len(f), dtype=bool) for f in faces]
    for k in range(len(faces)):
        e = edges_with_counts(faces[k])[0]
        for j in range(k + 1, len(faces)):
            if not len(faces[j]) or not len(e):
                continue
            # an edge of k through a triangle of j: k's triangles on that edge
            hit = _pierces(vertices[k][e[:, 0]], vertices[k][e[:, 1]], vertices[j][faces[j]]).any(1)
            fe = np.sort(np.stack([faces[k][:, [0, 1]], faces[k][:, [1, 2]], faces[k][:, [2, 0]]], 1), axis=2)
            for a, b in e[hit]:
                out[k] |= ((fe[..., 0] == a) & (fe[..., 1] == b)).any(1)
            # an edge of j through a triangle of k
            ej = edges_with_counts(faces[j])[0]
            out[k] |= _pierces(vertices[j][ej[:, 0]], vertices[j][ej[:, 1]], vertices[k][faces[k]]).any(0)
    return out


def wavy_layers(count, n=7, seed=0):
    rng = np.random.default_rng(seed)
    layers = []
    for i in range(count):
        phase = rng.uniform(0, 2 * np.pi, 2)
        v, f = sheet(size=1.0, n=n, z=0.01 * i, height_fn=lambda x, y, p=phase: 0.05 * np.sin(6 * x + p[0]) *
                     np.cos(5 * y + p[1]))
        v = v + rng.normal(scale=1e-3, size=v.shape)
        layers.append((v, f))
    return layers


@pytest.mark.parametrize("count", [2, 3, 4, 10])
def test_every_crossing_between_any_two_layers_is_found(count):
    layers = wavy_layers(count, seed=count)
    vertices = [v for v, _ in layers]
    faces = [f for _, f in layers]
    edges = [edges_with_counts(f)[0] for f in faces]
    found, rays = crossing_faces(vertices, faces, edges)
    expected = brute_hidden(vertices, faces)
    assert sum(m.sum() for m in expected) > 10 * (count - 1)  # the layers do cross
    for k in range(count):
        np.testing.assert_array_equal(found[k], expected[k])
    assert not found[-1].any()  # nothing lies above the top layer


@pytest.mark.parametrize("gap, most", [(0.01, 1.0), (1.0, 0.0)])
def test_layers_that_do_not_cross_cost_at_most_one_ray_per_edge_and_other_layer(gap, most):
    # the same 8 mm waves at every height: at a 1 cm gap each layer's bounds reach into its
    # neighbours' only
    layers = [sheet(size=1.0, n=7, z=gap * i, height_fn=lambda x, y: 0.008 * np.sin(6 * x)) for i in range(10)]
    edges = [edges_with_counts(f)[0] for _, f in layers]
    found, rays = crossing_faces([v for v, _ in layers], [f for _, f in layers], edges)
    assert not any(m.any() for m in found)
    # each edge is traced only against the layers whose bounds it reaches into: at most 2 of
    # the 9 others; none where the layers are a metre apart
    assert 0 < rays <= 2 * sum(len(e) for e in edges) if most else rays == 0


def test_empty_layers_between_crossing_ones_leave_no_pair_untested():
    layers = wavy_layers(4, seed=11)
    empty = (np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    layers = [layers[0], empty, layers[1], layers[2], empty, layers[3]]
    vertices = [v for v, _ in layers]
    faces = [f for _, f in layers]
    edges = [edges_with_counts(f)[0] for f in faces]
    found, _ = crossing_faces(vertices, faces, edges)
    expected = brute_hidden(vertices, faces)
    for k in range(len(layers)):
        np.testing.assert_array_equal(found[k], expected[k])


def test_empty_layers_apart_layers_and_zero_length_edges():
    (v0, f0), (v1, f1) = wavy_layers(2, seed=7)
    far = v1 + [10.0, 0.0, 0.0]  # a layer nowhere near the others traces nothing
    v0 = v0.copy()
    v0[1] = v0[0]  # a zero-length edge
    vertices = [v0, np.zeros((0, 3)), v1, far]
    faces = [f0, np.zeros((0, 3), np.int64), f1, f1]
    edges = [edges_with_counts(f)[0] for f in faces]
    found, _ = crossing_faces(vertices, faces, edges)
    expected = brute_hidden(vertices, faces)
    for k in range(4):
        np.testing.assert_array_equal(found[k], expected[k])
    assert found[0].any() and not found[3].any()
    assert crossing_faces([v0], [f0], [edges[0]])[1] == 0


def _grid(u_count, v_count, place):
    """A (u, v) grid of triangles on [0, 1]^2 mapped through place(u, v) -> (m, 3)."""
    u, v = np.meshgrid(np.linspace(0, 1, u_count), np.linspace(0, 1, v_count), indexing="ij")
    vertices = place(u.ravel(), v.ravel())
    i = np.arange(u_count - 1)[:, None] * v_count + np.arange(v_count - 1)[None, :]
    a, b, c, d = i.ravel(), i.ravel() + v_count, i.ravel() + v_count + 1, i.ravel() + 1
    return vertices, np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


@pytest.mark.parametrize("upper_first", [False, True])
def test_a_folded_layer_crossed_many_times_by_one_edge(upper_first):
    """A pleated sheet that folds back over itself (not a height field) and a narrow strip standing
    across it: each of the strip's long edges passes through the pleats five times, between the
    pleats' own edges, and every triangle it passes through is hidden, not only the first along
    it (6 triangles; the first alone would be 1). With the layers the other way round, the
    pleats' edges through the strip hide the strip's own triangles."""
    rng = np.random.default_rng(3)
    pleated = _grid(31, 4, lambda u, v: np.column_stack([0.3 * np.sin(5 * np.pi * u), v, 0.3 * u]))
    flat = _grid(2, 2, lambda u, v: np.column_stack([0.05 + 0.02 * u, 0.45 + 0.004 * v, 0.34 * u - 0.02]))
    turn = np.linalg.qr(rng.normal(size=(3, 3)))[0]  # anywhere in space
    layers = [flat, pleated] if upper_first else [pleated, flat]
    vertices = [v @ turn.T for v, _ in layers]
    faces = [f for _, f in layers]
    edges = [edges_with_counts(f)[0] for f in faces]
    found, _ = crossing_faces(vertices, faces, edges)
    expected = brute_hidden(vertices, faces)
    assert expected[0].sum() == (2 if upper_first else 6)
    for k in range(2):
        np.testing.assert_array_equal(found[k], expected[k])

"""Distances over the surface against a plain Dijkstra; what the boundary pass spreads over."""

import heapq

import numpy as np
import pytest

from core.geometry.topology import crease_edges, path_distance, topology_of
from core.layering.boundary_pass import spread_from_hits
from tests.core.layered_cases import sheet


def dijkstra_paths(vertices, faces, seeds, limit):
    neighbours = [dict() for _ in range(len(vertices))]
    for tri in faces:
        for x, y in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            if x != y:
                w = float(np.linalg.norm(vertices[x] - vertices[y]))
                neighbours[x][y] = neighbours[y][x] = w
    dist = np.full(len(vertices), np.inf)
    heap = [(0.0, int(s)) for s in seeds]
    while heap:
        d, x = heapq.heappop(heap)
        if d >= dist[x] or d > limit:
            continue
        dist[x] = d
        heap.extend((d + w, y) for y, w in neighbours[x].items() if d + w < dist[y])
    return dist


def edge_lengths(v, topology):
    e = topology.edges
    return np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)[topology.adjacency_edge]


@pytest.mark.parametrize("limit", [0.0, 0.05, 0.2, 10.0])
def test_path_distances_match_a_plain_dijkstra(limit):
    """A wavy sheet, unevenly spaced, with a second piece the seeds never reach and two
    vertices on one spot (a zero-length edge)."""
    rng = np.random.default_rng(int(limit * 100))
    v, f = sheet(n=15, height_fn=lambda x, y: 0.1 * np.sin(5 * x) * y)
    v = v + rng.normal(scale=0.01, size=v.shape)
    v[7] = v[8]
    f = np.vstack([f, f[:5] + len(v)])
    v = np.vstack([v, v[: int(f.max()) + 1 - len(v)] + 5.0])
    seeds = rng.choice(15 * 15, 4, replace=False)
    topo = topology_of(f, len(v))
    got = path_distance(topo.adjacency, edge_lengths(v, topo), seeds, limit)
    want = dijkstra_paths(v, f, seeds, limit)
    np.testing.assert_array_equal(np.isfinite(got), np.isfinite(want))
    np.testing.assert_allclose(got[np.isfinite(got)], want[np.isfinite(want)], rtol=1e-12, atol=1e-9)
    assert np.isinf(got[15 * 15:]).all()


def test_no_seeds_reach_nothing():
    v, f = sheet(n=5)
    topo = topology_of(f, len(v))
    assert np.isinf(path_distance(topo.adjacency, edge_lengths(v, topo), np.zeros(0, int), 3.0)).all()


def test_a_hem_tuck_stays_on_its_side_of_a_fold():
    """A strip folded flat over itself, 1 cm between its halves, and one hit on the upper half
    60 cm over the cloth from the fold: the upper half takes the Gaussian of its distance from
    the hit, out to 3c, and the lower half, 1 cm away through the air but 1.2 m over the
    cloth, takes nothing. One edge at the strip's far end is 0.1 mm long (draped cloth has
    such): a patch counted in rings of the shortest edge would reach round the fold."""
    n_along, n_across = 121, 11
    s = np.linspace(0.0, 1.5, n_along)  # arc length along the strip: 0.7 m, a 0.1 m bend, 0.7 m
    y = np.linspace(-0.05, 0.05, n_across)
    gap = 0.01
    radius = gap / 2

    def place(t):
        if t <= 0.7:
            return (t, 0.0)
        if t >= 0.8:
            return (0.7 - (t - 0.8), gap)
        a = (t - 0.7) / 0.1 * np.pi  # half a turn of the bend, squeezed into 0.1 m of arc
        return (0.7 + radius * np.sin(a), radius - radius * np.cos(a))

    xz = np.array([place(t) for t in s])
    v = np.column_stack([np.repeat(xz[:, 0], n_across), np.tile(y, n_along), np.repeat(xz[:, 1], n_across)])
    i, j = np.meshgrid(np.arange(n_along - 1), np.arange(n_across - 1), indexing="ij")
    a = i * n_across + j
    f = np.concatenate([np.stack([a, a + n_across, a + n_across + 1], -1).reshape(-1, 3),
                        np.stack([a, a + n_across + 1, a + 1], -1).reshape(-1, 3)])
    v[n_across] = v[0] + [1e-4, 0.0, 0.0]  # an edge along the strip at its far end
    topo = topology_of(f, len(v))
    upper = np.flatnonzero(np.repeat(s, n_across) >= 0.8)
    # the hit: on the upper half, above x = 0.1 (arc length 1.4), on a triangle there
    tri = next(k for k in range(len(f)) if np.isin(f[k], upper).all() and abs(v[f[k], 0].mean() - 0.1) < 0.01
               and abs(v[f[k], 1].mean()) < 0.01)
    hit = v[f[tri]].mean(0, keepdims=True)
    c = 0.02
    out = spread_from_hits(v, topo, hit, np.array([0.004]), f[tri], falloff=c)
    x = np.linalg.norm(v - hit, axis=1)
    want = np.where(x <= 3 * c, 0.004 * np.exp(-(x**2) / (2 * c * c)), 0.0)
    want[np.setdiff1d(np.arange(len(v)), upper)] = 0.0
    np.testing.assert_allclose(out, want, rtol=1e-12, atol=1e-15)
    lower_near = (np.repeat(s, n_across) <= 0.7) & (x <= 3 * c)
    assert lower_near.sum() > 10 and (out[upper] > 0).sum() > 10


def test_a_callers_faces_key_finds_the_topology_its_faces_are_filed_under():
    from core.geometry.topology import faces_key

    v, f = sheet(n=6)
    f32 = f.astype(np.int32)
    plain = topology_of(f, len(v))
    # the same triangles in another integer type are the same content, with or without a given key
    assert topology_of(f32, len(v)) is plain
    assert topology_of(f32, len(v), key=faces_key(f32)) is plain
    # against a topology built from scratch: the same edges
    other = topology_of(f32[::-1], len(v), key=faces_key(f32[::-1]))
    assert other is not plain
    np.testing.assert_array_equal(np.unique(other.edges, axis=0), np.unique(plain.edges, axis=0))


@pytest.mark.parametrize("angle, creased", [(30.0, False), (59.0, False), (61.0, True), (120.0, True)])
def test_creases_are_the_edges_whose_triangles_turn_past_sixty_degrees(angle, creased):
    """Two triangles hinged on one edge, against the angle between their normals; a fan's
    inner edges (flat) and its boundary (one triangle) are never creases."""
    a = np.radians(angle)
    v = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -np.cos(a), np.sin(a)]], float)
    f = np.array([[0, 1, 2], [1, 0, 3]])
    n = [np.cross(v[b] - v[a_], v[c] - v[a_]) for a_, b, c in f]
    assert np.isclose(np.degrees(np.arccos(np.dot(n[0], n[1]) / np.linalg.norm(n[0]) / np.linalg.norm(n[1]))), angle)
    got = crease_edges(v, topology_of(f, 4))
    assert got.tolist() == ([[0, 1]] if creased else [])
    fan_v, fan_f = sheet(n=4)
    assert len(crease_edges(fan_v, topology_of(fan_f, len(fan_v)))) == 0

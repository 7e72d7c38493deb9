"""Neighbour rings against a plain breadth-first search."""

from collections import deque

import numpy as np
import pytest

from core.topology import ring_distance, topology_of
from tests.core.layered_cases import sheet


def bfs_rings(faces, n, seeds, max_rings):
    neighbours = [set() for _ in range(n)]
    for a, b, c in faces:
        for x, y in ((a, b), (b, c), (c, a)):
            neighbours[x].add(y)
            neighbours[y].add(x)
    dist = np.full(n, -1)
    queue = deque()
    for s in seeds:
        dist[s] = 0
        queue.append(s)
    while queue:
        x = queue.popleft()
        if dist[x] == max_rings:
            continue
        for y in neighbours[x]:
            if dist[y] < 0:
                dist[y] = dist[x] + 1
                queue.append(y)
    return dist


@pytest.mark.parametrize("max_rings", [0, 1, 3, 50])
def test_rings_match_a_breadth_first_search(max_rings):
    v, f = sheet(n=15)
    f = np.vstack([f, f[:5] + len(v)])  # a second piece the seeds never reach
    n = int(f.max()) + 1
    rng = np.random.default_rng(max_rings)
    seeds = rng.choice(len(v), 4, replace=False)
    got = ring_distance(topology_of(f, n).adjacency, seeds, max_rings)
    np.testing.assert_array_equal(got, bfs_rings(f, n, seeds, max_rings))


def test_no_seeds_reach_nothing():
    v, f = sheet(n=5)
    assert (ring_distance(topology_of(f, len(v)).adjacency, np.zeros(0, int), 3) == -1).all()

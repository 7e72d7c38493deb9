"""Triangles that still show through a higher layer (thesis Fig. 4.14): where an edge of one layer
passes through a triangle of another, the lower layer's triangle there is hidden.

Each layer's scene is built once. Every layer's edges that reach into the bounds of the
others are traced once against all of them together (one Embree scene instancing theirs), so
every pair of layers is tested both ways; the few edges that cross anything are asked of each
layer in turn, and only those are traced on to name each triangle they pass through. (Tracing
every edge against each other layer in turn took twice as long on four concentric layers;
grouping layers by the bits of their index, with each triangle built into several scenes,
was slower still.)
"""

from __future__ import annotations

import numpy as np

from ..geometry.topology import used_vertices
from ..geometry.vectors import box, norms, rows
from ..rays.scene import FEW_RAYS, RayScene, step_past_hit
from ..rays.scene_union import SceneUnion

_MAX_ROUNDS = 64


def _edge_faces(faces, edges, crossed, n_vertices):
    """Triangles owning any of the crossed edges (sorted vertex pairs). Few edges cross: only
    triangles with two of their ends are looked at."""
    e = edges[crossed]
    marked = np.zeros(n_vertices, dtype=bool)
    marked[e.ravel()] = True
    # corner by corner: a sum over the rows of an (m, 3) gather is several times slower
    ends = marked[faces[:, 0]].astype(np.int8) + marked[faces[:, 1]] + marked[faces[:, 2]]
    maybe = np.flatnonzero(ends >= 2)
    f = faces[maybe]
    fe = np.sort(np.stack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]], 1), axis=2)
    out = np.zeros(len(faces), dtype=bool)
    out[maybe] = np.isin(fe[..., 0] * n_vertices + fe[..., 1], e[:, 0] * n_vertices + e[:, 1]).any(1)
    return out


def _bounds(vertices, faces):
    used = used_vertices(faces, len(vertices))
    v = vertices if used.all() else vertices[used]
    return box(v)


def _edges_near(vertices, edges, length, lo, hi):
    """Edges (of nonzero length) that may reach into the box lo..hi: both ends within the
    longest edge of it, tested vertex by vertex (a superset of the edges that do)."""
    inside = vertices[:, 0] >= -np.inf
    if len(length):
        reach = float(length.max())
        for axis in range(3):
            inside &= (vertices[:, axis] >= lo[axis] - reach) & (vertices[:, axis] <= hi[axis] + reach)
    return np.flatnonzero(inside[edges[:, 0]] & inside[edges[:, 1]] & (length > 0))


def crossing_faces(vertices, faces, edges, scenes=None) -> tuple[list, int]:
    """Per layer (lists ordered inner to outer; ``edges`` as sorted vertex pairs), a bool mask of
    its triangles that a higher layer crosses: the triangles an edge of a higher layer passes
    through, and the triangles owning an edge that passes through a higher layer.
    ``scenes``: per layer a RayScene already built over exactly these faces and vertices, or
    None (built here). Returns (masks, rays traced)."""
    removed = [np.zeros(len(f), dtype=bool) for f in faces]
    present = [k for k in range(len(faces)) if len(faces[k])]
    if len(present) < 2:
        return removed, 0
    layers = _Layers(vertices, faces, edges, scenes, present)
    found, rays = _edges_through_others(layers)
    crossed = [np.zeros(len(e), dtype=bool) for e in edges]
    for j in present:
        if found[j]:
            rays += _name_crossed(layers, j, found[j], removed, crossed)
    for k in present:
        if crossed[k].any():
            removed[k] |= _edge_faces(faces[k], edges[k], crossed[k], len(vertices[k]))
    return removed, rays


def edges_through_lower(vertices, faces, edges, scenes=None) -> list:
    """(lower layer j, higher layer k, edge ids of k) for every higher layer's edges that pass through a
    triangle of a lower layer (lists ordered inner to outer; ``edges`` as sorted vertex pairs;
    ``scenes`` as crossing_faces takes them)."""
    present = [k for k in range(len(faces)) if len(faces[k])]
    if len(present) < 2:
        return []
    found, _ = _edges_through_others(_Layers(vertices, faces, edges, scenes, present), lower_only=True)
    return [(j, k, idx) for j, pairs in found.items() for k, idx in pairs]


class _Layers:
    """The layers' edges as rays (start, vector, length), their boxes, and a scene per layer
    built when first asked."""

    def __init__(self, vertices, faces, edges, scenes, present):
        self.vertices, self.faces, self.edges, self.present = vertices, faces, edges, present
        self._given, self._built = scenes, {}
        self.bounds = {j: _bounds(vertices[j], faces[j]) for j in present}
        self.start = [rows(v, e[:, 0]) for v, e in zip(vertices, edges, strict=True)]
        self.vec = [rows(v, e[:, 1]) - a for v, e, a in zip(vertices, edges, self.start, strict=True)]
        self.length = [norms(x) for x in self.vec]

    def scene(self, j):
        if j not in self._built:
            given = self._given[j] if self._given is not None else None
            self._built[j] = given if given is not None else RayScene(self.vertices[j], self.faces[j], quality=FEW_RAYS)
        return self._built[j]


def _edges_through_others(layers, lower_only=False):
    """Per layer j: (layer k, its edges that pass through something of j) for every other layer k
    (``lower_only``: every layer k above j); and rays traced. Each layer's edges go once against
    all the others together: few cross anything, and only those are asked of each layer in turn."""
    bounds, length, present = layers.bounds, layers.length, layers.present
    found = {j: [] for j in present}
    rays = 0
    for k in present:
        own_lo, own_hi = bounds[k]
        others = [j for j in present if (j < k if lower_only else j != k)
                  and (bounds[j][0] <= own_hi).all() and (bounds[j][1] >= own_lo).all()]
        if not others:
            continue
        lo = np.min([bounds[j][0] for j in others], axis=0)
        hi = np.max([bounds[j][1] for j in others], axis=0)
        pick = (np.flatnonzero(length[k] > 0) if (own_lo >= lo).all() and (own_hi <= hi).all() else
                _edges_near(layers.vertices[k], layers.edges[k], length[k], lo, hi))
        if not len(pick):
            continue
        every = len(pick) == len(length[k])
        o, d = (layers.start[k], layers.vec[k]) if every else (rows(layers.start[k], pick), rows(layers.vec[k], pick))
        against = layers.scene(others[0]) if len(others) == 1 else SceneUnion([layers.scene(j) for j in others])
        rays += len(pick)
        hit = pick[against.occluded(o, d, max_dist=1.0, scaled=True)]
        if not len(hit):
            continue
        for j in others:  # which layers those edges cross
            near = hit if len(others) == 1 else hit[_edges_near(layers.vertices[k], layers.edges[k][hit],
                                                                length[k][hit], *bounds[j])]
            if len(near) and len(others) > 1:
                rays += len(near)
                near = near[layers.scene(j).occluded(rows(layers.start[k], near), rows(layers.vec[k], near),
                                                     max_dist=1.0, scaled=True)]
            if len(near):
                found[j].append((k, near))
    return found, rays


def _name_crossed(layers, j, found_j, removed, crossed) -> int:
    """The few edges that cross layer j, traced on to name each triangle of j they pass through:
    a higher layer's edge hides every triangle of j it passes through (``removed[j]``); an edge of
    a layer under j that meets j marks itself crossed (its own triangles hide). Returns rays traced."""
    scene, (lo, hi) = layers.scene(j), layers.bounds[j]
    owner = np.concatenate([np.full(len(idx), k) for k, idx in found_j])
    index = np.concatenate([idx for _, idx in found_j])
    o = np.concatenate([rows(layers.start[k], idx) for k, idx in found_j])
    d = np.concatenate([rows(layers.vec[k], idx) for k, idx in found_j])
    tmax = np.concatenate([layers.length[k][idx] for k, idx in found_j])
    live = np.arange(len(o))
    t_min = np.zeros(len(o))
    step = step_past_hit(tmax, lo, hi)
    rays = 0
    for _ in range(_MAX_ROUNDS):
        if not len(live):
            break
        hits = scene.intersect(o[live], d[live], max_dist=tmax[live], min_dist=t_min[live])
        rays += len(live)
        live, t, face = live[hits.hit], hits.t[hits.hit], hits.face[hits.hit]
        up = j > owner[live]  # the edge goes through a higher layer: its own triangles hide
        for k in np.unique(owner[live[up]]):
            crossed[k][index[live[up & (owner[live] == k)]]] = True
        removed[j][face[~up]] = True  # a higher layer's edge goes through this triangle
        # one hit hides an edge's own triangles; a higher layer's edge goes on to every
        # triangle of this layer it passes through
        live, t = live[~up], t[~up]
        t_min[live] = t + step[live]
    return rays

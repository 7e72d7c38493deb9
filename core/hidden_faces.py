"""Triangles that still show through a higher layer (seed Fig. 4.14): where an edge of one layer
passes through a triangle of another, the lower layer's triangle there is hidden.

Each layer's scene is built once and every other layer's edges that reach into its bounds are
traced against it, so every pair of layers is tested both ways. An occlusion test finds the
few edges that cross anything; only those are traced on to name each triangle they pass
through. (Grouping layers by the bits of their index, ceil(log2 layers) traces per edge
against scenes of half the layers, was slower at 4 to 10 layers: each triangle is built into
that many scenes, and half-layer bounds cull far fewer edges.)
"""

from __future__ import annotations

import numpy as np

from .rays import RayScene, step_past_hit
from .topology import used_vertices
from .vectors import box, norms, rows

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
    start = [rows(v, e[:, 0]) for v, e in zip(vertices, edges, strict=True)]
    vec = [rows(v, e[:, 1]) - a for v, e, a in zip(vertices, edges, start, strict=True)]
    length = [norms(x) for x in vec]
    # unit directions once per layer, as RayScene makes them, for its edges' traces against
    # every other layer (zero-length edges are never traced)
    with np.errstate(divide="ignore", invalid="ignore"):
        unit = [x / n[:, None] for x, n in zip(vec, length, strict=True)]
    edge_lo = [np.minimum(a, a + b) for a, b in zip(start, vec, strict=True)]
    edge_hi = [np.maximum(a, a + b) for a, b in zip(start, vec, strict=True)]
    crossed = [np.zeros(len(e), dtype=bool) for e in edges]
    rays = 0
    for j in present:
        lo, hi = _bounds(vertices[j], faces[j])
        scene = None
        found = []  # (layer, its edges that pass through something of layer j)
        for k in (k for k in present if k != j):
            # only edges reaching into the layer's bounds can cross it
            near = length[k] > 0
            for axis in range(3):  # column by column: all(axis=1) on (n, 3) is slow
                near &= (edge_lo[k][:, axis] <= hi[axis]) & (edge_hi[k][:, axis] >= lo[axis])
            pick = np.flatnonzero(near)
            if not len(pick):
                continue
            if scene is None:
                scene = scenes[j] if scenes is not None and scenes[j] is not None else RayScene(vertices[j], faces[j])
            rays += len(pick)
            # a layer's edges against another, straight from its arrays where all of them are asked
            every = len(pick) == len(near)
            o, d, t = ((start[k], unit[k], length[k]) if every else
                       (rows(start[k], pick), rows(unit[k], pick), length[k][pick]))
            found.append((k, pick[scene.occluded(o, d, max_dist=t, unit=True)]))
        found = [(k, idx) for k, idx in found if len(idx)]
        if not found:
            continue
        # the few edges that cross something, traced on to name each triangle they pass through
        owner = np.concatenate([np.full(len(idx), k) for k, idx in found])
        index = np.concatenate([idx for _, idx in found])
        o = np.concatenate([rows(start[k], idx) for k, idx in found])
        d = np.concatenate([rows(vec[k], idx) for k, idx in found])
        tmax = np.concatenate([length[k][idx] for k, idx in found])
        live = np.arange(len(o))
        t_min = np.zeros(len(o))
        step = step_past_hit(tmax, lo, hi)
        for _ in range(_MAX_ROUNDS):  # every triangle of layer j along each crossing edge
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
    for k in present:
        if crossed[k].any():
            removed[k] |= _edge_faces(faces[k], edges[k], crossed[k], len(vertices[k]))
    return removed, rays

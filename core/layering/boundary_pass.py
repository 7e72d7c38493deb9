"""The boundary pass (thesis Fig. 4.9-4.10): a higher layer's hem points look outward for the layer
under it, and the cloth around each hit is tucked in under the hem with a Gaussian RBF weight,
so no gap opens and no edge overstretches where an outer garment ends."""

from __future__ import annotations

import numpy as np

from ..geometry.topology import path_distance
from ..geometry.vectors import norms, rows
from .gaussian_peak import largest_gaussian
from .probe_ties import off_the_lines
from .tracer import HitRules, Probes, trace_layers


def spread_from_hits(vertices, topology, hit_points, amplitude, seed_vertices, falloff=None):
    """Per-vertex inward move near a higher layer's hem (Fig. 4.9-4.10).

    Each hit moves nearby vertices by amplitude * exp(-x^2 / 2c^2), x their distance from
    the hit point, truncated at 3c; only vertices that near over the cloth take part (an
    edge path from the hit triangle's corners of at most sqrt(2) times 3c, for the detours
    edge paths make, plus the corners' distance from the hit), so the move stays on the same
    patch of cloth: a fold, or another part of the garment lying close, does not follow.
    Distances from the hit point (not from the triangle's corners) make the result
    independent of which of two triangles sharing an edge the ray reported. ``seed_vertices``:
    the three corners of each hit's triangle, hit by hit.
    """
    e = topology.edges
    length = norms(rows(vertices, e[:, 0]) - rows(vertices, e[:, 1]))
    edge = float(length.mean()) if len(e) else 0.0
    c = float(falloff) if falloff is not None else 4.0 * edge
    if c <= 0:
        out = np.zeros(len(vertices))
        np.maximum.at(out, seed_vertices, np.repeat(amplitude, 3))
        return out
    reach = 3.0 * c
    if not len(hit_points):
        return np.zeros(len(vertices))
    corner_gap = norms(rows(vertices, seed_vertices) - np.repeat(hit_points, 3, axis=0))
    limit = np.sqrt(2.0) * reach + float(corner_gap.max(initial=0.0))
    over_cloth = path_distance(topology.adjacency, length[topology.adjacency_edge], seed_vertices, limit)
    candidates = np.flatnonzero(np.isfinite(over_cloth))
    out = np.zeros(len(vertices))
    out[candidates] = largest_gaussian(vertices[candidates], hit_points, amplitude, c, reach)
    return out


def tuck_under_hems(stack, k):
    """Tuck layer k of the LayerStack in under the hems of the layers above it."""
    v, f = stack.verts[k], stack.faces[k]
    up = stack.above(k)
    if not len(f) or not up:
        return
    # every higher layer's hem points at once: one scene of this layer near the hems (each off
    # the exact line through its vertex: see off_the_lines)
    n_o = np.concatenate([stack.normals[j][stack.hems[j]] for j in up])
    o = np.concatenate([off_the_lines(stack.verts[j], stack.topo[j], stack.chord * 1e-3,
                                      stack.normals[j][stack.hems[j]], stack.hems[j]) for j in up])
    if not len(o):
        return
    probes = Probes(o, n_o, np.concatenate([stack.probe_len[j][stack.hems[j]] for j in up]),
                    np.concatenate([stack.junction_parts[j][stack.hems[j]] for j in up]))
    traced = trace_layers(probes, stack.scenes, [k], HitRules(cull=True, facing=(stack.normals, n_o)))
    t, layer, face = traced.t, traced.layer, traced.face
    stack.rays["boundary"] += traced.rays
    hit = layer == k
    if not hit.any():
        return
    # A hit goes no deeper than the body lets its triangle go: where the body holds the
    # layer, the cloth around the hit stays too (else each resolve of the result digs it in further)
    corners = f[face[hit]]
    room = stack.room_of(k, corners).max(1)
    amp = np.clip(np.minimum(t[hit] + stack.gap, room), 0.0, None)
    spread = spread_from_hits(v, stack.topo[k], o[hit] + n_o[hit] * t[hit, None], amp,
                              corners.ravel(), stack.params.falloff)
    idx = np.flatnonzero(spread > 0)
    spread[idx] = stack.body_floor(k, idx, spread[idx])
    stack.moved(k, v - stack.normals[k] * spread[:, None])
    stack.moved_by["boundary"] += int((spread > 0).sum())

"""Push-behind (thesis 4.4, mesh-deformation mode): every vertex of a lower layer probes inward
along its global normal -n'; where it meets a higher layer of its own part within l_s, it moves
behind it by the distance plus the gap."""

from __future__ import annotations

import numpy as np

from .probe_ties import off_the_lines
from .tracer import HitRules, Probes, trace_layers


def push_behind(stack, k):
    """Push every vertex of layer k of the LayerStack behind the higher layers its probe meets."""
    v = stack.verts[k]
    if not len(v):
        return
    # Probes start the gap outside the vertex, so a vertex less than that behind a higher
    # layer is caught too: a hit at t means the layer is (t - gap) behind, and moving by t
    # leaves exactly the gap. Behind the farthest higher layer within reach, not the nearest.
    # Each runs just off the line through its vertex (off_the_lines, where float32 decided ties
    # by round-off); one that meets nothing is asked again off the other side, so a vertex right
    # under a higher layer's hem counts as under it, and one level with a crease of a higher
    # layer (where a Solidify's rim turns in) as beside it, whichever side either probe took.
    step = stack.chord * 1e-3
    above = stack.above(k)
    creases = [stack.creases(j) if j in above else None for j in range(len(stack.verts))]
    aside = off_the_lines(v, stack.topo[k], step, stack.normals[k]) - v
    t, layer = _probe(stack, k, aside, step, creases, stack.topo[k].loose)
    again = layer < 0
    if stack.topo[k].loose is not None:
        again &= ~stack.topo[k].loose
    if again.any():
        t2, layer2 = _probe(stack, k, -aside, step, creases, ~again)
        t[again], layer[again] = t2[again], layer2[again]
    hit = layer >= 0
    if hit.any():
        idx = np.flatnonzero(hit)
        t[idx] = stack.body_floor(k, idx, t[idx])
        out = v.copy()
        out[hit] -= stack.normals[k][hit] * t[hit, None]
        stack.moved(k, out)
        stack.moved_by["push"] += int(hit.sum())


def _probe(stack, k, aside, step, creases, skip):
    """(t, layer) of layer k's inward probes, each moved ``aside`` (``step`` long) off its vertex's line."""
    v, gap, normals = stack.verts[k], stack.gap, stack.normals
    start = v + aside + normals[k] * gap
    probes = Probes(start, -normals[k], stack.probe_len[k] + gap, stack.junction_parts[k], skip)
    rules = HitRules(farthest=True, facing=(normals, normals[k]), creases=(creases, np.full(len(v), 10 * abs(step))))
    traced = trace_layers(probes, stack.scenes, stack.above(k), rules)
    stack.rays["push"] += traced.rays
    stack.push_trace_s += traced.seconds
    return traced.t, traced.layer

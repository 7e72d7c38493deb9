"""Push-behind (thesis 4.4, mesh-deformation mode): every vertex of a lower layer probes inward
along its global normal -n'; where it meets a higher layer of its own part within l_s, it moves
behind it by the distance plus the gap."""

from __future__ import annotations

import numpy as np

from .tracer import trace_layers


def push_behind(stack, k):
    """Push every vertex of layer k of the LayerStack behind the higher layers its probe meets."""
    v = stack.verts[k]
    if not len(v):
        return
    gap, normals = stack.gap, stack.normals
    # Probes start the gap outside the vertex, so a vertex less than that behind a higher
    # layer is caught too: a hit at t means the layer is (t - gap) behind, and moving by t
    # leaves exactly the gap. Behind the farthest higher layer within reach, not the nearest.
    t, layer, _, r, secs = trace_layers(v + normals[k] * gap, -normals[k], stack.probe_len[k] + gap, stack.vseg2[k],
                                        stack.scenes, stack.above(k), farthest=True,
                                        facing=(normals, normals[k]), skip=stack.topo[k].loose)
    stack.rays["push"] += r
    stack.push_trace_s += secs
    hit = layer >= 0
    if hit.any():
        idx = np.flatnonzero(hit)
        t[idx] = stack.body_floor(k, idx, t[idx])
        out = v.copy()
        out[hit] -= normals[k][hit] * t[hit, None]
        stack.moved(k, out)
        stack.moved_by["push"] += int(hit.sum())

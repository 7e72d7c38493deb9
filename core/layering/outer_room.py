"""A higher layer's long edge dipping through a lower layer between the lower layer's vertices: push
behind puts each lower vertex a gap behind the higher layer along its probe, but where the body
leaves the lower layer no room (an armpit, a crotch) and the higher layer's triangles are long
(17-86 mm on MakeHuman's casual suit across the armpit crease), the higher edge still passes
through lower triangles between their corners. Hidden, such a triangle is seen edge-on past the
higher layer's outline as a hole. Here the higher edge's ends go out instead, by how far the lower
layer lies over the edge, plus the offset."""

from __future__ import annotations

import numpy as np

from ..geometry.vectors import unit
from .body_lift import inner_shell
from .hidden_faces import edges_through_lower

# points along a crossing edge where the lower layer's height over it is found
SAMPLES = 9
# the most an end goes out, in gaps between layers (farther, the lower layer is not what is over it)
MOST = 1.0


def make_room(stack) -> int:
    """Move the ends of each higher layer's edges that pass through a lower layer out along their
    global normals until the lower layer lies an offset behind the whole edge. Returns how many
    vertices moved."""
    active = stack.active
    if len(active) < 2 or all(stack.params.simulated[k] for k in active[1:]):
        return 0
    lift, shells = {}, {}
    crossing = edges_through_lower([stack.verts[i] for i in active], [stack.faces[i] for i in active],
                                   [stack.edges[i] for i in active], [stack.scenes[i].full() for i in active])
    for j, k, idx in crossing:
        k = active[k]
        if stack.params.simulated[k]:  # a solver's cloth keeps its contacts: its crossing faces hide
            continue
        if k not in shells:
            shells[k] = inner_shell(stack, k) is not None
        if shells[k]:  # a garment with thickness hides what crosses its inner shell behind its outer one
            continue
        e = stack.edges[k][idx]
        need = _height_over(stack, active[j], k, e)
        out = lift.setdefault(k, np.zeros(len(stack.verts[k])))
        for end in (0, 1):
            np.maximum.at(out, e[:, end], need)
    moved = 0
    for k, out in sorted(lift.items(), reverse=True):  # from the outside in: each capped by where those over it went
        if stack.params.subdivided[k]:
            out = _one_ring_wider(out, stack.edges[k])
        out = _below_the_next(stack, k, out)
        go = out > 0
        if go.any():
            v = stack.verts[k].copy()
            v[go] += stack.normals[k][go] * out[go, None]
            stack.clearance[k][go] = np.maximum(stack.clearance[k][go] - out[go], 0.0)
            stack.moved(k, v)
            moved += int(go.sum())
    stack.moved_by["room"] += moved
    return moved


def _below_the_next(stack, k, lift):
    """The lift of layer k kept an offset short of the layers above it along each vertex's normal:
    a middle layer lifted into the one over it would be hidden there instead (four layers of Fig
    4.12: 2.3 times the middle layers' hidden faces, and 3 crossing edges left)."""
    up = stack.above(k)
    go = np.flatnonzero(lift > 0)
    if not up or not len(go):
        return lift
    v, n = stack.verts[k][go], stack.normals[k][go]
    room = np.full(len(go), np.inf)
    for j in up:
        hits = stack.scenes[j].full().intersect(v, n, max_dist=float(lift[go].max()) + stack.params.offset)
        room[hits.hit] = np.minimum(room[hits.hit], hits.t[hits.hit])
    out = lift.copy()
    out[go] = np.clip(np.minimum(lift[go], room - stack.params.offset), 0.0, None)
    return out


def _one_ring_wider(lift, edges):
    """The lift, each vertex's also taken by its neighbours: a bump one edge wide, smoothed by a
    Subdivision Surface after the correction, sinks back about halfway and passes through the lower
    layer again (the rigged sample with Subdivision: 2-15 crossing edges on 10 frames of 96, against
    2-3 on 2 frames with the plateau). Not by default: on the cage itself the wider lift doubles the
    vertices moved, and the walk's jitter p99 goes 0.84 -> 0.96 mm."""
    out = lift.copy()
    np.maximum.at(out, edges[:, 0], lift[edges[:, 1]])
    np.maximum.at(out, edges[:, 1], lift[edges[:, 0]])
    return out


def _height_over(stack, j, k, e):
    """Per edge (vertex pairs of layer k), how far out its ends must go for layer j to lie an offset
    behind it: the most layer j lies over a point of it, along the edge's interpolated normal."""
    v, n = stack.verts[k], stack.normals[k]
    s = np.linspace(0.0, 1.0, SAMPLES)
    a, b = v[e[:, 0]], v[e[:, 1]]
    pts = (a[:, None, :] + s[None, :, None] * (b - a)[:, None, :]).reshape(-1, 3)
    nrm = unit((n[e[:, 0]][:, None, :] * (1 - s)[None, :, None] + n[e[:, 1]][:, None, :] * s[None, :, None])
               .reshape(-1, 3))
    reach = MOST * stack.gap
    hits = stack.scenes[j].full().intersect(pts, nrm, max_dist=reach)
    over = np.where(hits.hit, hits.t, 0.0).reshape(len(e), SAMPLES)
    need = np.where(over.max(1) > 0, np.minimum(over.max(1) + stack.params.offset, reach), 0.0)
    # only where the body holds the lower layer: with room behind it, push put it where it is for
    # another reason (cloth far from the body, beyond its probes), and the higher layer stays
    room = np.full(hits.hit.shape, np.inf)
    corners = stack.faces[j][hits.face[hits.hit]]
    room[hits.hit] = stack.room_of(j, corners.ravel()).reshape(-1, 3).min(1)
    held = room.reshape(len(e), SAMPLES).min(1) < need
    return np.where(held, need, 0.0)

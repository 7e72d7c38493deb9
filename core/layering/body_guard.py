"""Keep moved cloth out of the body: the body floor holds each vertex in front of the body, but a
triangle between vertices held close to it can still cut through a convex edge of the body (a
box's ridge, a wooden mannequin's joint, a fold of the collider). Such a triangle's moved
corners go back towards where they were, half the way at a time, until the moves put nothing
through the body."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..geometry.vectors import norms, rows
from ..rays.scene import FEW_RAYS, RayScene, step_past_hit
from .metrics import crossing_edges

# Halvings of a move before it is taken back whole (1, 1/2, 1/4, then 0 of it kept)
_HALVINGS = 3


@dataclass(frozen=True)
class Cloth:
    """A layer's faces and edges (vertex pairs); ``scene``: a callable giving a RayScene over all
    its faces where the layer lies, or None."""

    faces: np.ndarray
    edges: np.ndarray
    scene: Callable | None = None


def crossing_corners(body, cloth: Cloth, vertices, tri, edges):
    """Bool mask over ``vertices`` (the cloth's, where it lies): ends of ``edges`` that pass through
    the body, and corners of the triangles ``tri`` (face ids) that an edge of the body passes
    through (traced on the cloth's scene, or on one built over ``tri``). ``body``: its BodyFacts
    (its scene, vertices, and edges with their boxes)."""
    body_vertices, faces, scene = body.vertices, cloth.faces, cloth.scene
    out = np.zeros(len(vertices), dtype=bool)
    if len(edges):
        out[edges[crossing_edges(vertices, None, body.scene, edges=edges)].ravel()] = True
    if not len(tri):
        return out
    # only body edges whose box meets the triangles' box can pass through them
    pairs, edge_lo, edge_hi = body.edges
    used = np.zeros(len(vertices), dtype=bool)  # a mask, not a unique: a sort of most of the layer's corners
    used[faces[tri].ravel()] = True
    lo = [float(vertices[used, axis].min()) for axis in range(3)]
    hi = [float(vertices[used, axis].max()) for axis in range(3)]
    near = np.ones(len(pairs), dtype=bool)
    for axis in range(3):
        near &= (edge_lo[axis] <= hi[axis]) & (edge_hi[axis] >= lo[axis])
    near = np.flatnonzero(near)
    if not len(near):
        return out
    ids = None if scene is not None else tri
    scene = scene() if scene is not None else RayScene(vertices, faces[tri], quality=FEW_RAYS)
    asked = np.zeros(len(faces), dtype=bool)
    asked[tri] = True
    through = near[crossing_edges(body_vertices, None, scene, edges=pairs[near])]
    start = body_vertices[pairs[through, 0]]
    vec = body_vertices[pairs[through, 1]] - start
    length = norms(vec)
    step = step_past_hit(length, lo, hi)
    live, t_min = np.arange(len(through)), np.zeros(len(through))
    for _ in range(4):  # each triangle of the layer an edge passes through, up to four
        if not len(live):
            break
        hits = scene.intersect(start[live], vec[live], max_dist=length[live], min_dist=t_min[live])
        live, t, face = live[hits.hit], hits.t[hits.hit], hits.face[hits.hit]
        face = face if ids is None else ids[face]
        out[faces[face[asked[face]]].ravel()] = True
        t_min[live] = t + step[live]
    return out


def back_off(body, cloth: Cloth, before, after, clearance, through_before=False):
    """``after`` (a layer's vertices once moved, ``before`` as they came) with the moves that put
    cloth through the body taken back, halving them first. ``clearance``: a lower bound on each
    vertex's distance from the body at ``after`` (inf inside it). The cloth's scene (over it at
    ``after``) is asked only if a triangle needs it. ``through_before``: corners that passed
    through the body at ``before`` already keep their moves (a move that only fails to take cloth
    out of the body is not undone).
    Returns (vertices, how many went back).

    Only what a move touched and what is near enough to the body is asked: an edge meeting
    the body at x has its ends |a - x| and |b - x| from it, together its length; a triangle
    meeting it has every corner within its longest edge of x."""
    faces, edges = cloth.faces, cloth.edges
    move = norms(after - before)
    moved = move > 0
    if not moved.any():
        return after, 0
    length = norms(rows(after, edges[:, 1]) - rows(after, edges[:, 0]))
    e = edges[(moved[edges[:, 0]] | moved[edges[:, 1]])
              & (clearance[edges[:, 0]] + clearance[edges[:, 1]] <= length)]
    near = clearance <= length.max(initial=0.0)
    # corner by corner: any/all over the rows of an (m, 3) gather is several times slower
    tri = np.flatnonzero((moved[faces[:, 0]] | moved[faces[:, 1]] | moved[faces[:, 2]])
                         & near[faces[:, 0]] & near[faces[:, 1]] & near[faces[:, 2]])
    if not len(tri) and not len(e):
        return after, 0
    if through_before:
        moved &= ~crossing_corners(body, Cloth(faces, edges), before, tri, e)
    out = after.copy()
    keep = np.ones(len(out))
    went_back = np.zeros(len(out), dtype=bool)
    for step in range(_HALVINGS + 1):
        bad = crossing_corners(body, cloth if step == 0 else Cloth(faces, edges), out, tri, e) & moved
        if not bad.any():
            break
        keep[bad] = 0.0 if step == _HALVINGS else 0.5 * keep[bad]
        out[bad] = before[bad] + (after[bad] - before[bad]) * keep[bad, None]
        went_back |= bad
        # only what has a corner that went back can cross anew (clearances no longer hold there)
        corners = faces[tri]
        tri = tri[bad[corners[:, 0]] | bad[corners[:, 1]] | bad[corners[:, 2]]]
        e = edges[bad[edges[:, 0]] | bad[edges[:, 1]]]
    return out, int(went_back.sum())


def keep_clear_cloth_clear(stack, k, before, after, clearance):
    """Layer k of a LayerStack moved from ``before`` to ``after`` (the lift, easing), with the moves
    that put cloth through the body where it was clear taken back (``back_off`` keeping the moves of
    corners already through it). Returns (vertices, how many went back), counted on the stack."""
    out, n_back = back_off(stack.body, Cloth(stack.faces[k], stack.edges[k]), before, after, clearance,
                           through_before=True)
    stack.backed_off += n_back
    return out, n_back


def keep_out_of_body(stack, k) -> None:
    """The body guard on layer k of a LayerStack: where its moves put cloth through the body, they
    are taken back (before the layers under it are fitted to it). A correspondence passed in
    bounds no distance from below, so there every moved triangle is asked (guard_clearance). The
    layer's scene serves the layers under it next: built here, it is not built twice."""
    kept_out, n_back = back_off(stack.body, Cloth(stack.faces[k], stack.edges[k], stack.scenes[k].full), stack.rest[k],
                                stack.verts[k], stack.guard_clearance(k))
    if n_back:
        stack.moved(k, kept_out)
        stack.backed_off += n_back

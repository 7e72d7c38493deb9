"""The garment layers as the stages move them, and how far the body lets each vertex go."""

from __future__ import annotations

import numpy as np

from ..geometry.topology import crease_edges, topology_of
from .tracer import LayerLayout, SegmentScenes, face_segment


class LayerStack:
    """Each garment's vertices where the stages have moved them so far, with what stays fixed
    (faces, topology, hems, n', l_s, parts) and what follows the moves (its ray scenes, each
    vertex's room in front of the body). Only the garments the pre-processing found near another
    (``active``) have their topology and scenes; the rest never move."""

    def __init__(self, body, garment_arrays, prep, params):
        n_g = len(garment_arrays)
        self.body, self.params, self.n_garments = body, params, n_g
        self.rest = [v for v, _ in garment_arrays]  # as they came (lifted off the body: body_lift), for the body guard
        self.fitted = list(self.rest)  # as they came, always
        self.verts = [v.copy() for v, _ in garment_arrays]
        self.faces = [f for _, f in garment_arrays]
        self.normals, self.probe_len, self.junction_parts = prep.normals, prep.probe_len, prep.junction_parts
        self.active = prep.active
        # Faces never change, so each garment's edges, hem points and adjacency are found once,
        # and kept for the next frame of the same garments.
        self.topo, self.edges, self.hems, self.layouts, self.scenes, self.clearance, self.unbounded = (
            [None] * n_g for _ in range(7))
        for i in self.active:
            self.topo[i] = topology_of(self.faces[i], len(self.verts[i]), key=prep.faces_key(i))
            self.edges[i], self.hems[i] = self.topo[i].edges, self.topo[i].hem_vertices
            self.layouts[i] = LayerLayout(self.faces[i], face_segment(self.faces[i], prep.vseg[i]), params.links)
            self.scenes[i] = SegmentScenes(self.verts[i], self.layouts[i], prep.content(i))
        self.rays = {"boundary": 0, "push": 0, "hidden": 0}
        self._creases = {}
        self.moved_by = {"lift": 0, "boundary": 0, "push": 0, "room": 0, "relaxed": 0}
        # A lower bound on each vertex's distance from the body: the distance found at rest minus
        # every inward move since (distance is 1-Lipschitz). Unlike a ray along -n', it also sees
        # body parts beside the ray (a joint bulging next to a limb). Inside the body: no bound.
        for i in self.active:
            self.clearance[i] = prep.clearance[i]
        # A correspondence passed in may name body points from another frame (cloth slides over its
        # collider), whose distance only bounds the real one from above. There a vertex also keeps
        # no further than it can go along its -n' (every move goes that way) before it meets the
        # body, found when it is first about to move; what lies beside the ray the body guard sees.
        for i in self.active:
            self.unbounded[i] = np.full(len(self.verts[i]), params.correspondence[i] is not None)
        self.floor_clamped = 0
        # An edge between two vertices held at the floor bows into a curved body by its sagitta
        # e^2 / 8R; a tenth of the longest mean edge covers body radii down to 1.25 edges.
        self.chord = 0.1 * max((prep.mean_edge[i] for i in self.active if len(self.edges[i])), default=0.0)
        # Two garments tessellated apart cross between their vertices where they bend, unless the
        # gap covers how far each one's flat triangles bow off the smooth surface: the gap push and
        # tuck leave adds it (MakeHuman's clothes, 26 mm edges round a 6 cm leg: about 3 mm; without
        # it 0.2% of what shows was cut away by the hidden-face pass; flat cloth: nothing)
        self.tessellation = 2.0 * max((_bow(self.verts[i], self.edges[i], self.normals[i]) for i in self.active),
                                      default=0.0)
        self.gap = params.gap + self.tessellation
        self.built_before_moves = self.kept_before_moves = 0
        self.push_trace_s = 0.0
        self.backed_off = 0

    def above(self, k) -> list:
        """The garments worn over layer k that take part."""
        return [j for j in self.active if j > k]

    def guard_clearance(self, k) -> np.ndarray:
        """What the body guard may take for a lower bound on each vertex of layer k's distance from
        the body: its clearance where the body points were searched this frame, 0 where they came
        from another frame (a correspondence passed in: its distance bounds from above, and a bound
        along -n' misses a body part beside the ray, as the floor beside a sphere a sheet slid off)."""
        if self.params.correspondence[k] is not None:
            return np.zeros(len(self.verts[k]))
        return self.clearance[k]

    def floor(self, k) -> float:
        """How close layer k may come to the body: the chord allowance, then for each layer from
        the body out to k its share of d, d / (N+1) (N the garments that take part), and the
        tessellation allowance, so layers squeezed against the body keep their order with room
        enough not to cross between vertices."""
        # counted among the garments that take part: one that meets no other changes nobody's floor
        rank, count = self.active.index(k), len(self.active)
        return (self.tessellation + self.params.offset / (count + 1)) * (rank + 1) + self.chord

    def bound(self, k, idx) -> None:
        """Bound the clearance of vertices idx of layer k whose body points came from another frame
        by how far they can go along -n' before they meet the body (found once)."""
        unknown = np.unique(idx[self.unbounded[k][idx]])
        if len(unknown):
            along = self.body.scene.intersect(self.verts[k][unknown], -self.normals[k][unknown]).t
            self.clearance[k][unknown] = np.minimum(self.clearance[k][unknown], along)
            self.unbounded[k][unknown] = False

    def room_of(self, k, idx):
        """How far each vertex idx of layer k may still go inward."""
        self.bound(k, idx)
        return self.clearance[k][idx] - self.floor(k)

    def body_floor(self, k, idx, move):
        """Cap inward moves so layer k keeps (k+1) d / (N+1) plus the chord allowance in front
        of the body: layers squeezed against it compress their gaps instead of entering it."""
        room = self.room_of(k, idx)
        self.floor_clamped += int((room < move).sum())
        out = np.clip(np.minimum(move, room), 0.0, None)
        self.clearance[k][idx] -= out
        return out

    def creases(self, i):
        """Layer i's crease edges (core.geometry.topology.crease_edges) where it lies now, kept
        until it moves: the layers above the one being fitted are done moving."""
        if self._creases.get(i) is None:
            self._creases[i] = crease_edges(self.verts[i], self.topo[i])
        return self._creases[i]

    def moved(self, i, vertices):
        """Layer i now lies at ``vertices``: its scenes are built anew where it is."""
        self._creases[i] = None
        self.verts[i] = vertices
        self.built_before_moves += self.scenes[i].built
        self.kept_before_moves += self.scenes[i].kept
        self.scenes[i] = SegmentScenes(vertices, self.layouts[i])

    def scenes_built(self) -> int:
        return sum(self.scenes[i].built for i in self.active) + self.built_before_moves

    def scenes_kept(self) -> int:
        return sum(self.scenes[i].kept for i in self.active) + self.kept_before_moves


def _bow(vertices, edges, normals) -> float:
    """How far a garment's flat triangles bow off the smooth surface through its vertices, at
    most (the 90th percentile over its edges): an edge of length e whose ends' n' differ by the
    angle a spans an arc of radius e / a, and its sagitta is e a / 8."""
    if not len(edges):
        return 0.0
    a, b = edges[:, 0], edges[:, 1]
    length = np.linalg.norm(vertices[a] - vertices[b], axis=1)
    cos = np.clip(np.einsum("ij,ij->i", normals[a], normals[b]), -1.0, 1.0)
    return float(np.percentile(length * np.arccos(cos) / 8.0, 90))

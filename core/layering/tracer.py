"""The layer tracer: probe rays against the garment layers above (or below) them, each ray
meeting only the triangles of the body parts it may meet (thesis 4.4, Fig. 4.5), nearest or
farthest hit, past hits that face the other way. One Embree scene per layer serves every part."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..geometry.keys import digest
from ..geometry.vectors import box, norms, rows
from ..rays.scene import FEW_RAYS, RayScene, step_past_hit
from ..rays.scene_cache import kept_scene
from ..rays.scene_union import SceneUnion
from .probe_ties import grazing, on_edges


class LayerLayout:
    """What a layer's scenes need that moving its vertices does not change: each triangle's
    segment, which segments rays of each segment may meet, the corners grouped by segment."""

    def __init__(self, faces, face_segment, links):
        self.faces, self.face_segment, self.links = faces, face_segment, links
        self._groups = self._columns = None

    def groups(self):
        """(every triangle's corners, triangle by triangle grouped by segment; where each
        group's corners start; its segment)."""
        if self._groups is None:
            order = np.argsort(self.face_segment, kind="stable")
            seg = self.face_segment[order]
            starts = np.flatnonzero(np.r_[True, seg[1:] != seg[:-1]]) if len(seg) else np.zeros(0, np.int64)
            self._groups = rows(self.faces, order).ravel(), 3 * starts, seg[starts]
        return self._groups

    def columns(self):
        """Each corner's vertex ids, contiguous: a gather by a strided column is slower."""
        if self._columns is None:
            self._columns = [np.ascontiguousarray(self.faces[:, k]) for k in range(3)]
        return self._columns


# Cells in voxel_near's grid at most: a bigger grid costs more to mark than the cells save
_VOXEL_CELLS = 1 << 21


def voxel_near(centres, cell, points):
    """Which centres lie in a voxel (of side ``cell``) of some point, or next to one: all those
    within ``cell`` of a point, and some farther. A grid over the points' box, marked and grown
    by one voxel each way, is read at each centre (a gather, where hashing the voxels needs a
    sort); a cell too small for the grid to fit is taken larger, which only adds centres."""
    if not cell > 0:
        return np.zeros(len(centres), dtype=bool)
    p_lo, p_hi = box(points)
    spread = p_hi - p_lo
    cell = float(cell)
    while float(np.prod(np.floor(spread / cell) + 5)) > _VOXEL_CELLS:
        cell *= 2.0
    # the points' cells are 2.. at least two from the far end (one to grow into, one for round-off)
    base = p_lo - 2 * cell
    size = np.floor(spread / cell).astype(np.int64) + 5
    grid = np.zeros(tuple(size), dtype=bool)
    q = np.floor((points - base) / cell).astype(np.intp)
    grid[q[:, 0], q[:, 1], q[:, 2]] = True
    for axis in range(3):
        # in place: numpy buffers the overlapping slices, and the second shift of {i, i+1} is {i-1, i}
        lo, hi = [slice(None)] * 3, [slice(None)] * 3
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        grid[tuple(hi)] |= grid[tuple(lo)]
        grid[tuple(lo)] |= grid[tuple(hi)]
    flat = np.zeros(len(centres), dtype=np.intp)
    inside = np.ones(len(centres), dtype=bool)
    for axis in range(3):
        k = np.floor((centres[:, axis] - base[axis]) / cell)
        inside &= (k >= 0) & (k < size[axis])
        flat = flat * size[axis] + np.clip(k, 0, size[axis] - 1).astype(np.intp)
    return grid.ravel()[flat] & inside


class SegmentScenes:
    """One layer's Embree scene, built on first use, and the boxes of what each segment's rays
    may meet. One scene serves every segment: a ray's hits on triangles of a segment it may
    not meet are passed over (a few rays, near part borders), which costs far less than a
    BVH per segment, most of whose triangles several segments share."""

    def __init__(self, vertices, layout, key=None):
        """``key``: a digest of the layer's vertices and faces as they came, under which its scenes
        are kept between resolves (core.scene_cache); None once it has moved."""
        self.vertices, self.layout, self.key = vertices, layout, key
        self.faces, self.face_segment = layout.faces, layout.face_segment
        self._full = None
        self._bounds = None
        self._face_box = None
        self.built = self.kept = 0

    def _scene(self, faces, which):
        if self.key is None:
            self.built += 1
            return RayScene(self.vertices, faces, quality=FEW_RAYS)
        scene, was_kept = kept_scene((self.key, which), self.vertices, faces)
        self.kept += was_kept
        self.built += not was_kept
        return scene

    def built_full(self):
        """The scene over all of the layer's triangles if one was built, else None."""
        return self._full

    def full(self):
        """One scene over all of the layer's triangles."""
        if self._full is None:
            self._full = self._scene(self.faces, "all")
        return self._full

    def _face_boxes(self):
        if self._face_box is None:
            # corner by corner: a reduction over an axis of length 3 is several times slower
            a, b, c = (rows(self.vertices, corner) for corner in self.layout.columns())
            self._face_box = (np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c))
        return self._face_box

    def get_near(self, ids, points, reach):
        """(scene, ids): a scene over only those of the triangles ``ids`` within about ``reach``
        of some point (at least those: a voxel grid of that size decides), when that is under
        half of the layer (built for one use); else (the full scene, None: its own face
        numbers). None if none is near."""
        if not len(ids) or not len(points):
            return None
        # a sample of the triangles, from their own corners, decides first whether most of the
        # layer is near (hems of a short garment reach all of it): then the full scene, without
        # a box for every triangle
        every = max(1, len(ids) // 2048)
        if every > 1:
            corners = [rows(self.vertices, rows(column, ids[::every])) for column in self.layout.columns()]
            lo = np.minimum(np.minimum(*corners[:2]), corners[2])
            hi = np.maximum(np.maximum(*corners[:2]), corners[2])
            near = voxel_near(0.5 * (lo + hi), reach + 0.5 * float(norms(hi - lo).max()), points)
            if near.mean() * len(ids) > 0.6 * len(self.faces):
                return self.full(), None
        lo, hi = self._face_boxes()
        if len(ids) < len(self.faces):  # ids are sorted and distinct: fewer names a subset
            lo, hi = rows(lo, ids), rows(hi, ids)
        keep = voxel_near(0.5 * (lo + hi), reach + 0.5 * float(norms(hi - lo).max()), points)
        if not keep.any():
            return None
        if keep.sum() * 2 > len(self.faces) or self._full is not None:
            return self.full(), None
        ids = ids[keep]
        return self._scene(rows(self.faces, ids), digest(ids)), ids

    def bounds_overlap(self, segment, lo, hi):
        """Whether the box of the triangles rays of ``segment`` may meet overlaps lo..hi."""
        if self._bounds is None:
            # each part's own box once; a segment's is the union of its linked parts'
            self._bounds = np.full((len(self.layout.links), 2, 3), np.nan)
            corners, starts, seg = self.layout.groups()
            if len(corners):
                for axis in range(3):
                    at = self.vertices[:, axis][corners]
                    self._bounds[seg, 0, axis] = np.minimum.reduceat(at, starts)
                    self._bounds[seg, 1, axis] = np.maximum.reduceat(at, starts)
        boxes = self._bounds[self.layout.links[segment]]
        boxes = boxes[~np.isnan(boxes[:, 0, 0])]
        return bool(len(boxes)) and bool((boxes[:, 0].min(0) <= hi).all() and (boxes[:, 1].max(0) >= lo).all())


# Rays go on past hits that do not count (facing the other way, or on a part they may not
# meet) at most this many times.
_PASS_ROUNDS = 8


def _either_column(mask):
    """Rows of a 2-D bool array with any column set (any(axis=1) over short rows is 10-20x slower)."""
    out = mask[:, 0].copy()
    for k in range(1, mask.shape[1]):
        out |= mask[:, k]
    return out


def face_segment(faces, vertex_segment):
    if not len(faces):
        return np.zeros(0, dtype=np.int64)
    s = vertex_segment[faces]
    return np.where(s[:, 1] == s[:, 2], s[:, 1], s[:, 0])


@dataclass(frozen=True)
class Probes:
    """Rays to trace: from ``origins`` along unit ``directions`` up to ``max_dist``, each meeting
    only the triangles of its own segments (``segment``: (n,) or (n, 2), -1 for no second one);
    rays where ``skip`` (bool per ray, or None) holds are not traced."""

    origins: np.ndarray
    directions: np.ndarray
    max_dist: np.ndarray
    segment: np.ndarray
    skip: np.ndarray | None = None


@dataclass(frozen=True)
class HitRules:
    """Which hit counts. ``farthest``: the farthest within reach, not the nearest. ``cull``: only
    triangles within reach of the origins go into the scene (rays bunched along a few lines,
    such as hems). ``facing`` = (global normals per layer, per-ray normals): a hit counts only
    where the layer's interpolated global normal points the ray's way (the far side of a skirt,
    met through the gap between the legs, is not in front of the near side). ``creases`` = (per
    layer its crease edges as sorted vertex pairs or None, a distance per ray): a hit that close
    to a crease meets nothing there, the ray passes on (a tie float32 decides by round-off, see
    probe_ties.off_the_lines, decided the same way every time instead)."""

    farthest: bool = False
    cull: bool = False
    facing: tuple | None = None
    creases: tuple | None = None


@dataclass
class Traced:
    """Per ray the counted hit's distance, layer index (-1: none) and face index within that
    layer; rays traced and seconds tracing."""

    t: np.ndarray
    layer: np.ndarray
    face: np.ndarray
    rays: int = 0
    seconds: float = 0.0


def trace_layers(probes: Probes, layer_scenes, layers, rules: HitRules = HitRules()) -> Traced:
    """Each probe's nearest (or farthest) hit on the given layers by ``rules``: rays of segments
    whose triangles' bounds are out of their reach skip a layer; rays go on past hits that do
    not count and past triangles of segments they may not meet (a ray exactly through an edge
    between such a triangle and one it may meet misses both: measure zero, unlike a BVH per
    segment)."""
    n = len(probes.origins)
    out = Traced(np.full(n, -np.inf if rules.farthest else np.inf), np.full(n, -1), np.full(n, -1))
    segs = np.asarray(probes.segment).reshape(n, -1)  # a second column: the border segment, -1 for none
    if probes.skip is not None:
        segs = np.where(probes.skip[:, None], -1, segs)
    layers = list(layers)
    if not (segs >= 0).any() or not layers:
        return out
    allowed, plan = _plan(probes, segs, layer_scenes, layers)
    if not rules.cull and len(plan) > 1:
        t0 = time.perf_counter()
        meets, asked = _meeting_any(probes.origins, probes.directions, probes.max_dist, plan, layer_scenes)
        out.seconds += time.perf_counter() - t0
        out.rays += asked
        if meets is not None:
            plan = [(k, idx[meets[idx]], lo, hi) for k, idx, lo, hi in plan]
    tracing = _Tracing(probes, allowed, rules, out)
    for k, idx, lo, hi in plan:
        if len(idx):
            tracing.layer(layer_scenes[k], k, idx, (lo, hi))
    return out


def _plan(probes, segs, layer_scenes, layers):
    """Per ray the face segments it may meet (its own segments' links), and per layer (k, the
    rays of every segment whose triangles' box is within those rays' reach, their box)."""
    origins, max_dist = probes.origins, probes.max_dist
    ray_segments = np.unique(segs[segs >= 0])
    links = layer_scenes[layers[0]].layout.links
    allowed = np.zeros((len(origins), len(links)), dtype=bool)
    rows_of, box_of = {}, {}
    for s in ray_segments:
        members = rows_of[s] = np.flatnonzero(_either_column(segs == s))
        allowed[members] |= links[s]
        reach = max_dist[members]
        box_of[s] = np.array([[(origins[members, a] - reach).min() for a in range(3)],
                              [(origins[members, a] + reach).max() for a in range(3)]])
    plan = []
    for k in layers:
        near = [s for s in ray_segments if layer_scenes[k].bounds_overlap(s, *box_of[s])]
        if near:
            boxes = np.array([box_of[s] for s in near])
            if len(near) == 1:
                idx = rows_of[near[0]]
            else:
                # a table lookup, where isin sorts every ray's segments; -1 (none) reads the last, False
                listed = np.zeros(len(links) + 1, dtype=bool)
                listed[near] = True
                idx = np.flatnonzero(_either_column(listed[segs]))
            plan.append((k, idx, boxes[:, 0].min(0), boxes[:, 1].max(0)))
    return allowed, plan


class _Tracing:
    """One trace_layers call: its probes, the face segments each may meet, its rules, and the best
    hits found so far (``out``)."""

    def __init__(self, probes, allowed, rules, out: Traced):
        self.probes, self.allowed, self.rules, self.out = probes, allowed, rules, out

    def layer(self, scenes, k, idx, bounds) -> None:
        """Rays ``idx`` against layer k's SegmentScenes (``bounds`` the box of their reach), past
        every hit that does not count, keeping in ``out`` each one's best hit so far."""
        probes, allowed, rules, out = self.probes, self.allowed, self.rules, self.out
        max_dist = probes.max_dist
        if rules.cull:
            found = scenes.get_near(np.flatnonzero(allowed[idx].any(0)[scenes.face_segment]), probes.origins[idx],
                                    float(max_dist[idx].max()))
        else:
            found = scenes.full(), None
        if found is None:
            return
        scene, ids = found
        scene.commit()  # the BVH build is not tracing
        o, ray_dir, length = rows(probes.origins, idx), rows(probes.directions, idx), max_dist[idx]
        if rules.farthest:
            # the farthest hit within reach is the first met coming back from the far end
            # (a fold of one layer has two sheets in reach: the vertex goes behind both)
            o, ray_dir = o + ray_dir * length[:, None], -ray_dir
        step = step_past_hit(length, *bounds)
        live, t_min = slice(None), np.zeros(len(idx))
        for _ in range(_PASS_ROUNDS):
            t0 = time.perf_counter()
            hits = scene.intersect(o[live], ray_dir[live], max_dist=length[live],
                                   min_dist=None if isinstance(live, slice) else t_min[live])
            out.seconds += time.perf_counter() - t0
            out.rays += len(hits.t)
            live = np.arange(len(idx)) if isinstance(live, slice) else live
            live, t_hit, face = live[hits.hit], hits.t[hits.hit], hits.face[hits.hit]
            if ids is not None:
                face = ids[face]
            ok = allowed[idx[live], scenes.face_segment[face]]
            corners = rows(scenes.faces, face) if rules.creases is not None or rules.facing is not None else None
            if rules.creases is not None and rules.creases[0][k] is not None and len(live):
                ok &= ~on_edges(scenes.vertices, corners, rules.creases[0][k],
                                o[live] + ray_dir[live] * t_hit[:, None], rules.creases[1][idx[live]])
            if rules.facing is not None and len(live):
                # a triangle the probe runs along (a Solidify rim, a fold seen edge-on) is not in
                # front of it: where along the rim the probe meets it is round-off, by millimetres
                ok &= ~grazing(scenes.vertices, corners, ray_dir[live])
                u, w = hits.bary[hits.hit, 0], hits.bary[hits.hit, 1]
                nk = rows(rules.facing[0][k], corners)
                n_hit = (1 - u - w)[:, None] * nk[:, 0] + u[:, None] * nk[:, 1] + w[:, None] * nk[:, 2]
                ok &= np.einsum("ij,ij->i", n_hit, rows(rules.facing[1], idx[live])) > 0
            t_ray = length[live] - t_hit if rules.farthest else t_hit
            better = ok & ((t_ray > out.t[idx[live]]) if rules.farthest else (t_ray < out.t[idx[live]]))
            sel = idx[live[better]]
            out.t[sel] = t_ray[better]
            out.layer[sel] = k
            out.face[sel] = face[better]
            # a hit facing the other way (the far side of a skirt) or on a part the ray may not
            # meet hides nothing: look past it
            t_min[live] = t_hit + step[live]
            live = live[~ok]
            if not len(live):
                break


# Rays asked first whether they meet anything at all, to learn whether that test pays
_SAMPLE_RAYS = 1024


def _meeting_any(origins, directions, max_dist, plan, layer_scenes):
    """(mask over all rays of those the plan asks that meet any triangle of its layers, rays
    traced). One occlusion test against all the layers at once: where most probes meet nothing
    (cloth already behind), those need no search on each layer for the hit that counts. Probes
    that mostly meet something that does not count (the far side of a sleeve, facing away)
    gain nothing from it: a sample decides first, and then the mask is None. The test reaches a
    little past both ends of each ray, so it misses nothing the search finds."""
    n = len(origins)
    asked = np.zeros(n, dtype=bool)
    for _, idx, _, _ in plan:
        asked[idx] = True
    asked = np.flatnonzero(asked)
    slack = step_past_hit(max_dist[asked], np.min([p[2] for p in plan], 0), np.max([p[3] for p in plan], 0))
    union = SceneUnion([layer_scenes[k].full() for k, *_ in plan])

    def meeting(ids, reach):
        return union.occluded(rows(origins, ids), rows(directions, ids), max_dist=max_dist[ids] + reach,
                              min_dist=-reach)

    every = max(1, len(asked) // _SAMPLE_RAYS)
    traced = 0
    if every > 1:
        traced = len(asked[::every])
        # the search on each layer costs about what this test does: it pays where most meet nothing
        if meeting(asked[::every], slack[::every]).mean() > 0.5:
            return None, traced
    out = np.zeros(n, dtype=bool)
    out[asked[meeting(asked, slack)]] = True
    return out, traced + len(asked)


__all__ = ["HitRules", "LayerLayout", "Probes", "SegmentScenes", "Traced", "face_segment", "trace_layers", "voxel_near"]

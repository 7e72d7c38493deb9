"""Resolve layered garments so lower layers stay behind higher ones (seed ch. 4, sections 4.3-4.4).

Stages, in the seed's order: correspondence and global normals (pre-processing), the
boundary pass (smooth tuck-in of lower layers under higher layers' hems, Fig. 4.10),
push-behind (layered ray tracing for mesh deformation), hidden-face removal (Fig. 4.14).
The middle two run layer by layer, outer to inner, so each layer is fitted to the higher
layers where they end up.
Inputs are never modified; every stage works on copies.
"""

from __future__ import annotations

import time

import numpy as np
import trimesh

from ..geometry.keys import digest
from ..geometry.topology import path_distance, topology_of
from ..geometry.vectors import box, norms, rows
from ..rays.scene import RayScene, SceneUnion, step_past_hit
from ..rays.scene_cache import kept_scene
from .body_facts import body_facts
from .body_guard import back_off
from .correspondence import BodyCorrespondence
from .garment_prep import GarmentPrep
from .gaussian_peak import largest_gaussian
from .hidden_faces import crossing_faces
from .segmentation import get_scheme


def _found_on_first_use(name, doc):
    """A LayeringResult attribute whose untraced garments' entries are found when first read."""
    def get(self):
        self._completed()
        return getattr(self, name)
    return property(get, doc=doc)


class LayeringResult:
    """What resolve_layers returns. ``garments``: corrected trimesh.Trimesh per garment, hidden
    faces left out; ``moved``: (n_i, 3) displacement per garment vertex; ``removed_faces``:
    (m_i,) bool per input face; ``traced``: per garment, whether it came near another garment
    (the rest cannot move or lose a face and skip every stage); ``stats``: counts and seconds.

    ``global_normals`` (the n' per garment vertex), ``correspondence`` (BodyCorrespondence per
    garment, rest pose) and ``segments`` (segment id per vertex) of garments whose box was far
    from every other garment's are found on first use: the body search they need is most of a
    resolve's time."""

    def __init__(self, garments, moved, removed_faces, traced, normals, correspondence, segments, skirts, stats,
                 complete):
        self.garments, self.moved, self.removed_faces, self.traced = garments, moved, removed_faces, traced
        self._normals, self._corr, self._segments, self._skirts = normals, correspondence, segments, skirts
        self.stats = stats
        self._complete = complete  # fills the untraced garments' entries in place

    def _completed(self):
        if self._complete is not None:
            self._complete()
            self._complete = None

    global_normals = _found_on_first_use("_normals", "(n_i, 3) the n' used per garment vertex")
    correspondence = _found_on_first_use("_corr", "BodyCorrespondence per garment (rest pose)")
    segments = _found_on_first_use("_segments", "(n_i,) segment id per garment vertex")

    @property
    def skirts(self) -> list:
        """Which garments are skirts (their hem goes round both legs), sorted; stats["skirts"]
        names those the resolve searched the body for."""
        self._completed()
        return sorted(self._skirts)

    def found(self) -> tuple[list, list]:
        """(global normals, correspondence) per garment as the resolve found them, with None for
        the garments whose body points it did not search, without searching for those: what a
        caller that reads the others (or passes the correspondence back next frame) needs."""
        return list(self._normals), list(self._corr)


def _mesh_arrays(mesh, name):
    if mesh is None:
        raise ValueError(f"{name} is missing")
    if not hasattr(mesh, "vertices") or not hasattr(mesh, "faces"):
        raise ValueError(f"{name} must be a trimesh.Trimesh (or have .vertices and .faces), got {type(mesh).__name__}")
    v = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    if not np.isfinite(v).all():
        raise ValueError(f"{name} has NaN or infinite vertex coordinates")
    if len(f) and (f.min() < 0 or f.max() >= len(v)):
        raise ValueError(f"{name} has faces that refer to vertices outside 0..{len(v) - 1}")
    return v, f


def _per_garment(value, n, name):
    if value is None:
        return [None] * n
    if len(value) != n:
        raise ValueError(f"{name} needs one entry per garment ({n}), got {len(value)}")
    return list(value)


class _LayerLayout:
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


# Cells in _voxel_near's grid at most: a bigger grid costs more to mark than the cells save
_VOXEL_CELLS = 1 << 21


def _voxel_near(centres, cell, points):
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
    # column by column: reductions over (n, 3) rows are slower
    flat = np.zeros(len(centres), dtype=np.intp)
    inside = np.ones(len(centres), dtype=bool)
    for axis in range(3):
        k = np.floor((centres[:, axis] - base[axis]) / cell)
        inside &= (k >= 0) & (k < size[axis])
        flat = flat * size[axis] + np.clip(k, 0, size[axis] - 1).astype(np.intp)
    return grid.ravel()[flat] & inside


class _SegmentScenes:
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
            return RayScene(self.vertices, faces)
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
            near = _voxel_near(0.5 * (lo + hi), reach + 0.5 * float(norms(hi - lo).max()), points)
            if near.mean() * len(ids) > 0.6 * len(self.faces):
                return self.full(), None
        lo, hi = self._face_boxes()
        if len(ids) < len(self.faces):  # ids are sorted and distinct: fewer names a subset
            lo, hi = rows(lo, ids), rows(hi, ids)
        keep = _voxel_near(0.5 * (lo + hi), reach + 0.5 * float(norms(hi - lo).max()), points)
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
                # column by column: a reduction over (n, 3) rows is slower
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
    """Rows of a 2-D bool array with any column set, column by column: any(axis=1) over short
    rows is 10-20x slower."""
    out = mask[:, 0].copy()
    for k in range(1, mask.shape[1]):
        out |= mask[:, k]
    return out


def _face_segment(faces, vertex_segment):
    if not len(faces):
        return np.zeros(0, dtype=np.int64)
    s = vertex_segment[faces]
    return np.where(s[:, 1] == s[:, 2], s[:, 1], s[:, 0])


def _trace_layers(origins, directions, max_dist, segment, layer_scenes, layers, farthest=False, cull=False,
                  facing=None, skip=None):
    """Each ray's nearest (or, with ``farthest``, farthest) hit on the given layers (triangles of
    the ray's own segments only: ``segment`` is (n,) or (n, 2) with -1 for no second one).

    Returns (t, layer index, face index within that layer, rays traced, seconds tracing);
    layer -1 where nothing was hit. Rays of segments whose triangles' bounds are out of
    their reach skip a layer; with ``cull`` only triangles within that reach of the origins
    go into the scene (for rays bunched along a few lines, such as hems). With ``facing`` =
    (global normals per layer, per-ray normals), a hit counts only where the layer's
    interpolated global normal points the ray's way: the far side of a skirt, met through
    the gap between the legs, is not in front of the near side. Rays go on past such hits,
    and past triangles of segments they may not meet (a ray exactly through an edge between
    such a triangle and one it may meet misses both: measure zero, unlike a BVH per segment).
    Rays where ``skip`` (bool per ray, or None) holds are not traced.
    """
    n = len(origins)
    best_t = np.full(n, -np.inf if farthest else np.inf)
    best_layer = np.full(n, -1)
    best_face = np.full(n, -1)
    rays = 0
    trace_s = 0.0
    segs = np.asarray(segment).reshape(n, -1)  # a second column: the border segment, -1 for none
    if skip is not None:
        segs = np.where(skip[:, None], -1, segs)
    ray_segments = np.unique(segs[segs >= 0])
    layers = list(layers)
    if not len(ray_segments) or not layers:
        return best_t, best_layer, best_face, rays, trace_s
    links = layer_scenes[layers[0]].layout.links
    # per ray, the face segments it may meet: its own segments' links
    allowed = np.zeros((n, len(links)), dtype=bool)
    rows_of, box_of = {}, {}
    for s in ray_segments:
        members = rows_of[s] = np.flatnonzero(_either_column(segs == s))
        allowed[members] |= links[s]
        reach = max_dist[members]
        # column by column: a reduction over the long axis of an (n, 3) array is several times slower
        box_of[s] = np.array([[(origins[members, a] - reach).min() for a in range(3)],
                              [(origins[members, a] + reach).max() for a in range(3)]])
    plan = []
    for k in layers:
        # the rays of every segment whose triangles' box is within those rays' reach
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
    if not cull and len(plan) > 1:
        t0 = time.perf_counter()
        meets, asked = _meeting_any(origins, directions, max_dist, plan, layer_scenes)
        trace_s += time.perf_counter() - t0
        rays += asked
        if meets is not None:
            plan = [(k, idx[meets[idx]], lo, hi) for k, idx, lo, hi in plan]
    for k, idx, lo, hi in plan:
        if not len(idx):
            continue
        scenes = layer_scenes[k]
        if cull:
            found = scenes.get_near(np.flatnonzero(allowed[idx].any(0)[scenes.face_segment]), origins[idx],
                                    float(max_dist[idx].max()))
        else:
            found = scenes.full(), None
        if found is None:
            continue
        scene, ids = found
        scene.commit()  # the BVH build is not tracing
        o, ray_dir, length = rows(origins, idx), rows(directions, idx), max_dist[idx]
        if farthest:
            # the farthest hit within reach is the first met coming back from the far end
            # (a fold of one layer has two sheets in reach: the vertex goes behind both)
            o, ray_dir = o + ray_dir * length[:, None], -ray_dir
        step = step_past_hit(length, lo, hi)
        live, t_min = slice(None), np.zeros(len(idx))
        for _ in range(_PASS_ROUNDS):
            t0 = time.perf_counter()
            hits = scene.intersect(o[live], ray_dir[live], max_dist=length[live],
                                   min_dist=None if isinstance(live, slice) else t_min[live])
            trace_s += time.perf_counter() - t0
            rays += len(hits.t)
            live = np.arange(len(idx)) if isinstance(live, slice) else live
            live, t_hit, face = live[hits.hit], hits.t[hits.hit], hits.face[hits.hit]
            if ids is not None:
                face = ids[face]
            ok = allowed[idx[live], scenes.face_segment[face]]
            if facing is not None and len(live):
                u, w = hits.bary[hits.hit, 0], hits.bary[hits.hit, 1]
                nk = rows(facing[0][k], rows(scenes.faces, face))
                n_hit = (1 - u - w)[:, None] * nk[:, 0] + u[:, None] * nk[:, 1] + w[:, None] * nk[:, 2]
                ok &= np.einsum("ij,ij->i", n_hit, rows(facing[1], idx[live])) > 0
            t_ray = length[live] - t_hit if farthest else t_hit
            better = ok & ((t_ray > best_t[idx[live]]) if farthest else (t_ray < best_t[idx[live]]))
            sel = idx[live[better]]
            best_t[sel] = t_ray[better]
            best_layer[sel] = k
            best_face[sel] = face[better]
            # a hit facing the other way (the far side of a skirt) or on a part the ray may not
            # meet hides nothing: look past it
            t_min[live] = t_hit + step[live]
            live = live[~ok]
            if not len(live):
                break
    return best_t, best_layer, best_face, rays, trace_s


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


def _spread_from_hits(vertices, faces, topology, hit_points, amplitude, seed_vertices, falloff=None):
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


def _shell_gap(shells, n_garments) -> float:
    """What the gap between layers must add for the outward shells given (see resolve_layers)."""
    if shells is None:
        return 0.0
    shells = np.asarray(shells, dtype=np.float64)
    if shells.shape != (n_garments,) or not np.isfinite(shells).all() or (shells < 0).any():
        raise ValueError(f"outward_shells must be {n_garments} finite thicknesses >= 0, got {shells.tolist()}")
    return float(shells[:-1].max(initial=0.0))


def resolve_layers(body, garments, body_segments=None, **params) -> LayeringResult:
    """Move lower garment layers behind higher ones and drop triangles that still show through.

    body, garments: trimesh.Trimesh in world space, garments ordered inner to outer. A
        garment that comes near no other (see LayeringResult.traced) is returned as it is
        without any work, the body search included. What a resolve finds for a garment
        before moving anything (body points, global normals, parts) is kept with the body's
        facts under the content of all it came from: resolving the same garments again with
        another offset, falloff or stage switch skips it (stats["garments_kept"]), and the
        ray scenes of the garments as they came are kept too (core.scene_cache,
        stats["scenes_kept"]): a layer nothing moves builds no BVH the next time.
    body_segments: optional int per body vertex (body part ids); garment vertices take
        the part of their nearest body point and only meet triangles of the same part.
        Without it, each connected piece of the body mesh is a part.
    params:
        offset (d, scene units): gap left behind a higher layer; default 0.1% of the
            body's bounding-box diagonal (about 2 mm on a 1.8 m figure).
        probe_distance (l_s): scalar, or one value per segment id (NaN: that part's
            default). Default: with
            body_segments, each part's median local radius (half the chord through the
            body); without, the local radius at each garment vertex's nearest body point.
        scheme: "S5", "S13" or a segmentation.Scheme naming the body_segments ids. With it, a
            garment whose hem goes round both legs (skirt, dress) has its leg points put in the
            skirt segment, traced against the torso and both legs, with normals from the
            convex hull of those parts.
        segment_links: (S, S) bool, which segments' triangles each segment's rays meet;
            default each segment itself (and the skirt links of the scheme); True links all.
        garment_segments: list of per-vertex segment arrays (or None) overriding the nearest-body rule.
        global_normals: list of per-vertex (n,3) arrays (or None) overriding the body's normals.
        correspondence: list of BodyCorrespondence (or None) from an earlier call on the same
            garment topology (e.g. the rest pose), reused instead of searching again.
        segment_margin: garment points within sqrt(2) times their body distance plus this
            much of a place where their part meets another (a junction on the body) also trace
            against that part; default 1% of the body's diagonal (about 2 cm on a person), 0 for strict parts.
        boundary_pass, push_behind, body_guard, remove_hidden: bool stages, all on by default.
            The body guard takes back moves that put cloth through the body (core.body_guard):
            a body with no sharp edges (a smooth scan) rarely needs it.
        falloff: Gaussian radius c of the boundary pass's spread, scene units; default
            4 mean edge lengths of the lower layer.
        outward_shells: per garment, how far it grows outward after the resolve (scene units;
            a Solidify that runs after the correction): the gap d grows by the thickest of a
            lower layer's, so no shell shows through the next layer. A shell grown inward needs
            no room: it lies behind its own garment's surface, which hides what it crosses
            (measured on Fig 4.13 with 1 cm Solidify after Subdivision: making room for inward
            shells too pushes the layers against the body and doubles poke-through).
    """
    t_start = time.perf_counter()
    timings = {}
    known = {"offset", "probe_distance", "garment_segments", "global_normals", "boundary_pass", "push_behind",
             "body_guard", "remove_hidden", "falloff", "scheme", "segment_links", "correspondence", "segment_margin",
             "outward_shells"}
    unknown = set(params) - known
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; known: {sorted(known)}")
    bv, bf = _mesh_arrays(body, "body")
    if not len(bf):
        raise ValueError("body has no faces: the garments need a body surface to take normals from")
    if garments is None or isinstance(garments, trimesh.Trimesh):
        raise ValueError("garments must be a list of meshes, inner to outer")
    garr = [_mesh_arrays(g, f"garments[{i}]") for i, g in enumerate(garments)]
    n_g = len(garr)
    body = body_facts(bv, bf)
    if body_segments is None:
        # Separate pieces of the body (a figure modelled as parts) are separate segments.
        body_seg = body.pieces
    else:
        body_seg = np.asarray(body_segments)
        if body_seg.shape != (len(bv),) or not np.issubdtype(body_seg.dtype, np.integer) or (body_seg < 0).any():
            raise ValueError(f"body_segments must be {len(bv)} non-negative integers, one per body vertex")
        body_seg = body_seg.astype(np.int64)
    g_segments_in = _per_garment(params.get("garment_segments"), n_g, "garment_segments")
    g_normals_in = _per_garment(params.get("global_normals"), n_g, "global_normals")
    g_corr_in = _per_garment(params.get("correspondence"), n_g, "correspondence")
    scheme = params.get("scheme")
    n_seg = int(body_seg.max()) + 1
    if scheme is not None:
        if body_segments is None:
            raise ValueError("a segmentation scheme names body part ids: pass body_segments with it")
        scheme = get_scheme(scheme)
        if n_seg > scheme.skirt:
            raise ValueError(f"body_segments of scheme {scheme.name} must be ids 0..{scheme.skirt - 1} "
                             f"({', '.join(scheme.parts[:-1])}); got up to {n_seg - 1}")
        n_seg = len(scheme.parts)
    links = params.get("segment_links")
    if links is None:
        links = scheme.links() if scheme is not None else np.eye(n_seg, dtype=bool)
    else:
        links = np.asarray(links, dtype=bool)
        if links.ndim == 0:  # True: every part meets every other (a whole body of separate pieces)
            links = np.full((n_seg, n_seg), bool(links))
        if links.shape != (n_seg, n_seg):
            raise ValueError(f"segment_links must be ({n_seg}, {n_seg}) booleans, got shape {links.shape}")
        links = links | links.T | np.eye(n_seg, dtype=bool)
    # every part meets every other: trace them as one (same hits, one batch per layer)
    one_part = scheme is None and bool(links.all())
    body_lo, body_hi = box(bv)
    diag = float(np.linalg.norm(body_hi - body_lo))
    if diag <= 0:
        raise ValueError("body has zero size")
    d = float(params.get("offset", 1e-3 * diag))
    if not np.isfinite(d) or d < 0:
        raise ValueError(f"offset must be a finite distance >= 0, got {d}")
    gap = d + _shell_gap(params.get("outward_shells"), n_g)  # what a lower layer keeps behind a higher one

    # --- pre-processing: correspondence, global normals, segments, probe distance
    t0 = time.perf_counter()
    probe = params.get("probe_distance")
    given = None if probe is None else np.broadcast_to(np.asarray(probe, dtype=np.float64), (n_seg,)).copy()
    if given is not None and (np.isinf(given).any() or (given < 0).any()):
        raise ValueError("probe_distance must be finite and >= 0 (NaN for a part's default)")
    if given is not None and np.isnan(given).all():
        given = None
    radius = body.radius if given is None or np.isnan(given).any() else None
    l_seg = given if radius is None else body.probe_lengths(body_seg, n_seg, links, given)
    # Without segments (one part) the probe distance follows the body locally: each garment
    # vertex takes the body's radius at its nearest point, so a sleeve probe stops inside the arm.
    local_probe = given is None and body_segments is None
    margin = float(params.get("segment_margin", 0.01 * diag))
    if not np.isfinite(margin) or margin < 0:
        raise ValueError(f"segment_margin must be a finite distance >= 0, got {margin}")
    junctions = (body.junctions(body_seg) if margin > 0 and len(np.unique(body_seg)) > 1 and not one_part
                 else (np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64)))
    for i, (v, _) in enumerate(garr):  # all given inputs checked now: the untraced are prepared later
        c = g_corr_in[i]
        if c is not None and (len(c.triangle) != len(v) or (len(c.triangle) and c.triangle.max() >= len(bf))):
            raise ValueError(f"correspondence[{i}] is for another mesh: {len(c.triangle)} points for "
                             f"{len(v)} vertices, or triangles beyond the body's {len(bf)}")
        n = g_normals_in[i]
        if n is not None and (np.shape(n) != v.shape or not np.isfinite(n).all()):
            raise ValueError(f"global_normals[{i}] must be finite with shape {v.shape}")
        s = g_segments_in[i]
        if s is not None and (np.shape(s) != (len(v),) or (len(s) and (np.min(s) < 0 or np.max(s) >= n_seg))):
            raise ValueError(f"garment_segments[{i}] must be {len(v)} ids in 0..{n_seg - 1}")
    prep = GarmentPrep(body, garr, body_seg, scheme, links, one_part, l_seg, radius, local_probe, junctions, margin,
                       gap, g_normals_in, g_segments_in, g_corr_in)
    corr, normals, vseg, vseg2, probe_len = prep.corr, prep.normals, prep.vseg, prep.vseg2, prep.probe_len
    traced, active = prep.traced, prep.active
    timings["correspondence_s"] = time.perf_counter() - t0

    verts = [v.copy() for v, _ in garr]
    faces = [f for _, f in garr]
    # Faces never change, so each garment's edges, hem points and adjacency are found once,
    # and kept for the next frame of the same garments.
    topo, edges, hems, layouts, scenes, clearance, unbounded = ([None] * n_g for _ in range(7))
    for i in active:
        topo[i] = topology_of(faces[i], len(verts[i]), key=prep.faces_key(i))
        edges[i], hems[i] = topo[i].edges, topo[i].hem_vertices
        layouts[i] = _LayerLayout(faces[i], _face_segment(faces[i], vseg[i]), links)
        scenes[i] = _SegmentScenes(verts[i], layouts[i], prep.content(i))
    rays = {"boundary": 0, "push": 0, "hidden": 0}
    moved_by = {"boundary": 0, "push": 0}

    # A lower bound on each vertex's distance from the body: the distance found at rest minus
    # every inward move since (distance is 1-Lipschitz). Unlike a ray along -n', it also sees
    # body parts beside the ray (a joint bulging next to a limb). Inside the body: no bound.
    for i in active:
        clearance[i] = prep.clearance[i]
    # A correspondence passed in may name body points from another frame (cloth slides over its
    # collider), whose distance only bounds the real one from above. There a vertex also keeps
    # no further than it can go along its -n' (every move goes that way) before it meets the
    # body, found when it is first about to move; what lies beside the ray the body guard sees.
    for i in active:
        unbounded[i] = np.full(len(verts[i]), g_corr_in[i] is not None)
    floor_clamped = 0
    # An edge between two vertices held at the floor bows into a curved body by its sagitta
    # e^2 / 8R; a tenth of the longest mean edge covers body radii down to 1.25 edges.
    chord = 0.1 * max((prep.mean_edge[i] for i in active if len(edges[i])), default=0.0)

    def room_of(k, idx):
        """How far each vertex idx of layer k may still go inward."""
        unknown = np.unique(idx[unbounded[k][idx]])
        if len(unknown):
            along = body.scene.intersect(verts[k][unknown], -normals[k][unknown]).t
            clearance[k][unknown] = np.minimum(clearance[k][unknown], along)
            unbounded[k][unknown] = False
        return clearance[k][idx] - d * (k + 1) / (n_g + 1) - chord

    def body_floor(k, idx, move):
        """Cap inward moves so layer k keeps (k+1) d / (N+1) plus the chord allowance in front
        of the body: layers squeezed against it compress their gaps instead of entering it."""
        nonlocal floor_clamped
        room = room_of(k, idx)
        floor_clamped += int((room < move).sum())
        out = np.clip(np.minimum(move, room), 0.0, None)
        clearance[k][idx] -= out
        return out

    built_before_moves = kept_before_moves = 0

    def refresh(i):
        nonlocal built_before_moves, kept_before_moves
        built_before_moves += scenes[i].built
        kept_before_moves += scenes[i].kept
        scenes[i] = _SegmentScenes(verts[i], layouts[i])

    def tuck_under_hems(k):
        """Boundary pass (Fig. 4.10): higher layers' hem points look outward for layer k."""
        v, f = verts[k], faces[k]
        up = [j for j in active if j > k]
        o = np.concatenate([verts[j][hems[j]] for j in up]) if up else np.zeros((0, 3))
        if not len(f) or not len(o):
            return
        # every higher layer's hem points at once: one scene of this layer near the hems
        n_o = np.concatenate([normals[j][hems[j]] for j in up])
        t, layer, face, r, _ = _trace_layers(o, n_o, np.concatenate([probe_len[j][hems[j]] for j in up]),
                                             np.concatenate([vseg2[j][hems[j]] for j in up]), scenes, [k],
                                             cull=True, facing=(normals, n_o))
        rays["boundary"] += r
        hit = layer == k
        if not hit.any():
            return
        # A hit goes no deeper than the body lets its triangle go: where the body holds the
        # layer, the cloth around the hit stays too (else each resolve of the result digs it in further)
        corners = f[face[hit]]
        room = room_of(k, corners).max(1)
        amp = np.clip(np.minimum(t[hit] + gap, room), 0.0, None)
        spread = _spread_from_hits(v, f, topo[k], o[hit] + n_o[hit] * t[hit, None], amp,
                                   corners.ravel(), params.get("falloff"))
        idx = np.flatnonzero(spread > 0)
        spread[idx] = body_floor(k, idx, spread[idx])
        verts[k] = v - normals[k] * spread[:, None]
        moved_by["boundary"] += int((spread > 0).sum())
        refresh(k)

    def push_behind(k):
        """Push-behind: every vertex of layer k behind the higher layers its probe meets."""
        nonlocal push_trace_s
        v = verts[k]
        if not len(v):
            return
        # Probes start the gap outside the vertex, so a vertex less than that behind a higher
        # layer is caught too: a hit at t means the layer is (t - gap) behind, and moving by t
        # leaves exactly the gap. Behind the farthest higher layer within reach, not the nearest.
        t, layer, _, r, secs = _trace_layers(v + normals[k] * gap, -normals[k], probe_len[k] + gap, vseg2[k],
                                             scenes, [j for j in active if j > k], farthest=True,
                                             facing=(normals, normals[k]), skip=topo[k].loose)
        rays["push"] += r
        push_trace_s += secs
        hit = layer >= 0
        if hit.any():
            idx = np.flatnonzero(hit)
            t[idx] = body_floor(k, idx, t[idx])
            verts[k] = v.copy()
            verts[k][hit] -= normals[k][hit] * t[hit, None]
            moved_by["push"] += int(hit.sum())
            refresh(k)

    # Outer to inner, each lower layer is tucked under, then pushed behind, higher layers where
    # they end up: a higher layer moved after a lower one was fitted to it would undo the fit.
    push_trace_s = 0.0
    timings["boundary_pass_s"] = timings["push_behind_s"] = timings["body_guard_s"] = 0.0
    backed_off = 0
    for k in active[-2::-1]:
        t0 = time.perf_counter()
        if params.get("boundary_pass", True):
            tuck_under_hems(k)
        t1 = time.perf_counter()
        if params.get("push_behind", True):
            push_behind(k)
        t2 = time.perf_counter()
        if params.get("body_guard", True):
            # where the moves put cloth through the body, they are taken back (before the layers
            # under this one are fitted to it); a correspondence passed in bounds no distance
            # from below, so there every moved triangle is asked. The layer's scene serves the
            # layers under it next: built here, it is not built twice.
            near = np.zeros(len(verts[k])) if g_corr_in[k] is not None else clearance[k]
            kept_out, n_back = back_off(body.scene, bv, body.edges, garr[k][0], verts[k], faces[k], edges[k],
                                        near, scenes[k].full)
            if n_back:
                verts[k] = kept_out
                backed_off += n_back
                refresh(k)
        timings["boundary_pass_s"] += t1 - t0
        timings["push_behind_s"] += t2 - t1
        timings["body_guard_s"] += time.perf_counter() - t2

    # --- hidden-face removal (Fig. 4.14): triangles still crossing a higher layer
    t0 = time.perf_counter()
    removed = [np.zeros(len(f), dtype=bool) for f in faces]
    if params.get("remove_hidden", True):
        # a layer's last scene is over where it ended up (each move builds anew): traced again here
        built = [scenes[i].built_full() if scenes[i].vertices is verts[i] else None for i in active]
        masks, rays["hidden"] = crossing_faces([verts[i] for i in active], [faces[i] for i in active],
                                               [edges[i] for i in active], built)
        for i, mask in zip(active, masks, strict=True):
            removed[i] = mask
    timings["hidden_faces_s"] = time.perf_counter() - t0

    out, moved = [], []
    for i, (v0, _) in enumerate(garr):
        moved.append(verts[i] - v0)
        kept_faces = faces[i][~removed[i]] if removed[i].any() else faces[i].copy()  # a mask's gather is slower
        out.append(trimesh.Trimesh(verts[i], kept_faces, process=False, validate=False))
    timings["total_s"] = time.perf_counter() - t_start
    stats = {
        **timings,
        "garments": n_g,
        "segments": n_seg,
        "segments_traced": 1 if one_part else n_seg,
        "scheme": scheme.name if scheme is not None else None,
        "skirts": list(prep.skirts),
        "offset": d,
        "probe_distance": l_seg.tolist(),
        "probe_distance_per_vertex": bool(local_probe),
        "rays_boundary": rays["boundary"],
        "rays_push": rays["push"],
        "push_trace_s": push_trace_s,
        "rays_hidden": rays["hidden"],
        "vertices_moved_boundary": moved_by["boundary"],
        "vertices_moved_push": moved_by["push"],
        "vertices_held_by_body": floor_clamped,
        "vertices_kept_out_of_body": backed_off,
        "faces_removed": int(sum(r.sum() for r in removed)),
        "vertices_far_from_body": prep.far,
        "vertices_on_part_borders": int(sum((vseg2[i][:, 1] >= 0).sum() for i in active)),
        "scenes_built": sum(scenes[i].built for i in active) + built_before_moves,
        "scenes_kept": sum(scenes[i].kept for i in active) + kept_before_moves,
        "garments_traced": len(active),
        "garments_kept": len(prep.reused),  # pre-processing found in an earlier resolve of the same garment
    }
    return LayeringResult(out, moved, removed, traced, normals, corr, vseg, prep.skirts, stats,
                          prep.complete if len(active) < n_g else None)


__all__ = ["BodyCorrespondence", "LayeringResult", "resolve_layers"]

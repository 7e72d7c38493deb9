"""Layered ray tracing for display (thesis 4.4): the first hit a camera ray should show.

A ray that meets layer n looks back along -n' (the global normal at the hit) for a higher
layer within the probe distance l_s. Finding one means the hit point pokes out of a garment
worn over it, so the hit is ignored and the ray goes on from there, until it meets a surface
no higher layer covers (or nothing). Nothing in the meshes changes: only what is shown.
"""

from dataclasses import dataclass

import numpy as np

from ..geometry.normals import vertex_normals
from ..geometry.vectors import box, rows, unit
from ..rays.scene import RayHits, RayScene, unit_rays
from .layered_shadows import ShadowRays

# a ray goes on past at most this many hits a higher layer covers
MAX_SKIPS = 16


@dataclass
class Visible:
    t: np.ndarray  # distance along the ray (inf: nothing)
    obj: np.ndarray  # object index (-1: nothing)
    face: np.ndarray  # face within its object
    bary: np.ndarray  # (u, v) on that face
    fixed: np.ndarray  # True where a probe ray changed what the ray shows
    skipped: int  # hits ignored


class LayeredScene(ShadowRays):
    """Objects (vertices, faces) with a layer each (None: not layered, e.g. props; 0: the
    body; 1, 2, ...: garments inner to outer) and global normals per vertex (default: the
    object's own vertex normals). ``probe_distance`` is l_s: one distance, or a list with one
    entry per object, each a distance per vertex (the body part's radius under a garment
    vertex, as the resolve takes it) or None for ``default_probe``."""

    def __init__(self, objects, layers, global_normals=None, probe_distance=0.05, offset=0.0, default_probe=0.05):
        if len(objects) != len(layers):
            raise ValueError(f"{len(objects)} objects but {len(layers)} layers")
        if not isinstance(probe_distance, (list, tuple)):
            probe_distance = [probe_distance] * len(objects)
        if len(probe_distance) != len(objects):
            raise ValueError(f"probe_distance needs one entry per object ({len(objects)}), got {len(probe_distance)}")
        self.vertices = [np.asarray(v, float).reshape(-1, 3) for v, _ in objects]
        self.probes = [np.full(len(v), default_probe if p is None else p, float) if p is None or np.ndim(p) == 0
                       else np.asarray(p, float) for v, p in zip(self.vertices, probe_distance, strict=True)]
        for v, p in zip(self.vertices, self.probes, strict=True):
            if p.shape != (len(v),) or not (np.isfinite(p) & (p >= 0)).all():
                raise ValueError(f"probe distances must be finite and >= 0, one per vertex: got shape {p.shape}")
        self.faces = [np.asarray(f, np.int64).reshape(-1, 3) for _, f in objects]
        self.layers = list(layers)
        self.shading_normals = [vertex_normals(v, f) for v, f in zip(self.vertices, self.faces, strict=True)]
        # all objects' shading normals indexed as the combined scene's vertices
        self.stacked_shading_normals = self.stack(self.shading_normals)
        normals = global_normals or [None] * len(objects)
        self.normals = [own if n is None else np.asarray(n, float)
                        for own, n in zip(self.shading_normals, normals, strict=True)]
        for v, n in zip(self.vertices, self.normals, strict=True):
            if n.shape != v.shape:
                raise ValueError(f"global normals must be one per vertex: {n.shape} for {v.shape}")
        self.offset = float(offset)
        self._stacked_probes = self.stack(self.probes)
        # global normal and l_s side by side: a probe blends both from one gather of its corners
        self._stacked_frames = (np.column_stack([self.stack(self.normals), self._stacked_probes])
                                if len(self._stacked_probes) else np.zeros((0, 4)))
        counts = np.array([len(f) for f in self.faces], dtype=np.int64)
        self.first_face = np.concatenate([[0], np.cumsum(counts)])
        all_v = np.vstack(self.vertices) if self.vertices else np.zeros((0, 3))
        all_f = _stack_faces(self.faces, [len(v) for v in self.vertices]) if self.faces else np.zeros((0, 3))
        self.scene = RayScene(all_v, all_f)
        self.face_object = np.repeat(np.arange(len(objects)), counts)
        self.size = 1.0
        if len(all_v):
            lo, hi = box(all_v)
            self.size = float(np.linalg.norm(hi - lo))
        self.eps = 1e-5 * max(self.size, 1e-12)  # above float32 round-off in Embree
        self.object_layer = np.array([-1 if lay is None else lay for lay in self.layers] + [-1])
        # per layer: the objects worn over it, their ray scene (built on first use: plain tracing
        # never needs it), the box they fill and how far a probe from the layer reaches
        self._cover_ids, self._layer_scenes, self._cover_box = {}, {}, {}
        for layer in sorted({lay for lay in self.layers if lay is not None}):
            ids = [i for i, lay in enumerate(self.layers) if lay is not None and lay > layer and len(self.faces[i])]
            if ids:
                self._cover_ids[layer] = ids
                cover = np.vstack(box(*(self.vertices[i] for i in ids)))
                reach = max((float(self.probes[i].max(initial=0.0)) for i, lay in enumerate(self.layers)
                             if lay == layer), default=0.0) + abs(self.offset)
                # the layer's own box inside that box grown by reach / sqrt(3) on every side lies
                # within reach of it everywhere: no hit on the layer needs the per-hit test
                own = [self.vertices[i] for i, lay in enumerate(self.layers) if lay == layer and len(self.vertices[i])]
                grown = (cover[0] - reach / np.sqrt(3), cover[1] + reach / np.sqrt(3))
                lo, hi = box(*own)
                inside = bool(own) and bool((lo >= grown[0]).all() and (hi <= grown[1]).all())
                self._cover_box[layer] = (cover, reach, inside)
        # per layer value (-1, a miss or an object outside the layering, last): is anything worn over it?
        top = max([lay for lay in self.layers if lay is not None], default=-1)
        self._has_cover = np.zeros(top + 2, bool)
        self._has_cover[list(self._cover_ids)] = True
        self._uncovered = None  # built on the first layered shadow ray
        self._past_pokes = {}  # per layer a shadow ray leaves: _poke_bounds
        self._seen_parts = {}  # per mask of objects camera rays pass through: _seen_part
        self._without = {}  # per mask of objects that cast no shadow: without

    def split(self, face):
        """Global face ids -> (object, face within it); -1 for both on a miss. Only the hits are
        looked up: most camera rays of a frame miss."""
        obj, local = np.full(len(face), -1), np.full(len(face), -1)
        hit = np.flatnonzero(face >= 0)
        if len(hit):
            f = face[hit]
            obj[hit] = self.face_object[f]
            local[hit] = f - self.first_face[obj[hit]]
        return obj, local

    def stack(self, per_vertex):
        """One array per object (a number or a vector per vertex) -> one array indexed as the
        combined scene's vertices, for ``interpolate``."""
        return np.concatenate(per_vertex) if per_vertex else np.zeros(0)

    def interpolate(self, stacked, obj, face, bary):
        """Per-vertex values (``stack``ed) at hit points, blended by barycentrics; 0 on misses.
        One gather over all objects at once: grouping the hits by object costs a sort."""
        hit = obj >= 0
        if not len(stacked):
            return np.zeros((len(obj), *np.shape(stacked)[1:]))
        corner = rows(self.scene.faces, np.where(hit, self.first_face[np.maximum(obj, 0)] + face, 0))
        shape = (-1, *([1] * (np.ndim(stacked) - 1)))
        u, v = bary[:, 0].reshape(shape), bary[:, 1].reshape(shape)
        # corner by corner, in place: (n, 3, ...) gathers of a frame's hits do not fit in cache
        out = (1 - u - v) * rows(stacked, corner[:, 0])
        out += u * rows(stacked, corner[:, 1])
        out += v * rows(stacked, corner[:, 2])
        out[~hit] = 0.0
        return out

    def probe_at(self, obj, face, bary):
        """l_s at hit points, blended from the objects' per-vertex probe distances."""
        return self.interpolate(self._stacked_probes, obj, face, bary)

    def _probe_frame(self, obj, face, bary):
        """(unit global normal, l_s) at hit points (all hits)."""
        frame = self.interpolate(self._stacked_frames, obj, face, bary)
        return unit(frame[:, :3]), frame[:, 3]

    def _scene_of(self, ids):
        """The combined scene's part over the given objects (hits name the combined scene's
        faces); each object's triangles are built once for all the parts that hold them."""
        return self.scene.part([(self.first_face[i], self.first_face[i + 1]) for i in ids])

    def _seen_part(self, unseen):
        """The combined scene's part over the objects not ``unseen`` (kept per mask)."""
        key = tuple(bool(x) for x in unseen)
        if len(key) != len(self.layers):
            raise ValueError(f"unseen needs one entry per object ({len(self.layers)}), got {len(key)}")
        if key not in self._seen_parts:
            self._seen_parts[key] = self._scene_of([i for i, hidden in enumerate(key) if not hidden])
        return self._seen_parts[key]

    def without(self, hidden):
        """(this scene without the ``hidden`` objects, the index of each object in it, -1 for the
        hidden and at the end for "no object"): what shadow rays meet when some objects cast
        none (Cycles' Ray Visibility > Shadow off). Kept per mask."""
        key = tuple(bool(x) for x in hidden)
        if len(key) != len(self.layers):
            raise ValueError(f"hidden needs one entry per object ({len(self.layers)}), got {len(key)}")
        if key not in self._without:
            keep = [i for i, h in enumerate(key) if not h]
            part = LayeredScene([(self.vertices[i], self.faces[i]) for i in keep], [self.layers[i] for i in keep],
                                [self.normals[i] for i in keep], [self.probes[i] for i in keep], self.offset)
            index = np.full(len(key) + 1, -1)
            index[keep] = np.arange(len(keep))
            self._without[key] = (part, index)
        return self._without[key]

    def _cover(self, layer):
        """The ray scene of what is worn over ``layer``."""
        if layer not in self._layer_scenes:
            self._layer_scenes[layer] = self._scene_of(self._cover_ids[layer])
        return self._layer_scenes[layer]

    def _uncovered_scene(self, rays):
        """A ray scene of the objects nothing is worn over; None when that is every object or
        none, or while fewer rays ask than it has triangles not yet built for a cover (building
        them would cost more than the rays it settles save)."""
        if self._uncovered is None:
            ids = [i for i, lay in enumerate(self.layers) if not self._has_cover[-1 if lay is None else lay]]
            built = {i for layer in self._layer_scenes for i in self._cover_ids[layer]}
            if not ids or len(ids) == len(self.layers):
                self._uncovered = False
            elif rays < sum(len(self.faces[i]) for i in ids if i not in built):
                return None
            else:
                self._uncovered = self._scene_of(ids)
        return self._uncovered or None

    def first_visible(self, origins, directions, layered=True, min_dist=0.0, scaled=False, unseen=None) -> Visible:
        """The hit each ray shows; with ``layered`` False, plain ray tracing. ``min_dist``
        skips what lies closer (a ray leaving a surface starts on it). ``scaled``: as in
        RayScene (distances in units of each direction's length), for callers whose rays are
        of length one already. ``unseen``: a bool per object these rays go through (an object
        hidden from the camera): they are traced against the others only, so a surface on one
        of those at the same place is still met."""
        trace = self.scene if unseen is None or not np.any(unseen) else self._seen_part(unseen)
        # of length one once: every later round goes on along these, traced as they are
        o, d = (np.asarray(origins, float), np.asarray(directions, float)) if scaled else unit_rays(origins, directions)
        return self._shown(trace, o, d, np.broadcast_to(np.asarray(min_dist, float), (len(o),)), layered)

    def shown_from(self, first: RayHits, o, d) -> Visible:
        """``first_visible`` (layered) of rays of length one whose first hits from their origins
        the caller has traced already."""
        return self._shown(self.scene, o, d, np.zeros(len(o)), True, first)

    def _shown(self, trace, o, d, lo, layered, first=None) -> Visible:
        """The hit each ray o + t d (t >= lo) shows, traced on ``trace``: past any hit a higher
        layer covers, for at most MAX_SKIPS of them (a ray still going on after that shows
        nothing); ``first``, its first hits if known."""
        n = len(o)
        if not n:
            return Visible(np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)),
                           np.zeros(0, bool), 0)
        result = None
        # Each round traces only the rays still going on past an ignored hit, as their own
        # compact arrays (``live``: which rays they are; None in the first round, all of them).
        live = None
        travelled = 0.0  # how far each live ray's origin has moved on
        cover = None  # (t, face, bary) of the covering layer met just behind an ignored hit
        for _ in range(MAX_SKIPS + 1):
            if first is not None:
                hits, first = first, None
            else:
                hits = trace.intersect(o, d, min_dist=lo, scaled=True)
            if cover is not None:
                # a covering layer closer than the skip distance (coincident layers) still counts
                nearer = np.flatnonzero(cover[0] < hits.t)
                if len(nearer):
                    hits.t[nearer], hits.face[nearer], hits.bary[nearer] = (x[nearer] for x in cover)
            obj, face = self.split(hits.face)
            rejected = np.zeros(len(o), bool)
            cover = None
            if layered and self._cover_ids:
                rejected, cover = self._rejected(o, d, hits, obj, face)
            again = np.flatnonzero(rejected)
            t = np.where(hits.face >= 0, hits.t + travelled, np.inf)
            if result is None:
                # the first round writes every ray at once (rays it ignores go on, and are
                # written over when they end; any still going after MAX_SKIPS show nothing)
                result = Visible(t, obj, face, hits.bary, np.zeros(n, bool), 0)
                if len(again):
                    result.t[again], result.obj[again], result.face[again], result.bary[again] = np.inf, -1, -1, 0.0
            else:
                shown = np.flatnonzero(~rejected)  # integer takes: boolean ones of (n, 2) rows are slower
                done = live[shown]
                result.t[done], result.obj[done], result.face[done] = t[shown], obj[shown], face[shown]
                result.bary[done] = hits.bary[shown]  # (0, 0) on a miss already
            if not len(again):
                break
            live = again if live is None else live[again]
            result.fixed[live] = True
            result.skipped += len(again)
            # go on from the ignored hit
            step = hits.t[again]
            d = rows(d, again)
            o = rows(o, again) + d * step[:, None]
            travelled = (travelled[again] if np.ndim(travelled) else travelled) + step
            lo = np.full(len(again), self.eps)
            if cover is not None:
                cover = tuple(rows(x, again) for x in cover)
        return result

    def _rejected(self, o, d, hits, obj, face):
        """(rejected, cover) for rays o + t d with ``hits``: which hits lie on a layer a higher
        one covers (the probe along -n' meets it within l_s), and per ray the covering layer
        just behind a rejected hit, closer than the next round's skip distance (t inf: none)."""
        rejected = np.zeros(len(o), bool)
        cover = None
        # hits on a layer something is worn over: one pass over the rays, then by layer
        layer_of = self.object_layer[obj]
        cand_all = np.flatnonzero(self._has_cover[layer_of])
        by_layer = layer_of[cand_all]
        for layer in self._cover_ids:
            cand = cand_all[by_layer == layer]
            if not len(cand):
                continue
            p = rows(o, cand) + rows(d, cand) * hits.t[cand, None]
            # a probe cannot reach what is worn over the layer from farther than its reach
            box, most, inside = self._cover_box[layer]
            if not inside:
                near = _box_distance(p, box) <= most
                if not near.all():
                    near = np.flatnonzero(near)
                    cand, p = cand[near], rows(p, near)
                    if not len(cand):
                        continue
            scene = self._cover(layer)
            g, reach = self._probe_frame(obj[cand], face[cand], rows(hits.bary, cand))
            # a probe from just outside: a higher layer at the same place is in front
            start = p + g * self.offset
            covered = scene.occluded(start, -g, max_dist=reach + self.offset, scaled=True)
            rejected[cand] = covered
            if not covered.any():
                continue
            at = np.flatnonzero(covered)
            c, dc = cand[at], rows(d, cand[at])
            # only a covering layer within the skip distance: the next round meets anything
            # farther. Short occlusion rays first, as layers rarely coincide.
            back = rows(p, at) - dc * self.eps
            close = scene.occluded(back, dc, max_dist=3 * self.eps, scaled=True)
            if close.any():
                close = np.flatnonzero(close)
                c, back, dc = c[close], rows(back, close), rows(dc, close)
                again_hits = scene.intersect(back, dc, max_dist=3 * self.eps, scaled=True)
                if cover is None:
                    cover = (np.full(len(o), np.inf), np.full(len(o), -1), np.zeros((len(o), 2)))
                cover[0][c] = np.where(again_hits.hit, np.maximum(again_hits.t - self.eps, 0.0), np.inf)
                cover[1][c] = again_hits.face
                cover[2][c] = again_hits.bary
        return rejected, cover


def _box_distance(points, box):
    """Distance from each point to an axis-aligned box (0 inside); column by column."""
    gap = [np.maximum(np.maximum(box[0, k] - points[:, k], points[:, k] - box[1, k]), 0.0) for k in range(3)]
    return np.sqrt(gap[0] ** 2 + gap[1] ** 2 + gap[2] ** 2)


def _stack_faces(faces, counts):
    """Faces of several objects indexing their stacked vertices."""
    base = np.concatenate([[0], np.cumsum(counts)[:-1]])
    return np.vstack([f + b for f, b in zip(faces, base, strict=True)])

"""What a resolve finds for each garment before it moves anything (thesis 4.3's pre-processing):
its body points, global normals n', parts and probe distances l_s, and which garments come near
another at all (the rest skip every stage, the body search too). What it finds is kept with the
body's facts under the content of everything it came from, so resolving the same garments again
(another offset, falloff or stage switch) skips it."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from ..geometry.keys import digest
from ..geometry.parallel import tree_workers
from ..geometry.topology import faces_key, topology_of
from ..geometry.vectors import box, norms, rows
from .body_facts import frozen
from .correspondence import BodyCorrespondence, closest_on_table, nearest_on_surface, nearest_within, triangle_table
from .probes import part_at, radius_at
from .segmentation import hull_normals, is_skirt, skirt_segments


class Prepared(NamedTuple):
    """What the pre-processing finds for one garment (kept for the next resolve as a read-only copy)."""

    corr: BodyCorrespondence
    clearance: np.ndarray  # a lower bound on each vertex's distance from the body (inf: inside it)
    normals: np.ndarray  # the global normals n'
    vseg: np.ndarray  # segment id per vertex
    junction_parts: np.ndarray  # (n, 2) segment and the part across a nearby junction (-1: none)
    probe_len: np.ndarray  # l_s per vertex
    skirt: bool
    far: int  # vertices farther from the body than their probe reaches
    mean_edge: float  # the garment's mean edge length




def _read_only_copy(entry: Prepared) -> Prepared:
    """A copy of ``entry`` to keep: read-only, so nothing handed out or passed in can change it."""
    c = entry.corr
    return entry._replace(corr=BodyCorrespondence(frozen(c.triangle), frozen(c.bary), frozen(c.distance),
                                                  None if c.checked is None else frozen(c.checked)),
                          **{f: frozen(getattr(entry, f))
                             for f in ("clearance", "normals", "vseg", "junction_parts", "probe_len")})


class GarmentPrep:
    """The pre-processing of one resolve of garments ``garment_arrays`` ((vertices, faces) each) on the
    BodyFacts ``body``. Per garment, filled as each is prepared (None before): ``corr``
    (BodyCorrespondence), ``clearance`` (a lower bound on each vertex's distance from the body:
    the distance to its body point, inf inside the body), ``normals`` (n'), ``vseg`` (segment per
    vertex), ``junction_parts`` (segment and the part across a nearby junction), ``probe_len`` (l_s per
    vertex), ``mean_edge`` (mean edge length). ``traced``: per garment whether it comes
    near another; ``active``: those, in order; ``skirts``, ``reused`` (found kept), ``far``
    (vertices farther from the body than their probe reaches). ``complete()`` prepares the
    garments the resolve did not trace, for a caller that reads them."""

    def __init__(self, body, garment_arrays, params, reach):
        """``params``: the resolve's LayeringParameters; ``reach``: its ProbeReach."""
        body_seg, scheme, links, one_part = params.body_segments, params.scheme, params.links, params.one_part
        l_seg, radius, local_probe, margin = reach.per_segment, reach.radius, reach.local, params.segment_margin
        given_normals, given_segments = params.global_normals, params.garment_segments
        given_corr = params.correspondence
        self.body, self.garment_arrays, self.body_seg, self.scheme = body, garment_arrays, body_seg, scheme
        self.one_part, self.l_seg, self.radius, self.local_probe = one_part, l_seg, radius, local_probe
        self.junctions, self.margin = reach.junctions, margin
        self.given_normals, self.given_segments, self.given_corr = given_normals, given_segments, given_corr
        self.gap = offset = params.gap  # a stage moves a vertex by at most l_s plus the gap
        n_g = len(garment_arrays)
        self.corr, self.normals, self.vseg, self.junction_parts, self.probe_len = ([None] * n_g for _ in range(5))
        self.clearance, self.mean_edge = [None] * n_g, [0.0] * n_g
        self.skirts, self.reused = [], []
        # A garment whose box, grown by three times what a stage can reach (a probe or hem ray's
        # l_s plus d, and two moves of at most that, its own or the other's), meets no other
        # garment's box can neither move nor lose a face: it skips every stage, the body search too.
        self.reach = reach = float(np.nanmax(radius if local_probe else l_seg, initial=0.0)) + offset
        self.traced = traced = near_another([box(v) for v, _ in garment_arrays], 3 * reach)
        # What prepare finds for a garment depends on nothing but these and the garment's own
        # arrays: resolving the same garments again (a setting changed) finds it kept on the body.
        self._stage_key = digest(body_seg, l_seg, links, np.array([local_probe, one_part, margin]),
                                 np.array(repr(scheme)))
        self._keys, self._held, self._contents, self._face_keys = {}, {}, {}, {}
        # Closer, before the body search: garments whose reach, bounded by the normals of the body
        # near them, meets no other's skip the search too (sleeves at separate heights). Not with a
        # scheme: a skirt takes its normals off a hull instead. A kept garment's normals are known:
        # the box from them decides after, as it does for the searched.
        searchable = [given_corr[i] is None and given_normals[i] is None
                      and not (traced[i] and self.kept(i) is not None) for i in range(n_g)]
        # garment -> its vertices' nearest body vertices, asked there for the search
        self._nearest = _apart_before_search(garment_arrays, traced, body, reach, searchable) if scheme is None else {}
        searched = [i for i in range(n_g) if traced[i]]
        found = self._search([i for i in searched if given_corr[i] is None and self.kept(i) is None])
        self.far = sum(self._prepare(i, found.get(i)) for i in searched)
        # With the normals known, closer: every move goes along a vertex's n' (at most two reaches
        # inward: tuck, then push) and every ray one reach more, in along -n' or out along n', so a
        # garment's triangles and rays stay in the box of v + R n' .. v - 3R n' over its vertices.
        # Garments whose such boxes meet no other's skip the stages too (sleeves at separate heights).
        swept = near_another([box(garment_arrays[i][0] + reach * self.normals[i],
                                  garment_arrays[i][0] - 3 * reach * self.normals[i]) for i in searched], 0.0)
        for i, near in zip(searched, swept, strict=True):
            traced[i] = near
        self.active = [i for i in searched if traced[i]]

    def _key(self, i):
        if i not in self._keys:
            given = (self.given_normals[i], self.given_segments[i], self.given_corr[i])
            c = self.given_corr[i]
            self._keys[i] = digest(np.frombuffer(self._stage_key, np.uint8), np.frombuffer(self.content(i), np.uint8),
                                   np.array([x is None for x in given]),
                                   *(np.asarray(x) for x in given[:2] if x is not None),
                                   *((c.triangle, c.bary) if c is not None else ()))
        return self._keys[i]

    def faces_key(self, i):
        """Garment i's faces_key (its faces are hashed once for its topology and its content)."""
        if i not in self._face_keys:
            self._face_keys[i] = faces_key(self.garment_arrays[i][1])
        return self._face_keys[i]

    def content(self, i):
        """A digest of garment i's vertices and faces as they came."""
        if i not in self._contents:
            self._contents[i] = digest(self.garment_arrays[i][0], np.frombuffer(self.faces_key(i), np.uint8))
        return self._contents[i]

    def kept(self, i):
        """Garment i's kept pre-processing, asked once: keeping another's may drop it after."""
        if i not in self._held:
            self._held[i] = self.body.prepared(self._key(i))
        return self._held[i]

    def _search(self, ids):
        """One body search for all of the garments ``ids`` (the body's kd-tree and fans made once)."""
        if not ids:
            return {}
        garment_arrays, body = self.garment_arrays, self.body
        known = np.vstack([self._nearest[i] for i in ids]) if all(i in self._nearest for i in ids) else None
        whole = nearest_on_surface(np.vstack([garment_arrays[i][0] for i in ids]), body.vertices, body.faces,
                                   search=body.search, near=known)
        start = np.cumsum([0] + [len(garment_arrays[i][0]) for i in ids])
        return {i: BodyCorrespondence(whole.triangle[a:b], whole.bary[a:b], whole.distance[a:b])
                for i, a, b in zip(ids, start[:-1], start[1:], strict=True)}

    def _prepare(self, i, c):
        """Garment i's correspondence c (None: searched), global normals, segments and probe
        lengths; returns its vertices farther from the body than their probe reaches."""
        entry = self.kept(i)
        if entry is None:
            entry = self._find(i, c)
            self.body.keep_prepared(self._key(i), _read_only_copy(entry))  # the result hands out entry's own
            self.corr[i], self.normals[i], self.vseg[i] = entry.corr, entry.normals, entry.vseg
        else:
            self.reused.append(i)
            # the caller's own copies of what the result hands out: the kept ones must not change
            kc = entry.corr
            self.corr[i] = BodyCorrespondence(kc.triangle.copy(), kc.bary.copy(), kc.distance.copy(),
                                              None if kc.checked is None else kc.checked.copy())
            self.normals[i], self.vseg[i] = entry.normals.copy(), entry.vseg.copy()
        self.junction_parts[i], self.probe_len[i] = entry.junction_parts, entry.probe_len
        self.clearance[i], self.mean_edge[i] = entry.clearance.copy(), entry.mean_edge
        if entry.skirt:
            self.skirts.append(i)
        return entry.far

    def _find(self, i, c):
        v, f = self.garment_arrays[i]
        body_vertices, body_faces, body_seg, scheme = self.body.vertices, self.body.faces, self.body_seg, self.scheme
        if self.given_corr[i] is not None:
            c = carried(self.given_corr[i], v, self.body, self.gap)
        at_body = c.normals(self.body.normals, body_faces) if len(v) else np.zeros((0, 3))
        if self.given_normals[i] is not None:
            n = np.asarray(self.given_normals[i], dtype=np.float64)
            n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        else:
            n = at_body
        skirt = False
        if self.given_segments[i] is not None:
            s = np.asarray(self.given_segments[i], dtype=np.int64)
            skirt = scheme is not None and bool((s == scheme.skirt).any())
        elif len(v):
            s, corner = part_at(c, body_faces, body_seg)
            if scheme is not None and is_skirt(f, s, scheme, vertices=v, body=(body_vertices, body_seg)):
                s = skirt_segments(s, scheme)
                skirt = True
        else:
            s = np.zeros(0, dtype=np.int64)
        if skirt:
            # the hull's normals for the whole skirt (torso points too: under the torso's
            # bottom its normals point down, not out of the skirt)
            on_skirt = np.isin(s, (scheme.skirt, scheme.torso))
            if self.given_normals[i] is None and on_skirt.any():
                n = n.copy()  # at_body keeps the body's own
                n[on_skirt] = hull_normals(body_vertices, body_seg, (scheme.torso, *scheme.skirt_spans), v[on_skirt])
        if self.local_probe and len(v):
            lv = radius_at(c, body_faces, self.radius)
        else:
            lv = self.l_seg[s]
        if self.one_part:
            s = np.zeros_like(s)
        border = np.full(len(v), -1)
        if len(self.junctions[0]) and self.given_segments[i] is None and len(v):
            # from the corner whose part the vertex took: no junction of that part is nearer than
            # the corner's own nearest less the corner's distance (the others are asked)
            lower = self.body.junction_distance(body_seg, corner) - norms(v - rows(body_vertices, corner))
            lower[s != body_seg[corner]] = 0.0
            border = border_segment(v, c.distance, s, self.junctions, self.margin, lower)
        far = int((c.distance > lv).sum()) if len(v) else 0
        # distance is 1-Lipschitz: the distance to the body point bounds the distance to the
        # body from below, unless the vertex is inside it (behind its body point's normal)
        outward = np.einsum("ij,ij->i", v - c.points(body_vertices, body_faces), at_body)
        clearance = np.where(outward < 0, np.inf, c.distance)
        e = topology_of(f, len(v), key=self.faces_key(i)).edges
        mean_edge = float(norms(rows(v, e[:, 0]) - rows(v, e[:, 1])).mean()) if len(e) else 0.0
        return Prepared(c, clearance, n, s, np.column_stack([s, border]), lv, skirt, far, mean_edge)

    def complete(self):
        """The entries of the garments not searched, for the result's first reader."""
        rest = [i for i in range(len(self.garment_arrays)) if self.corr[i] is None]
        found = self._search([i for i in rest if self.given_corr[i] is None and self.kept(i) is None])
        for i in rest:
            self._prepare(i, found.get(i))


# A carried body point is searched again once the cloth is DRIFT times farther from it than when
# it was last checked (and by a gap more): a leg swinging away from the cloth on the inner thigh
# of the other; or once the cloth lies off the point's normal by more than ASIDE. The nearest
# found then replaces it only when nearer by SWITCH, so a point between two body parts at about
# the same distance does not switch from frame to frame.
DRIFT = 1.25
SWITCH = 0.8
FEW = 256  # drifted points asked without the body's search structure
# ... as long as their bounds take in at most this many body vertices (point-vertex pairs): cloth
# on a skinned figure takes in up to 3,100; sheets falling 10-30 cm above the stage take in all
# of its vertices for every point (170,000-200,000 pairs, 100-800 ms a frame against 5-10 ms by
# the search structure)
WITHIN_PAIRS = 20_000
ASIDE = 0.7  # cos 45 degrees: off its body point's normal line by more is beside it


def carried(given, v, body, gap) -> BodyCorrespondence:
    """The body points ``given`` (found on an earlier frame of the same garment) where the body is
    now: the binding follows the body's deformation (posed, skinned, or cloth sliding over it).
    Where a point has drifted away (DRIFT), the body is searched again for those vertices alone
    and the nearer point taken (SWITCH); elsewhere the binding stays, so the normals and parts
    read through it change only as smoothly as the body moves."""
    body_vertices, body_faces = body.vertices, body.faces
    off = v - given.points(body_vertices, body_faces)
    d = norms(off)
    checked = np.array(given.checked_distance(), dtype=np.float64, copy=True)
    # drifted: farther than when last checked, or beside the point rather than over or under it (the
    # cloth slid along the body: its nearest point is elsewhere, and "behind the point's normal" would
    # read as inside the body)
    over = np.einsum("ij,ij->i", off, given.normals(body.normals, body_faces))
    drift = np.flatnonzero((d > np.maximum(DRIFT * checked, checked + gap)) | ((d > gap) & (np.abs(over) < ASIDE * d)))
    tri, bary = given.triangle, given.bary
    if len(drift):
        found = None
        if len(drift) <= FEW:  # the carried point bounds the nearest: no body search built this frame
            found = nearest_within(v[drift], d[drift], body_vertices, body_faces, body.vertex_faces, body.longest_edge,
                                   budget=WITHIN_PAIRS, tree=body.vertex_tree)
        if found is None:
            found = nearest_on_surface(v[drift], body_vertices, body_faces, search=body.search)
        take = found.distance < SWITCH * d[drift]
        tri, bary = tri.copy(), bary.copy()
        moved = drift[take]
        tri[moved], bary[moved], d[moved] = found.triangle[take], found.bary[take], found.distance[take]
        checked[drift] = d[drift]  # the kept ones are about the nearest now too
    return BodyCorrespondence(tri, bary, d, checked)


def near_another(boxes, grow):
    """Per box (low, high), whether it grown by ``grow`` meets another of them."""
    boxes = np.array(boxes).reshape(-1, 2, 3)
    if not len(boxes):
        return []
    lo, hi = boxes[:, 0] - grow, boxes[:, 1] + grow
    meet = ((lo[:, None] <= boxes[None, :, 1]) & (hi[:, None] >= boxes[None, :, 0])).all(2)
    np.fill_diagonal(meet, False)
    return [bool(x) for x in meet.any(1)]


def _swept_bound(v, near, nearest_distance, body, reach):
    """A box holding v + s n' (s from -3 reach to reach) for each of the points ``v`` and the
    global normal n' its body search will give it, before searching. The search picks a
    triangle around the point's nearest body vertices (``near``, the tree points) or a larger
    one nearer than the nearest vertex (``nearest_distance``), and n' is a blend of that
    triangle's corner normals made unit: the box follows the normals of all those triangles."""
    search = body.search
    picked = np.zeros(len(body.faces) + 1, dtype=bool)  # one more: the -1 padding lands there
    picked[search.incident[near].ravel()] = True
    lo, hi = box(v)
    if len(search.big):
        picked[_big_in_reach(v, nearest_distance, body)] = True
    tri = np.flatnonzero(picked[:-1])
    if not len(tri):
        return lo - 3 * reach, hi + 3 * reach
    corners = body.normals[body.faces[tri].ravel()]
    # a blend of unit vectors whose pairwise dot products are at least c is at least sqrt(c)
    # long, and each of its components lies between the corners' (and 0, for a blend of length 0)
    shortest = float(np.sqrt(max(float(body.normal_agreement[tri].min()), 0.0)))
    low, high = np.minimum(corners.min(0), 0.0), np.maximum(corners.max(0), 0.0)
    if shortest > 0:
        low, high = low / shortest, high / shortest
    else:
        low, high = np.full(3, -1.0), np.full(3, 1.0)
    # float64 barycentrics may stray past [0, 1] by round-off
    low, high = np.clip(low - 1e-9, -1.0, 1.0), np.clip(high + 1e-9, -1.0, 1.0)
    ends = np.array([reach * low, reach * high, -3 * reach * low, -3 * reach * high])
    return lo + ends.min(0), hi + ends.max(0)


def _apart_before_search(garment_arrays, traced, body, reach, searchable):
    """Before any body search, clears ``traced`` (in place) for the garments whose box of
    v + R n' .. v - 3R n' (R = ``reach``: every stage's moves and rays stay in it, see
    GarmentPrep), bounded by _swept_bound, meets no other's. A garment not ``searchable``
    (its correspondence or normals given) keeps the box of v grown by 3R. Returns the nearest
    body vertices asked on the way, per garment, for its search."""
    ids = [i for i in range(len(garment_arrays)) if traced[i]]
    ask = [i for i in ids if searchable[i] and len(garment_arrays[i][0])]
    # a garment whose own box meets another's is near it whatever its normals (the common case)
    if len(ids) < 2 or not ask or all(near_another([box(garment_arrays[i][0]) for i in ids], 0.0)):
        return {}
    asked = np.vstack([garment_arrays[i][0] for i in ask])
    dist, near = body.search.tree.query(asked, k=min(2, body.search.tree.n), workers=tree_workers(len(asked)))
    dist, near = np.reshape(dist, (len(near), -1)), np.reshape(near, (len(near), -1))
    start = np.cumsum([0] + [len(garment_arrays[i][0]) for i in ask])
    rows = {i: slice(a, b) for i, a, b in zip(ask, start[:-1], start[1:], strict=True)}
    boxes = []
    for i in ids:
        if i in rows:
            boxes.append(_swept_bound(garment_arrays[i][0], near[rows[i]], dist[rows[i], 0], body, reach))
        else:
            lo, hi = box(garment_arrays[i][0])
            boxes.append((lo - 3 * reach, hi + 3 * reach))
    for i, near_other in zip(ids, near_another(boxes, 0.0), strict=True):
        traced[i] = near_other
    return {i: near[r] for i, r in rows.items()}


def _big_in_reach(points, nearest_distance, body, budget=1_000_000):
    """The body's large triangles (SurfaceSearch.big) that some point is nearer to than to its
    nearest body vertex: the only ones the search can pick over the triangles around that vertex."""
    search = body.search
    size = float(np.ptp(body.vertices, 0).max())
    reach = nearest_distance * (1 + 1e-5) + 1e-5 * size  # float32 boxes and distances in the search
    big_lo = search.big_box[0].astype(np.float64) + search.centre
    big_hi = search.big_box[1].astype(np.float64) + search.centre
    lo, hi = points.min(0) - reach.max(initial=0.0), points.max(0) + reach.max(initial=0.0)
    near = np.flatnonzero(((big_lo <= hi) & (big_hi >= lo)).all(1))
    if not len(near):
        return near
    # the points whose box distance to some of these comes within their reach, pair by pair
    box_lo, box_hi = big_lo[near].min(0), big_hi[near].max(0)
    gap = norms(np.maximum(box_lo - points, 0) + np.maximum(points - box_hi, 0))
    ask = np.flatnonzero(gap <= reach)
    if len(ask) * len(near) > budget:  # too many pairs to weigh: every one of them may be picked
        return search.big[near]
    p, r = points[ask], reach[ask]
    g = np.maximum(big_lo[near][None] - p[:, None], 0) + np.maximum(p[:, None] - big_hi[near][None], 0)
    pi, ti = np.nonzero(np.einsum("ijk,ijk->ij", g, g) <= (r * r)[:, None])
    if not len(pi):
        return near[:0]
    faces = body.faces[search.big[near[ti]]]
    a, b, c = (rows(body.vertices, faces[:, k]) for k in range(3))
    d2 = closest_on_table(p[pi], triangle_table(a, b, c), bary=False)
    return np.unique(search.big[near[ti[d2 <= r[pi] ** 2]]])


def border_segment(points, distance, primary, junctions, margin, lower=None):
    """Per point, the other part at the nearest junction of its own part within sqrt(2) times
    its body distance plus ``margin``, else -1. Near a border between parts, a garment's triangles and
    the vertices of the layer below take different parts by a hair; their rays look in both.
    ``lower``: per point a lower bound on its distance to those junctions; points it puts out
    of reach are not searched."""
    out = np.full(len(points), -1)
    pos, own, other = junctions
    for part in np.unique(primary):
        mine = np.flatnonzero(primary == part)
        at = own == part
        if not at.any():
            continue
        # within 45 degrees of the junction as seen from the body: sqrt(2) times the distance
        reach = np.sqrt(2.0) * distance[mine] + margin
        bound = float(reach.max())
        if lower is not None:
            # round-off of the bound's two distances: far below any reach that matters
            ask = lower[mine] <= reach * (1 + 1e-9) + 1e-12 * bound
            mine, reach = mine[ask], reach[ask]
            if not len(mine):
                continue
        d, j = cKDTree(pos[at]).query(points[mine], distance_upper_bound=bound, workers=tree_workers(len(mine)))
        ok = d <= reach
        out[mine[ok]] = other[at][j[ok]]
    return out

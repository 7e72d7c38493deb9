"""Garment-to-body correspondence: nearest body surface point, global normals (thesis 4.3, Fig. 4.6).

The correspondence (body triangle + barycentrics per garment vertex) is found once at
rest; a posed body's normals are then read through it without searching again.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

try:
    import fcpw as _fcpw  # exact closest points (a BVH): bundled with the extension
except ImportError:  # pragma: no cover - the candidate search below stands in, nearly exact
    _fcpw = None

from ..geometry.normals import vertex_normals
from ..geometry.parallel import map_chunks, tree_workers
from ..geometry.topology import used_vertices
from ..geometry.vectors import box, cross, norms, rows, unit
from ..rays.scene import FEW_RAYS, RayScene


@dataclass
class BodyCorrespondence:
    triangle: np.ndarray  # (n,) body triangle nearest to each point
    bary: np.ndarray  # (n, 3) barycentric weights of the nearest point on it
    distance: np.ndarray  # (n,) distance to the body surface
    # (n,) the distance when each body point was last checked to be (about) the nearest; None:
    # ``distance`` is that (a fresh search). A point carried through the body's motion is
    # searched again when it drifts well past this (garment_prep.carried).
    checked: np.ndarray | None = None

    def checked_distance(self) -> np.ndarray:
        return self.distance if self.checked is None else self.checked

    def normals(self, body_vertex_normals: np.ndarray, body_faces: np.ndarray) -> np.ndarray:
        """Interpolated unit body normals at the corresponding points (the thesis' n')."""
        corners = rows(body_vertex_normals, rows(body_faces, self.triangle))  # (n, 3, 3)
        n = np.einsum("ij,ijk->ik", self.bary, corners)
        return unit(n)

    def points(self, body_vertices: np.ndarray, body_faces: np.ndarray) -> np.ndarray:
        return np.einsum("ij,ijk->ik", self.bary, rows(body_vertices, rows(body_faces, self.triangle)))


def triangle_table(a, b, c, dtype=np.float64) -> np.ndarray:
    """What a closest-point test needs of each triangle abc, worked out once: corner a, edges
    ab and ac, the unit normal, |ab|^2, |ac|^2, ab.ac and 1/det of the in-plane system
    (0 for a degenerate triangle). (n, 16)."""
    ab, ac = b - a, c - a
    bb, cc, bc = (np.einsum("ij,ij->i", x, y) for x, y in ((ab, ab), (ac, ac), (ab, ac)))
    det = bb * cc - bc * bc
    normal = unit(cross(ab, ac))
    # det is |ab x ac|^2: below a relative 1e-12 the in-plane solve is noise
    flat = det <= 1e-12 * bb * cc
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=~flat)
    return np.column_stack([a, ab, ac, normal, bb, cc, bc, inv]).astype(dtype, copy=False)


def closest_on_table(p, table, bary: bool = True):
    """Squared distance from each p to its row of ``triangle_table`` and, with ``bary``, the
    barycentric weights (n, 3) of the closest point.

    Everything comes from four dot products per pair: a point whose projection falls inside
    is as far as the plane; any other is nearest to one of the three edges, each a clamped
    segment projection. Degenerate triangles have no inside and fall to their edges; a
    triangle of one point to its corner a.
    """
    # column by column on contiguous copies: products of strided columns, or einsum over them,
    # are 2-4x slower than the copy and the products together
    c = np.ascontiguousarray(np.asarray(table).T)
    q = np.ascontiguousarray(np.asarray(p).T)
    ax, ay, az = q[0] - c[0], q[1] - c[1], q[2] - c[2]
    d1 = ax * c[3] + ay * c[4] + az * c[5]
    d2 = ax * c[6] + ay * c[7] + az * c[8]
    pp = ax * ax + ay * ay + az * az
    pn = ax * c[9] + ay * c[10] + az * c[11]
    bb, cc, bc, inv = c[12], c[13], c[14], c[15]
    s = (cc * d1 - bc * d2) * inv
    t = (bb * d2 - bc * d1) * inv
    inside = (s >= 0) & (t >= 0) & (s + t <= 1) & (inv > 0)
    ee = bb + cc - 2 * bc  # |bc|^2
    be = d2 - d1 - bc + bb  # (p - b).(c - b)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ab = np.clip(d1 / bb, 0, 1)
        t_ac = np.clip(d2 / cc, 0, 1)
        t_bc = np.clip(be / ee, 0, 1)
    # |p - (a + t e)|^2 = |ap|^2 - t (2 ap.e - t |e|^2), from corner b for edge bc
    e_ab = pp - t_ab * (2 * d1 - t_ab * bb)
    e_ac = pp - t_ac * (2 * d2 - t_ac * cc)
    e_bc = (pp - 2 * d1 + bb) - t_bc * (2 * be - t_bc * ee)
    # fmin passes over NaN: an edge of zero length, whose corners are another edge's
    d = np.where(inside, pn * pn, np.fmin(np.fmin(e_ab, e_ac), e_bc))
    lone = np.isnan(d)
    d[lone] = pp[lone]  # all three corners at a
    if not bary:
        return d
    edges = np.column_stack([e_ab, e_ac, e_bc])
    edges[np.isnan(edges)] = np.inf
    edge = np.argmin(edges, axis=1)
    wb = np.select([inside, edge == 0, edge == 1], [s, t_ab, 0.0], 1 - t_bc)
    wc = np.select([inside, edge == 0, edge == 1], [t, 0.0, t_ac], t_bc)
    wb[lone] = wc[lone] = 0.0
    return d, np.column_stack([1 - wb - wc, wb, wc])


def closest_point_on_triangles(p, a, b, c):
    """Closest point to p on triangle abc, all (n,3); returns barycentric weights (n,3)."""
    return closest_on_table(p, triangle_table(a, b, c))[1]


def incident_triangles(faces: np.ndarray, n_vertices: int, width: int) -> np.ndarray:
    """Up to ``width`` incident triangles per vertex, padded with -1."""
    order = np.argsort(faces.ravel(), kind="stable")
    verts = faces.ravel()[order]
    tris = order // 3
    start = np.searchsorted(verts, np.arange(n_vertices))
    rank = np.arange(len(verts)) - start[verts]
    keep = rank < width
    table = np.full((n_vertices, width), -1, dtype=np.int64)
    table[verts[keep], rank[keep]] = tris[keep]
    return table


class SurfaceSearch(NamedTuple):
    """What nearest_on_surface needs of a surface, made once per surface."""

    tree: cKDTree  # over the vertices some triangle uses
    vertex_ids: np.ndarray  # the surface vertex of each tree point
    incident: np.ndarray  # (tree points, ring_width) incident triangles, -1 padded
    table: np.ndarray  # float32 triangle_table about ``centre``: the candidates' first pick
    centre: np.ndarray
    big: np.ndarray  # triangles far larger than most, asked by every point their box is near
    big_box: np.ndarray  # (2, len(big), 3) float32 boxes about ``centre``
    exact: np.ndarray  # float64 triangle_table, in place: the pick solved again
    bvh: object = None  # fcpw's scene over the triangles (float32 about ``centre``), when installed


# Points per piece of the candidates' test: about 2 MB of float32 temporaries, what one core's
# cache holds (Fig 4.12's 102k points: 190 -> 130 ms; pieces of 512 pay numpy's per-call cost).
_SEARCH_BLOCK = 2048
# Points a thread takes at a time.
_CHUNK = 4096

# A triangle whose longest edge is this many times the median's is "big": a point can be nearest
# to it with none of its corners among the point's nearest vertices (a floor under a figure).
_BIG = 4.0


def vertex_tree(vertices) -> cKDTree:
    """A k-d tree of the vertices for nearest_within (built unbalanced: about twice as fast to
    build, as fast to ask, for a body's 10,000-odd vertices)."""
    return cKDTree(np.asarray(vertices, dtype=np.float64), balanced_tree=False, compact_nodes=False)


def surface_search(vertices, faces, ring_width: int = 8) -> SurfaceSearch:
    """The search structure of nearest_on_surface. A vertex of no triangle stays out: as a
    nearest vertex it would offer no candidate at all."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    ids = np.flatnonzero(used_vertices(faces, len(vertices)))
    incident = incident_triangles(faces, len(vertices), ring_width)[ids]
    # float32 about the surface's centre, so precision follows its size
    centre = 0.5 * np.add(*box(vertices)) if len(vertices) else np.zeros(3)
    tri = vertices[faces] - centre
    table = triangle_table(tri[:, 0], tri[:, 1], tri[:, 2], np.float32)
    longest = np.sqrt(np.max(table[:, 12:14], axis=1, initial=0.0))  # |ab|, |ac| (|bc| < their sum)
    big = np.flatnonzero(longest > _BIG * np.median(longest)) if len(faces) else np.zeros(0, np.int64)
    big_box = np.stack([tri[big].min(1), tri[big].max(1)]).astype(np.float32)
    exact = triangle_table(*(rows(vertices, faces[:, k]) for k in range(3)))
    return SurfaceSearch(cKDTree(vertices[ids]), ids, incident, table, centre, big, big_box, exact,
                         _bvh(vertices - centre, faces))


def _bvh(vertices, faces):
    """fcpw's BVH over the triangles, or None (no fcpw, or nothing to build)."""
    if _fcpw is None or not len(faces):
        return None
    scene = _fcpw.scene_3D()
    scene.set_object_count(1)
    scene.set_object_vertices(np.asfortranarray(vertices, dtype=np.float32), 0)
    scene.set_object_triangles(np.asfortranarray(faces, dtype=np.int32), 0)
    scene.build(_fcpw.aggregate_type.bvh_surface_area, True)
    return scene


def _exact_picks(search, points) -> np.ndarray:
    """The nearest triangle of each point by fcpw's BVH traversal: exact up to float32 about the
    surface's centre (two triangles nearer to a point than that apart are either answer)."""
    out = np.empty(len(points), dtype=np.int64)

    def run(sl):
        found = _fcpw.interaction_3D_list()
        query = np.asfortranarray(points[sl] - search.centre, dtype=np.float32)
        search.bvh.find_closest_points(query, np.full(len(query), np.inf, dtype=np.float32), found)
        out[sl] = np.fromiter((i.primitive_index for i in found), np.int64, len(found))

    map_chunks(run, len(points), 16384)
    return out


def _nearer_big(points32, best_d2, search, block: int = 512):
    """(better, triangle): points whose nearest "big" triangle is nearer than ``best_d2`` (squared),
    and which one. Only big triangles whose box is within reach are asked."""
    better = np.zeros(len(points32), dtype=bool)
    pick = np.zeros(len(points32), dtype=np.int64)
    best = best_d2.copy()
    rows = np.arange(len(points32))
    # first the boxes within reach of the points' box at all (a figure's caps far from its sleeves)
    reach = float(np.sqrt(best.max(initial=0.0)))
    p_lo, p_hi = (corner + step for corner, step in zip(box(points32), (-reach, reach), strict=True))
    ask = search.big_box[0] <= p_hi
    ask &= search.big_box[1] >= p_lo
    ask = np.flatnonzero(ask.all(1))
    for b0 in range(0, len(ask), block):
        which = ask[b0:b0 + block]
        lo, hi = search.big_box[0, which], search.big_box[1, which]
        gap = np.maximum(lo[None] - points32[:, None], 0) + np.maximum(points32[:, None] - hi[None], 0)
        pr, pc = np.nonzero(np.einsum("ijk,ijk->ij", gap, gap) < best[:, None])
        if not len(pr):
            continue
        d2 = np.full((len(points32), len(lo)), np.inf, dtype=np.float32)
        d2[pr, pc] = closest_on_table(points32[pr], search.table[search.big[which[pc]]], bary=False)
        j = np.argmin(d2, axis=1)
        win = d2[rows, j] < best
        best[win], pick[win], better[win] = d2[rows, j][win], search.big[which[j[win]]], True
    return better, pick


def nearest_on_surface(points, vertices, faces, search: SurfaceSearch | None = None, near=None,
                       k: int = 2) -> BodyCorrespondence:
    """Nearest point on a triangle surface for each point.

    With fcpw (bundled) the nearest triangle is found exactly by its BVH. Without, candidates
    are the triangles around the ``k`` nearest vertices (a kd-tree), which
    contains the true nearest triangle whenever it has a vertex among them: always, for
    surfaces whose triangles are small against the distance to the points' neighbours.
    Triangles far larger than most (a floor, a box's faces), which a point can be nearest to
    with none of their corners near it, are asked directly wherever their box is in reach.
    ``near``: the points' ``k`` nearest tree points (``search.tree.query``'s indices), when the
    caller has asked already.
    """
    points = np.asarray(points, dtype=np.float64)
    n = len(points)
    if not n:
        return BodyCorrespondence(np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0))
    if search is None:
        search = surface_search(vertices, faces)
    best_t = np.zeros(n, dtype=np.int64)
    best_w = np.zeros((n, 3))
    best_d = np.zeros(n)
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if search.bvh is not None:
        picks = _exact_picks(search, points)

        def solve(sl):  # the pick solved again in float64
            best_w[sl] = closest_on_table(points[sl], rows(search.exact, picks[sl]))[1]
            best_d[sl] = norms(points[sl] - np.einsum("ij,ijk->ik", best_w[sl], rows(vertices, rows(faces, picks[sl]))))

        map_chunks(solve, n, _CHUNK, block=_SEARCH_BLOCK)
        return BodyCorrespondence(picks, best_w, best_d)
    if near is None:
        _, near = search.tree.query(points, k=min(k, search.tree.n), workers=tree_workers(len(points)))
    near = np.asarray(near).reshape(n, -1)
    points32 = (points - search.centre).astype(np.float32)

    def run(sl):
        cand = rows(search.incident, near[sl]).reshape(sl.stop - sl.start, -1)  # (c, k * width), -1 padded
        real = cand >= 0
        owner = np.nonzero(real)[0]
        # pick in float32 over the real candidates only (half the memory traffic, no padding),
        # then solve the pick again in float64
        d = np.full(cand.shape, np.inf, dtype=np.float32)
        d[real] = closest_on_table(rows(points32[sl], owner), rows(search.table, cand[real]), bary=False)
        arg = np.argmin(d, axis=1)
        pick = np.maximum(cand[np.arange(len(d)), arg], 0)  # no triangle at all: triangle 0
        if len(search.big):
            better, big = _nearer_big(points32[sl], d[np.arange(len(d)), arg], search)
            pick[better] = big[better]
        tri = rows(vertices, rows(faces, pick))
        best_w[sl] = closest_on_table(points[sl], rows(search.exact, pick))[1]
        best_t[sl] = pick
        best_d[sl] = norms(points[sl] - np.einsum("ij,ijk->ik", best_w[sl], tri))

    # numpy releases the GIL on these array sizes: slices run side by side on the cores, each
    # in pieces whose (points x candidates) temporaries stay in its cache
    map_chunks(run, n, _CHUNK, block=_SEARCH_BLOCK)
    return BodyCorrespondence(best_t, best_w, best_d)


def nearest_within(points, bound, vertices, faces, vertex_faces, longest=None, budget=None, tree=None
                   ) -> BodyCorrespondence | None:
    """The exact nearest surface point of each of a few points whose nearest lies within
    ``bound`` (per point) of it: a body point carried from an earlier frame bounds it. Only the
    triangles with a corner within the bound plus the longest edge can hold it (every point of
    a triangle is within its longest edge of each corner): those corners come from a k-d tree of
    the vertices, and nearest_on_surface's search structure is not needed.
    ``vertex_faces``: MeshTopology.vertex_faces of ``faces``; ``longest``: the longest edge, when
    the caller knows it. ``budget``: the most point-corner pairs worth testing so; None is
    returned where the bounds take in more (a search structure is then cheaper). ``tree``:
    vertex_tree(vertices), when the caller keeps one (built here otherwise)."""
    points, vertices = np.asarray(points, dtype=np.float64), np.asarray(vertices, dtype=np.float64)
    n = len(points)
    if not n or not len(faces):
        return BodyCorrespondence(np.zeros(n, np.int64), np.zeros((n, 3)), np.full(n, np.inf))
    if longest is None:
        corners = [rows(vertices, faces[:, k]) for k in range(3)]
        longest = float(np.sqrt(max(((corners[a] - corners[b]) ** 2).sum(1).max()
                                    for a, b in ((0, 1), (1, 2), (0, 2)))))
    bound = np.asarray(bound, dtype=np.float64) * (1 + 1e-9)
    # the corners within reach, from a k-d tree: a (points x vertices) distance matrix is a matrix
    # product, which wakes the BLAS threads (they then spin on the other core for the rest of the frame)
    tree = vertex_tree(vertices) if tree is None else tree
    reach, workers = (bound + longest) * (1 + 1e-9) + 1e-9 * longest, tree_workers(n)
    # counted first: listing the pairs of cloth far above a body costs more (8 million: 280 ms, counted 70)
    if budget is not None and tree.query_ball_point(points, reach, return_length=True, workers=workers).sum() > budget:
        return None
    within = tree.query_ball_point(points, reach, return_sorted=False, workers=workers)
    counts = np.fromiter(map(len, within), np.int64, n)
    pi = np.repeat(np.arange(n), counts)
    vi = np.fromiter(itertools.chain.from_iterable(within), np.int64, int(counts.sum()))
    start, tris = vertex_faces
    counts = start[vi + 1] - start[vi]
    pair_point = np.repeat(pi, counts)
    offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    pair_tri = tris[np.repeat(start[vi], counts) + offsets]
    key = np.unique(pair_point * np.int64(len(faces)) + pair_tri)
    pair_point, pair_tri = key // len(faces), key % len(faces)
    corner = [rows(vertices, rows(faces[:, k], pair_tri)) for k in range(3)]
    # a triangle whose box is farther than the bound cannot hold the nearest point
    p = points[pair_point]
    gap = np.maximum(np.minimum(np.minimum(corner[0], corner[1]), corner[2]) - p, 0) + \
        np.maximum(p - np.maximum(np.maximum(corner[0], corner[1]), corner[2]), 0)
    near = np.einsum("ij,ij->i", gap, gap) <= bound[pair_point] ** 2 * (1 + 1e-9) + 1e-24
    pair_point, pair_tri, corner = pair_point[near], pair_tri[near], [c[near] for c in corner]
    table = triangle_table(*corner)
    dist2, bary = closest_on_table(points[pair_point], table)
    # per point its nearest pair (pairs come sorted by point)
    order = np.lexsort((dist2, pair_point))
    first = order[np.searchsorted(pair_point[order], np.arange(n))]
    return BodyCorrespondence(pair_tri[first], bary[first], np.sqrt(np.maximum(dist2[first], 0.0)))


def local_radius(vertices, faces, normals=None, scene: RayScene | None = None) -> np.ndarray:
    """Half the chord length straight through the body from each vertex (the thesis' l_s, per vertex).

    Rays go inward along -normal; a vertex whose ray finds nothing (open or odd geometry)
    takes the median of the rest.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    if normals is None:
        normals = vertex_normals(vertices, faces)
    scene = scene if scene is not None else RayScene(vertices, faces, quality=FEW_RAYS)
    size = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 1.0
    ok = np.linalg.norm(normals, axis=1) > 0
    radius = np.full(len(vertices), np.nan)
    if ok.any():
        hits = scene.intersect(vertices[ok], -normals[ok], min_dist=1e-6 * size)
        radius[ok] = np.where(hits.hit, 0.5 * hits.t, np.nan)
    fill = np.nanmedian(radius) if np.isfinite(radius).any() else 0.1 * size
    return np.where(np.isfinite(radius), radius, fill)

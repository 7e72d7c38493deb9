"""Garment-to-body correspondence: nearest body surface point, global normals (seed 4.3, Fig. 4.6).

The correspondence (body triangle + barycentrics per garment vertex) is found once at
rest; a posed body's normals are then read through it without searching again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .parallel import map_chunks
from .rays import RayScene
from .topology import used_vertices


@dataclass
class BodyCorrespondence:
    triangle: np.ndarray  # (n,) body triangle nearest to each point
    bary: np.ndarray  # (n, 3) barycentric weights of the nearest point on it
    distance: np.ndarray  # (n,) distance to the body surface

    def normals(self, body_vertex_normals: np.ndarray, body_faces: np.ndarray) -> np.ndarray:
        """Interpolated unit body normals at the corresponding points (the seed's n')."""
        corners = body_vertex_normals[body_faces[self.triangle]]  # (n, 3, 3)
        n = np.einsum("ij,ijk->ik", self.bary, corners)
        return _unit(n)

    def points(self, body_vertices: np.ndarray, body_faces: np.ndarray) -> np.ndarray:
        return np.einsum("ij,ijk->ik", self.bary, body_vertices[body_faces[self.triangle]])


def _unit(v: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, length, out=np.zeros_like(v), where=length > 0)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (zero for vertices of zero-area triangles only)."""
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    # bincount per axis: several times faster than np.add.at
    idx = np.asarray(faces).T.ravel()
    out = np.column_stack([np.bincount(idx, weights=np.tile(cross[:, k], 3), minlength=len(vertices))
                           for k in range(3)]) if len(vertices) else np.zeros((0, 3))
    return _unit(out)


def closest_point_on_triangles(p, a, b, c):
    """Closest point to p on triangle abc, all (n,3); returns barycentric weights (n,3).

    Ericson, Real-Time Collision Detection, 5.1.5, vectorised: the Voronoi region tests run
    in his order and ``np.select`` takes the first that holds. Degenerate triangles fall into
    the edge and vertex regions and stay finite.
    """
    ab, ac, ap = b - a, c - a, p - a
    d1 = np.einsum("ij,ij->i", ab, ap)
    d2 = np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3 = np.einsum("ij,ij->i", ab, bp)
    d4 = np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5 = np.einsum("ij,ij->i", ab, cp)
    d6 = np.einsum("ij,ij->i", ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        denom = va + vb + vc
        v_in, w_in = vb / denom, vc / denom
    regions = [(d1 <= 0) & (d2 <= 0),  # vertex a
               (d3 >= 0) & (d4 <= d3),  # vertex b
               (d6 >= 0) & (d5 <= d6),  # vertex c
               (vc <= 0) & (d1 >= 0) & (d3 <= 0),  # edge ab
               (vb <= 0) & (d2 >= 0) & (d6 <= 0),  # edge ac
               (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)]  # edge bc
    zero = 0.0
    wb = np.select(regions, [zero, 1.0, zero, t_ab, zero, 1 - t_bc], v_in)
    wc = np.select(regions, [zero, zero, 1.0, zero, t_ac, t_bc], w_in)
    w = np.column_stack([1 - wb - wc, wb, wc])
    bad = ~np.isfinite(w).all(1)
    w[bad] = (1.0, 0.0, 0.0)
    return w


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


def surface_search(vertices, faces, ring_width: int = 8):
    """(kd-tree over the vertices some triangle uses, their incident triangles row by row) for
    nearest_on_surface. A vertex of no triangle stays out: as a nearest vertex it would offer no
    candidate at all."""
    used = used_vertices(faces, len(vertices))
    incident = incident_triangles(faces, len(vertices), ring_width)
    if used.all():
        return cKDTree(vertices), incident
    return cKDTree(vertices[used]), incident[used]


def nearest_on_surface(points, vertices, faces, k: int = 2, ring_width: int = 8,
                       chunk: int = 4096, search=None) -> BodyCorrespondence:
    """Nearest point on a triangle surface for each point.

    Candidates are the triangles around the ``k`` nearest vertices (a kd-tree), which
    contains the true nearest triangle whenever it has a vertex among them: always, for
    surfaces whose triangles are small against the distance to the points' neighbours.
    """
    points = np.asarray(points, dtype=np.float64)
    n = len(points)
    if not n:
        return BodyCorrespondence(np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0))
    # search: surface_search(vertices, faces, ring_width) made earlier
    if search is None or search[1].shape[1] != ring_width:
        search = surface_search(vertices, faces, ring_width)
    tree, incident = search
    k = min(k, tree.n)
    _, near = tree.query(points, k=k, workers=-1)
    near = near.reshape(n, -1)
    best_t = np.zeros(n, dtype=np.int64)
    best_w = np.zeros((n, 3))
    best_d = np.zeros(n)
    tris = vertices[faces]  # (m, 3, 3)
    # float32 about the points' centre, so precision follows the scene's size
    centre = points.mean(0)
    tris32, points32 = (tris - centre).astype(np.float32), (points - centre).astype(np.float32)

    def run(sl):
        cand = incident[near[sl]].reshape(sl.stop - sl.start, -1)  # (c, width), -1 padded
        width = cand.shape[1]
        # pick in float32 (half the memory traffic), then solve the pick again in float64
        tri = tris32[np.maximum(cand, 0)].reshape(-1, 3, 3)
        p = np.repeat(points32[sl], width, axis=0)
        w = closest_point_on_triangles(p, tri[:, 0], tri[:, 1], tri[:, 2])
        off = p - np.einsum("ij,ijk->ik", w, tri)
        d = np.einsum("ij,ij->i", off, off).reshape(-1, width)
        d[cand < 0] = np.inf
        pick = np.maximum(cand[np.arange(len(d)), np.argmin(d, axis=1)], 0)  # no triangle at all: triangle 0
        tri = tris[pick]
        best_t[sl] = pick
        best_w[sl] = closest_point_on_triangles(points[sl], tri[:, 0], tri[:, 1], tri[:, 2])
        best_d[sl] = np.linalg.norm(points[sl] - np.einsum("ij,ijk->ik", best_w[sl], tri), axis=1)

    # numpy releases the GIL on these array sizes: slices run side by side on the cores
    map_chunks(run, n, chunk)
    return BodyCorrespondence(best_t, best_w, best_d)


def local_radius(vertices, faces, normals=None, scene: RayScene | None = None) -> np.ndarray:
    """Half the chord length straight through the body from each vertex (the seed's l_s, per vertex).

    Rays go inward along -normal; a vertex whose ray finds nothing (open or odd geometry)
    takes the median of the rest.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    if normals is None:
        normals = vertex_normals(vertices, faces)
    scene = scene if scene is not None else RayScene(vertices, faces)
    size = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 1.0
    ok = np.linalg.norm(normals, axis=1) > 0
    radius = np.full(len(vertices), np.nan)
    if ok.any():
        hits = scene.intersect(vertices[ok], -normals[ok], min_dist=1e-6 * size)
        radius[ok] = np.where(hits.hit, 0.5 * hits.t, np.nan)
    fill = np.nanmedian(radius) if np.isfinite(radius).any() else 0.1 * size
    return np.where(np.isfinite(radius), radius, fill)

"""Independent float64 references for the ray tests: all rays against all triangles."""

import numpy as np


def moller_trumbore(origins, directions, vertices, faces, tmin=0.0, tmax=np.inf, eps=1e-12):
    """Every (ray, triangle) pair by Möller–Trumbore; returns t (inf on miss) and face (-1)."""
    o = np.asarray(origins, float)
    d = np.asarray(directions, float)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    tri = np.asarray(vertices, float)[np.asarray(faces)]
    n, m = len(o), len(tri)
    t_best = np.full(n, np.inf)
    f_best = np.full(n, -1)
    if m == 0:
        return t_best, f_best
    tmin = np.broadcast_to(np.asarray(tmin, float), (n,))
    tmax = np.broadcast_to(np.asarray(tmax, float), (n,))
    e1 = tri[:, 1] - tri[:, 0]
    e2 = tri[:, 2] - tri[:, 0]
    for start in range(0, n, 256):
        sl = slice(start, min(n, start + 256))
        dd = d[sl, None, :]
        p = np.cross(dd, e2[None])
        det = np.einsum("rmk,mk->rm", p, e1)
        ok = np.abs(det) > eps * np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = o[sl, None, :] - tri[None, :, 0]
            u = np.einsum("rmk,rmk->rm", s, p) * inv
            q = np.cross(s, e1[None])
            v = np.einsum("rk,rmk->rm", d[sl], q) * inv
            t = np.einsum("mk,rmk->rm", e2, q) * inv
            ok &= (u >= 0) & (v >= 0) & (u + v <= 1)
            ok &= (t >= tmin[sl, None]) & (t <= tmax[sl, None])
        t = np.where(ok, t, np.inf)
        f_best[sl] = np.where(np.isfinite(t.min(1)), t.argmin(1), -1)
        t_best[sl] = t.min(1)
    return t_best, f_best


def edge_margin(points, vertices, faces, face_ids):
    """Smallest barycentric coordinate of each point in its triangle: near 0 means on an edge."""
    tri = np.asarray(vertices, float)[np.asarray(faces)[face_ids]]
    e1 = tri[:, 1] - tri[:, 0]
    e2 = tri[:, 2] - tri[:, 0]
    w = points - tri[:, 0]
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    w1, w2 = (w * e1).sum(1), (w * e2).sum(1)
    det = d11 * d22 - d12**2
    u = (d22 * w1 - d12 * w2) / det
    v = (d11 * w2 - d12 * w1) / det
    return np.minimum(np.minimum(u, v), 1 - u - v)


def brute_crossings(va, fa, vb, fb):
    """Edges of either mesh that pass through a triangle of the other, every (edge, triangle) pair
    tested: what core.layering.metrics.crossings counts."""
    total = 0
    for (v1, f1), (v2, f2) in (((va, fa), (vb, fb)), ((vb, fb), (va, fa))):
        f1 = np.asarray(f1)
        e = np.unique(np.sort(np.concatenate([f1[:, [0, 1]], f1[:, [1, 2]], f1[:, [2, 0]]]), axis=1), axis=0)
        v1 = np.asarray(v1, float)
        vec = v1[e[:, 1]] - v1[e[:, 0]]
        _, face = moller_trumbore(v1[e[:, 0]], vec, v2, f2, 0.0, np.linalg.norm(vec, axis=1))
        total += int((face >= 0).sum())
    return total


def brute_self_crossings(vertices, faces):
    """Bool per unique edge (sorted pairs, np.unique order): it passes through a triangle of the same
    mesh sharing no vertex with it, every (edge, triangle) pair tested."""
    f = np.asarray(faces)
    v = np.asarray(vertices, float)
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    out = np.zeros(len(e), dtype=bool)
    for i, (a, b) in enumerate(e):
        apart = ~(f == a).any(1) & ~(f == b).any(1)
        if apart.any():
            vec = v[b] - v[a]
            length = np.linalg.norm(vec)
            _, face = moller_trumbore(v[a][None], vec[None], v, f[apart], 0.0, length)
            out[i] = face[0] >= 0
    return out


def nearest_distances(points, vertices, faces):
    """Distance from each point to a triangle surface, every triangle that could be nearest tested:
    trimesh's query gives a distance to some triangle, an upper bound; every triangle whose centroid
    lies within that bound plus the largest centroid-to-corner distance is then measured
    (trimesh.triangles.closest_point, pair by pair) and the least kept."""
    import trimesh
    from scipy.spatial import cKDTree

    points = np.asarray(points, float)
    mesh = trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces), process=False)
    _, bound, _ = trimesh.proximity.closest_point(mesh, points)
    tris = mesh.triangles
    centroid = tris.mean(axis=1)
    reach = float(np.linalg.norm(tris - centroid[:, None], axis=2).max())
    lists = cKDTree(centroid).query_ball_point(points, bound + reach + 1e-12)
    owner = np.repeat(np.arange(len(points)), [len(c) for c in lists])
    cand = np.concatenate([np.asarray(c, dtype=np.int64) for c in lists])
    d = np.linalg.norm(trimesh.triangles.closest_point(tris[cand], points[owner]) - points[owner], axis=1)
    out = np.full(len(points), np.inf)
    np.minimum.at(out, owner, d)
    return out

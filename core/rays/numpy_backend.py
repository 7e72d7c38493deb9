"""The numpy backend: trimesh's ray-triangle intersector, where embreex is not installed (one to
two orders of magnitude slower, said once per process)."""

from __future__ import annotations

import warnings

import numpy as np

warned = False


def intersector(vertices, faces):
    global warned
    if not warned:
        warnings.warn(
            "embreex is not installed: DeformRT falls back to trimesh's numpy ray engine, "
            "which is one to two orders of magnitude slower.",
            RuntimeWarning,
            stacklevel=3,
        )
        warned = True
    import trimesh
    from trimesh.ray.ray_triangle import RayMeshIntersector

    mesh = trimesh.Trimesh(vertices, faces, process=False, validate=False)
    engine = RayMeshIntersector(mesh)

    def trace(o, d, tmin, tmax):
        n = len(o)
        t = np.full(n, np.inf)
        face = np.full(n, -1, dtype=np.int64)
        tri, ray, loc = engine.intersects_id(o, d, multiple_hits=True, return_locations=True)
        if len(tri):
            dist = np.einsum("ij,ij->i", loc - o[ray], d[ray])
            keep = (dist >= tmin[ray]) & (dist <= tmax[ray])
            tri, ray, dist = tri[keep], ray[keep], dist[keep]
            order = np.lexsort((dist, ray))
            first = order[np.r_[True, ray[order][1:] != ray[order][:-1]]] if len(order) else order
            t[ray[first]] = dist[first]
            face[ray[first]] = tri[first]
        return t, face

    return trace

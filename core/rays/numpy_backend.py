"""The numpy backend: trimesh's ray-triangle intersector, where embreex is not installed (one to
two orders of magnitude slower, said once per process)."""

from __future__ import annotations

import warnings

import numpy as np

from ..geometry.vectors import norms

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


class NumpyEngine:
    """A RayScene's triangles traced by trimesh's intersector (no embreex): along unit directions,
    exact distances refined on the hit triangle's plane as Embree's are."""

    name = "numpy"
    shares_buffers = False

    def __init__(self, vertices, faces, center):
        self.center = center
        self.trace = intersector(vertices, faces)

    def commit(self) -> None:
        pass

    def instance_handles(self):
        return None

    def first_hits(self, rays, o, d, tmax, scaled):
        scale = norms(d) if scaled else np.ones(len(d))
        with np.errstate(divide="ignore", invalid="ignore"):
            tf, ff = self.trace(o, d / scale[:, None], np.zeros(len(o)), tmax * scale)
            tf = tf / scale
        ff = rays.faces_of(ff, None)
        hit = ff >= 0
        tf[hit] = rays.refined_t(o[hit], d[hit], ff[hit], tf[hit], tmax[hit])
        uv = np.zeros((len(ff), 2))
        uv[hit] = rays.barycentric(o[hit] + d[hit] * tf[hit, None], ff[hit])
        return tf, ff, uv

    def occluded(self, rays, segments, scaled):
        o, d, lo, tmax = segments.o, segments.d, segments.lo, segments.tmax
        scale = norms(d) if scaled else np.ones(len(o))
        with np.errstate(divide="ignore", invalid="ignore"):
            unit = d / scale[:, None]
        start = np.zeros(len(o)) if lo is None else lo
        return self.trace(o, unit, start * scale, tmax * scale)[1] >= 0

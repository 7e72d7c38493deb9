"""The Embree backend (through embreex): one device per process, scenes, their BVH build, and
occlusion queries split over a thread pool (embreex releases the GIL while tracing). Embree
traces in float32: callers centre their scenes on their box first."""

from __future__ import annotations

import numpy as np

from ..geometry.parallel import map_chunks
from ..geometry.vectors import rows
from . import embree_direct

try:
    from embreex import rtcore as _rtc
    from embreex import rtcore_scene as _rtcs
    from embreex.mesh_construction import TriangleMesh  # noqa: F401  (a scene's triangles, when not shared)

    HAVE_EMBREE = True
except ImportError:  # pragma: no cover - exercised by the fallback test via monkeypatch
    HAVE_EMBREE = False

# Below this many rays a thread hand-off costs more than it saves.
MIN_RAYS_PER_CHUNK = 8192
_device = None


def new_scene():
    return _rtcs.EmbreeScene(_get_device())


def _get_device():
    # One Embree device per process: creating one per scene spawns thread pools each time.
    global _device
    if _device is None:
        _device = _rtc.EmbreeDevice()
    return _device


def commit(scene):
    """Build an embreex scene's BVH if it is not built."""
    if not scene.is_committed:
        # embreex commits on its first ray: one ray here, on one thread, not in several chunks at once
        scene.run(np.zeros((1, 3), np.float32), np.array([[0.0, 0.0, 1.0]], np.float32))


def occluded(scene, center, threads, segments):
    """Occlusion of ray_input.Segments against an embreex scene built about ``center``
    (committed first)."""
    commit(scene)
    o, d, lo, span = segments.o, segments.d, segments.lo, segments.span

    # each worker converts its own slice to float32, so that runs on every core too
    def run(sl):
        start = o[sl] if lo is None else o[sl] + d[sl] * lo[sl, None]
        return scene.run((start - center).astype(np.float32), d[sl].astype(np.float32),
                         dists=float32_dist(span[sl]), query="OCCLUDED")

    return np.concatenate(map_chunks(run, len(o), MIN_RAYS_PER_CHUNK, threads)) >= 0


def float32_dist(dist: np.ndarray) -> np.ndarray:
    # Embree's "no limit" is a huge finite float; inf also works but keep it explicit.
    return np.ascontiguousarray(np.minimum(dist, 1e37), dtype=np.float32)


class EmbreeEngine:
    """A RayScene's triangles traced by Embree: a float32 copy about ``center``, sharing its
    buffers with Embree where the library can be reached directly (moved in place, ranges of it
    built into scenes of their own for parts to instance, built at ``quality``), else copied flat
    by embreex (at its medium quality)."""

    name = "embree"

    def __init__(self, vertices, faces, center, quality="medium"):
        self.center = center
        self.scene = new_scene()
        self.mesh = None
        if embree_direct.available(new_scene):
            self.mesh = embree_direct.Triangles(self.scene, vertices - center, faces, quality)
        else:
            # The flat (m,3,3) constructor copies about 30% faster than the indexed one.
            TriangleMesh(self.scene, vertices[faces] - center)

    @property
    def shares_buffers(self) -> bool:
        """Whether it moves in place and has ranges for parts to instance."""
        return self.mesh is not None

    def move(self, centred_vertices) -> None:
        self.mesh.move(centred_vertices)

    def group(self, start, stop, geom_id):
        return embree_direct.Group(self.mesh, start, stop, geom_id=geom_id)

    def instance_handles(self) -> list:
        return [embree_direct.handle_of(self.scene)]

    def commit(self) -> None:
        commit(self.scene)

    def first_hits(self, rays, o, d, tmax, scaled):
        """(t, face, uv) of the rays on the RayScene ``rays`` (its faces, float64 distances)."""
        n = len(o)
        tf = np.empty(n)
        ff = np.empty(n, dtype=np.int64)
        uv = np.empty((n, 2))

        # Each worker converts, traces and refines its own slice, so the numpy work runs
        # in parallel with tracing too (numpy and embreex both release the GIL).
        def run(sl):
            oo, dd, hi = o[sl], d[sl], tmax[sl]
            org = np.ascontiguousarray(oo - self.center, dtype=np.float32)
            r = self.scene.run(org, np.ascontiguousarray(dd, dtype=np.float32), dists=float32_dist(hi), output=1)
            face = rays.faces_of(r["primID"].astype(np.int64), r["geomID"])
            hit = face >= 0
            idx = np.flatnonzero(hit)  # integer takes: boolean indexing of (n, 3) rows is slower
            t = np.full(len(face), np.inf)
            t[idx] = rays.refined_t(rows(oo, idx), rows(dd, idx), face[idx], r["tfar"][idx].astype(np.float64), hi[idx])
            tf[sl], ff[sl] = t, face
            uv[sl, 0] = np.where(hit, r["u"], 0.0)
            uv[sl, 1] = np.where(hit, r["v"], 0.0)

        if n * 4 >= len(rays.faces):
            rays.planes()  # all faces, once, here rather than in every worker at the same time
        self.commit()
        map_chunks(run, n, MIN_RAYS_PER_CHUNK, rays.threads)
        return tf, ff, uv

    def occluded(self, rays, segments, scaled):
        """Occlusion of ray_input.Segments on the RayScene ``rays``."""
        return occluded(self.scene, self.center, rays.threads, segments)


class EmbreeInstances(EmbreeEngine):
    """A part of a RayScene: one Embree scene instancing the whole's ranges (``groups``)."""

    def __init__(self, groups, center):
        self.center, self.groups, self.mesh = center, groups, None
        self.scene = new_scene()
        embree_direct.instance(self.scene, [g.handle for g in groups])

    def instance_handles(self) -> list:
        return [g.handle for g in self.groups]

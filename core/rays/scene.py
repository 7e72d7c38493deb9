"""One ray engine for all of DeformRT: first hits and occlusion against a triangle set.

Embree (through ``embreex``) does the traversal in float32 on a copy of the scene
centred on its bounding box; rays are split into chunks on a thread pool because
embreex releases the GIL while tracing. Hit distances are then recomputed in
float64 on the hit triangle's plane, so ``t`` agrees with a float64 reference to
round-off even far from the origin.
Without embreex the same answers come from trimesh's numpy intersector.
"""

from __future__ import annotations

import numpy as np

from ..geometry.parallel import thread_count
from ..geometry.topology import used_vertices
from ..geometry.vectors import box, cross, rows
from . import embree, embree_direct, numpy_backend
from .ray_input import as_points, as_range, as_rays, occlusion_rays, step_past_hit, unit_rays

__all__ = ["FEW_RAYS", "RayHits", "RayScene", "ScenePart", "step_past_hit", "thread_count", "unit_rays"]

# The build quality of a scene traced by about as many rays as it has triangles, and built again
# when it moves (the layering's, every frame): Embree's low quality builds the 26,756-triangle body
# in 1.5 ms against 6.3 ms at its medium and traces about a third slower, which such a scene never
# pays back (a playback frame: BVH builds 11 -> 4 ms, builds and traces 24 -> 19 ms). The hits are
# the same at every quality; a scene traced for a whole image (the render engine) keeps the medium.
FEW_RAYS = "low"
QUALITIES = tuple(embree_direct.QUALITY)  # Embree's names, one list


def engine_for(vertices, faces, center, quality="medium"):
    """The backend that traces these triangles: Embree when embreex is there (its BVH built at
    ``quality``), else numpy."""
    if embree.HAVE_EMBREE:
        return embree.EmbreeEngine(vertices, faces, center, quality)
    return numpy_backend.NumpyEngine(vertices, faces, center)

class RayHits:
    """First hit per ray.

    t: distance along the unit direction (inf on a miss).
    face: index of the hit triangle (-1 on a miss).
    normal: unit geometric normal of the hit triangle in its winding order (0 on a miss);
        gathered on first use, since many passes only need t and face.
    bary: (u, v) with hit = (1-u-v)*v0 + u*v1 + v*v2 (0 on a miss); Embree's float32
        values (about 1e-7 relative), enough to interpolate normals or attributes.
    """

    __slots__ = ("t", "face", "bary", "_normals_of", "_normal")

    def __init__(self, t, face, bary, normals_of):
        self.t, self.face, self.bary = t, face, bary
        self._normals_of = normals_of
        self._normal = None

    @property
    def hit(self) -> np.ndarray:
        return self.face >= 0

    @property
    def normal(self) -> np.ndarray:
        if self._normal is None:
            normal = np.zeros((len(self.face), 3))
            h = self.hit
            normal[h] = self._normals_of(self.face[h])
            self._normal = normal
        return self._normal

    def points(self, origins, directions) -> np.ndarray:
        """Hit points (NaN on a miss), using the unit directions the rays were traced with."""
        o, d = as_rays(origins, directions)
        out = np.full_like(o, np.nan)
        h = self.hit
        out[h] = o[h] + d[h] * self.t[h, None]
        return out


class RayScene:
    """First hits and occlusion against one triangle set (``vertices`` (n,3), ``faces`` (m,3) int),
    traced by its backend (``engine_for``: embree.EmbreeEngine, else numpy_backend.NumpyEngine).

    ``threads`` defaults to :func:`thread_count`; ``quality``: how well its BVH is built
    (``QUALITIES``: ``FEW_RAYS`` for a scene traced about once per triangle). Degenerate triangles
    are kept (indices stay valid) but can never be hit.
    """

    def __init__(self, vertices, faces, threads: int | None = None, quality: str = "medium"):
        if quality not in QUALITIES:
            raise ValueError(f"quality must be one of {QUALITIES}, got {quality!r}")
        self.quality = quality
        self.threads = thread_count() if threads is None else max(1, int(threads))
        self._faces = self._check_faces(faces, None)
        self._set_vertices(vertices)

    @staticmethod
    def _check_faces(faces, n_vertices):
        f = np.asarray(faces)
        if f.size == 0:
            return np.zeros((0, 3), dtype=np.int64)
        if f.ndim != 2 or f.shape[1] != 3:
            raise ValueError(f"faces must have shape (m, 3), got {f.shape}")
        if not np.issubdtype(f.dtype, np.integer):
            if not np.all(np.mod(f, 1) == 0):
                raise ValueError("faces must hold whole-number vertex indices")
        return f.astype(np.int64)

    def _set_vertices(self, vertices, in_place=False):
        v = as_points("vertices", vertices)
        f = self._faces
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise ValueError(
                f"faces index vertices 0..{len(v) - 1} but refer to {f.min()}..{f.max()}"
            )
        self.vertices = v
        self.faces = f
        self._face_normals = None
        self._planes = None
        # a part reads its root's planes (it names the root's faces); None for a root, not self:
        # a scene referring to itself is freed only by the cycle collector, with its Embree memory
        self._plane_owner = None
        self._face_base = self._face_map = None
        self._groups, self._group_start = {}, []  # the BVHs parts instance, dropped on a move
        self._moves = getattr(self, "_moves", -1) + 1
        if in_place:
            self._engine.move(v - self._center)
            return
        self._used = np.flatnonzero(used_vertices(f, len(v)))
        # Re-centre before float32 so precision follows the scene's size, not its distance from 0.
        self._center = 0.5 * np.add(*box(rows(v, self._used))) if len(f) else np.zeros(3)
        self._engine = engine_for(v, f, self._center, self.quality) if len(f) else None

    def update(self, vertices) -> None:
        """New positions for the same faces: written into the buffers Embree shares and
        committed again, unless the scene moved far from the centre it was built about (float32
        round-off grows with that distance), when it is built afresh."""
        v = np.asarray(vertices)
        in_place = (self._engine is not None and self._engine.shares_buffers and v.shape == self.vertices.shape
                    and np.isfinite(v).all())
        if in_place:
            used = v[self._used]
            lo, hi = box(used)
            in_place = np.linalg.norm(0.5 * (lo + hi) - self._center) <= np.linalg.norm(hi - lo)
        self._set_vertices(vertices, in_place=in_place)

    def part(self, ranges) -> RayScene:
        """A scene of some of this scene's triangles, given as ``(start, stop)`` ranges of face
        ids, sharing this scene's vertices; its hits name this scene's faces. Each range is
        built once, into an Embree scene of its own that every part holding it instances, so
        parts over overlapping sets of triangles (what is worn over each layer) build no
        triangle twice; a ray through several overlapping ranges costs a little more than through
        one flat scene of them (docs/REPORT.md, ray engine). A part does not follow ``update``:
        make it again from the moved scene."""
        ranges = sorted({(int(a), int(b)) for a, b in ranges if int(b) > int(a)})
        if any(a < 0 or b > len(self.faces) for a, b in ranges):
            raise ValueError(f"face ranges must lie in 0..{len(self.faces)}, got {ranges}")
        if not ranges:
            return RayScene(np.zeros((0, 3)), np.zeros((0, 3), np.int64), threads=self.threads, quality=self.quality)
        return ScenePart(self, ranges)

    def _group(self, start, stop):
        """Faces start..stop-1 as an Embree scene of their own (built on first use, kept)."""
        if (start, stop) not in self._groups:
            self._groups[start, stop] = self._engine.group(start, stop, geom_id=len(self._group_start))
            self._group_start.append(start)
        return self._groups[start, stop]

    def version(self):
        """What changes when the triangles this scene traces move."""
        return id(self), self._moves

    @property
    def center(self) -> np.ndarray:
        """The point Embree's float32 copy of this scene is centred on."""
        return self._center

    def instance_handles(self) -> list | None:
        """Handles of the Embree scenes holding this scene's triangles, for another scene to
        instance (a part's own groups, not the part: Embree instances one level deep); None when
        this scene is not traced by Embree."""
        return None if self._engine is None else self._engine.instance_handles()

    def _check_fresh(self):
        """A part raises when the scene it was made from has moved since."""

    def faces_of(self, prim, geom):
        """Embree's (or the fallback's) primitive ids -> this scene's face ids (-1 stays)."""
        if self._face_base is not None:
            return np.where(prim >= 0, self._face_base[np.maximum(geom, 0)] + prim, -1)
        if self._face_map is not None:
            return np.where(prim >= 0, self._face_map[np.maximum(prim, 0)], -1)
        return prim

    @property
    def face_normals(self) -> np.ndarray:
        """Unit geometric normal per face in its winding order (0 for a degenerate face)."""
        if self._face_normals is None:
            self._face_normals = self.normals_of(slice(None))
        return self._face_normals

    def normals_of(self, face) -> np.ndarray:
        n, _, ln = self._plane_of(face)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(ln[:, None] > 0, n / ln[:, None], 0.0)

    @property
    def backend(self) -> str:
        return self._engine.name if self._engine is not None else ("embree" if embree.HAVE_EMBREE else "numpy")

    def intersect(self, origins, directions, max_dist=None, min_dist=None, scaled=False) -> RayHits:
        """First hit of each ray with ``min_dist <= t <= max_dist`` (per ray or scalar).

        Directions need not be unit; ``t`` is in the units of the vertices. A miss has ``t``
        inf, ``face`` -1 and ``bary`` (0, 0). ``scaled``: as in :meth:`occluded` (``t`` in
        units of each direction's length), so rays already of length one are not made so again.
        """
        self._check_fresh()
        o, d = as_rays(origins, directions, scaled)
        n = len(o)
        tmax = as_range("max_dist", max_dist, n, np.inf)
        t = np.full(n, np.inf)
        face = np.full(n, -1, dtype=np.int64)
        bary = np.zeros((n, 2))
        tmin = as_range("min_dist", min_dist, n, 0.0)
        if not tmin.any() and (max_dist is None or (tmax >= 0).all()):
            tmin, idx = None, None  # every ray traced as given: no index copies
        else:
            idx = np.flatnonzero(tmax >= tmin)
        if self._engine is None or (idx is not None and not len(idx)):
            return RayHits(t, face, bary, self.normals_of)
        if idx is None:
            oo, dd, lo, hi = o, d, None, tmax
        else:
            lo = tmin[idx]
            dd = rows(d, idx)
            oo, hi = rows(o, idx) + dd * lo[:, None], tmax[idx] - lo
        tf, ff, uv = self._engine.first_hits(self, oo, dd, hi, scaled)
        if lo is not None:
            tf += lo
        if idx is None:
            t, face, bary = tf, ff, uv
        else:
            t[idx], face[idx], bary[idx] = tf, ff, uv
        return RayHits(t, face, bary, self.normals_of)

    def occluded(self, origins, directions, max_dist=None, min_dist=None, scaled=False) -> np.ndarray:
        """True where something lies between ``min_dist`` and ``max_dist`` along the ray.
        ``scaled``: the directions are used as given, not made of length one, and the distances
        are in units of each direction's length (an edge as origin and vector: 0..1)."""
        self._check_fresh()
        out, idx, segments = occlusion_rays(origins, directions, max_dist, min_dist, scaled)
        if self._engine is None or idx is None:
            return out
        out[idx] = self._engine.occluded(self, segments, scaled)
        return out

    def commit(self) -> None:
        """Build the acceleration structure now (else the first ray after a build or a move
        does), so callers can time the build apart from tracing."""
        if self._engine is not None:
            self._engine.commit()

    def planes(self):
        """Every face's plane, worked out once and kept (an engine asks before many hits)."""
        return self._plane_of()

    def _plane_of(self, face=None):
        """Per face (all, or just ``face``), the unnormalised normal, its dot with the first
        corner and its length. All faces are done once per scene and kept, so a hit's float64
        distance is a gather and a few products; a few hits on a big scene do only their own."""
        if self._plane_owner is not None:
            return self._plane_owner._plane_of(face)
        asked = len(self.faces) if face is None or isinstance(face, slice) else len(face)
        if self._planes is None and asked * 4 < len(self.faces):
            planes = self._planes_for(self.faces[face])
        else:
            if self._planes is None:
                self._planes = self._planes_for(self.faces)
            if face is None or isinstance(face, slice):
                planes = self._planes[face or slice(None)]
            else:
                planes = rows(self._planes, face)  # one gather of whole rows
        return planes[:, :3], planes[:, 3], planes[:, 4]

    def _planes_for(self, corners):
        """(m, 5) rows: the unnormalised normal, its dot with the first corner, its length."""
        v = self.vertices
        a = rows(v, corners[:, 0])
        e1, e2 = rows(v, corners[:, 1]) - a, rows(v, corners[:, 2]) - a
        out = np.empty((len(a), 5))
        n = cross(e1, e2, out=out[:, :3])
        out[:, 3] = n[:, 0] * a[:, 0] + n[:, 1] * a[:, 1] + n[:, 2] * a[:, 2]
        out[:, 4] = np.sqrt(n[:, 0] ** 2 + n[:, 1] ** 2 + n[:, 2] ** 2)
        return out

    def refined_t(self, o, d, face, t32, tmax):
        """Float64 distance to the hit triangle's plane, kept inside [0, tmax]."""
        n, offset, length = self._plane_of(face)
        denom = n[:, 0] * d[:, 0] + n[:, 1] * d[:, 1] + n[:, 2] * d[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (offset - (n[:, 0] * o[:, 0] + n[:, 1] * o[:, 1] + n[:, 2] * o[:, 2])) / denom
        # Grazing rays (unit d): the plane solve is ill-conditioned; keep Embree's distance.
        bad = ~np.isfinite(t) | (np.abs(denom) < 1e-6 * length)
        t[bad] = t32[bad]
        return np.clip(t, 0.0, tmax)

    def barycentric(self, p, face):
        tri = self.vertices[self.faces[face]]
        e1 = tri[:, 1] - tri[:, 0]
        e2 = tri[:, 2] - tri[:, 0]
        w = p - tri[:, 0]
        d11 = np.einsum("ij,ij->i", e1, e1)
        d12 = np.einsum("ij,ij->i", e1, e2)
        d22 = np.einsum("ij,ij->i", e2, e2)
        w1 = np.einsum("ij,ij->i", w, e1)
        w2 = np.einsum("ij,ij->i", w, e2)
        det = d11 * d22 - d12 * d12
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (d22 * w1 - d12 * w2) / det
            v = (d11 * w2 - d12 * w1) / det
        return np.nan_to_num(np.column_stack([u, v]))


class ScenePart(RayScene):
    """Some of a RayScene's triangles (``RayScene.part``): it shares the whole's vertices and
    names its faces; with Embree's shared buffers it instances the whole's ranges, else it is a
    flat copy of them. It does not follow the whole's moves (asked after one, it raises)."""

    def __init__(self, whole: RayScene, ranges):
        self.threads, self.vertices, self.faces, self._used = whole.threads, whole.vertices, whole.faces, whole._used
        self.quality = whole.quality
        self._face_normals = self._planes = self._face_map = self._face_base = None
        self._plane_owner = whole._plane_owner or whole
        self._whole, self._whole_moves = whole, whole._moves
        self._groups, self._group_start, self._moves = {}, [], 0
        if whole._engine.shares_buffers:
            groups = [whole._group(a, b) for a, b in ranges]
            self._center = whole._center
            self._engine = embree.EmbreeInstances(groups, self._center)
            self._face_base = np.asarray(whole._group_start, np.int64)  # geomID -> first face
        else:
            keep = np.concatenate([np.arange(a, b) for a, b in ranges])
            self._flat = RayScene(whole.vertices, whole.faces[keep], threads=whole.threads, quality=whole.quality)
            self._center, self._engine = self._flat._center, self._flat._engine
            self._face_map = keep

    def update(self, vertices) -> None:
        raise RuntimeError("a part of a scene cannot move: make it again from the moved scene")

    def version(self):
        return self._whole.version()

    def _check_fresh(self):
        if self._whole._moves != self._whole_moves:
            raise RuntimeError("the scene this part was made from has moved since: make the part again")

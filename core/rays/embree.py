"""The Embree backend (through embreex): one device per process, scenes, their BVH build, and
occlusion queries split over a thread pool (embreex releases the GIL while tracing). Embree
traces in float32: callers centre their scenes on their box first."""

from __future__ import annotations

import numpy as np

from ..geometry.parallel import map_chunks

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


def occluded(scene, center, threads, o, d, lo, span):
    """Occlusion of rays from ``o`` (+ ``d`` x ``lo``, if given) over ``span`` against an
    embreex scene built about ``center`` (committed first)."""
    commit(scene)

    # each worker converts its own slice to float32, so that runs on every core too
    def run(sl):
        start = o[sl] if lo is None else o[sl] + d[sl] * lo[sl, None]
        return scene.run((start - center).astype(np.float32), d[sl].astype(np.float32),
                         dists=float32_dist(span[sl]), query="OCCLUDED")

    return np.concatenate(map_chunks(run, len(o), MIN_RAYS_PER_CHUNK, threads)) >= 0


def float32_dist(dist: np.ndarray) -> np.ndarray:
    # Embree's "no limit" is a huge finite float; inf also works but keep it explicit.
    return np.ascontiguousarray(np.minimum(dist, 1e37), dtype=np.float32)

"""Ray scenes of garments as they came, kept between resolves: resolving the same garments again
(another offset, falloff or stage switch, what an artist does after a resolve) builds no BVH
for a layer nothing moved, nor for the first scene of one that moves."""

from __future__ import annotations

import numpy as np

from ..geometry.cache import Cache
from .scene import FEW_RAYS, RayScene

# What the kept scenes may hold, about 256 MiB (KEPT.max_bytes)
KEPT = Cache(max_bytes=256 << 20)


def scene_bytes(n_triangles: int, n_vertices: int) -> int:
    """About what a kept scene holds: its BVH and float32 buffers in Embree plus its own float64
    vertices, faces and plane table."""
    return 180 * n_triangles + 40 * n_vertices


def kept_scene(key, vertices, faces) -> tuple[RayScene, bool]:
    """(scene over ``faces`` at ``vertices``, whether it was kept). ``key`` must name that content
    (a digest of the arrays it comes from); a scene made here is built over its own copy of the
    vertices, so a caller writing into its arrays later cannot change a kept one."""
    found = KEPT.get(key)
    if found is not None:
        return found, True
    scene = RayScene(np.array(vertices, dtype=np.float64), faces, quality=FEW_RAYS)
    scene.commit()  # a kept scene may be traced from two threads: none of them commits it then
    KEPT.put(key, scene, scene_bytes(len(scene.faces), len(scene.vertices)), replace=False)
    return scene, False


def forget_scenes() -> None:
    """Drop every kept scene."""
    KEPT.clear()


def kept_bytes() -> int:
    """About how much the kept scenes hold."""
    return KEPT.held_bytes()


__all__ = ["KEPT", "forget_scenes", "kept_bytes", "kept_scene", "scene_bytes"]

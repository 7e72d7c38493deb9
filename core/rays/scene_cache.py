"""Ray scenes of garments as they came, kept between resolves: resolving the same garments again
(another offset, falloff or stage switch, what an artist does after a resolve) builds no BVH
for a layer nothing moved, nor for the first scene of one that moves."""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np

from .scene import RayScene

# What the kept scenes may hold, about: a scene of n triangles over m vertices takes its BVH and
# float32 buffers in Embree plus its own float64 vertices, faces and plane table
BUDGET_BYTES = 256 << 20
_TRIANGLE_BYTES, _VERTEX_BYTES = 180, 40

_kept: OrderedDict = OrderedDict()  # key -> (scene, bytes), most recently asked last
_held = 0
_lock = threading.Lock()


def kept_scene(key, vertices, faces) -> tuple[RayScene, bool]:
    """(scene over ``faces`` at ``vertices``, whether it was kept). ``key`` must name that content
    (a digest of the arrays it comes from); a scene made here is built over its own copy of the
    vertices, so a caller writing into its arrays later cannot change a kept one."""
    global _held
    with _lock:
        found = _kept.pop(key, None)
        if found is not None:
            _kept[key] = found
            return found[0], True
    scene = RayScene(np.array(vertices, dtype=np.float64), faces)
    scene.commit()  # a kept scene may be traced from two threads: none of them commits it then
    size = _TRIANGLE_BYTES * len(scene.faces) + _VERTEX_BYTES * len(scene.vertices)
    if size > BUDGET_BYTES:
        return scene, False
    with _lock:
        if key not in _kept:
            _kept[key] = (scene, size)
            _held += size
        while _held > BUDGET_BYTES:
            _, (_, dropped) = _kept.popitem(last=False)
            _held -= dropped
    return scene, False


def forget_scenes() -> None:
    """Drop every kept scene."""
    global _held
    with _lock:
        _kept.clear()
        _held = 0


def kept_bytes() -> int:
    """About how much the kept scenes hold."""
    return _held


__all__ = ["BUDGET_BYTES", "forget_scenes", "kept_bytes", "kept_scene"]

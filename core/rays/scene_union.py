"""Occlusion against several RayScenes at once."""

from __future__ import annotations

import numpy as np

from ..geometry.parallel import thread_count
from . import embree, embree_direct
from .ray_input import occlusion_rays


class SceneUnion:
    """Occlusion against several scenes at once, for rays that only need to know whether any of
    them is in the way: one Embree scene instancing theirs, so each ray crosses one BVH over
    all of them instead of being traced against each in turn (about a third less time for
    three layers; docs/REPORT.md, layering). Without instancing, each scene is asked in turn.
    A member that moves after the union is made must not be asked through it (checked)."""

    def __init__(self, scenes):
        self._members = [s for s in scenes if len(s.faces)]
        self.threads = max((s.threads for s in self._members), default=thread_count())
        self._versions = [s.version() for s in self._members]
        self._scene = None
        direct = len(self._members) > 1 and all(s.backend == "embree" for s in self._members)
        held = [s.instance_handles() for s in self._members] if direct and embree_direct.available(embree.new_scene) \
            else None
        if held is not None and all(h is not None for h in held):
            for s in self._members:
                s.commit()  # Embree builds an instanced scene before the one holding it
            self._center = np.mean([s.center for s in self._members], axis=0)
            self._scene = embree.new_scene()
            embree_direct.instance(self._scene, [h for hs in held for h in hs],
                                   [s.center - self._center for s, hs in zip(self._members, held, strict=True)
                                    for _ in hs])

    def occluded(self, origins, directions, max_dist=None, min_dist=None, scaled=False) -> np.ndarray:
        """As :meth:`RayScene.occluded`, against every member."""
        if [s.version() for s in self._members] != self._versions:
            raise RuntimeError("a scene of this union has moved since: make the union again")
        if self._scene is None:
            out = np.zeros(len(origins), dtype=bool)
            for s in self._members:
                out |= s.occluded(origins, directions, max_dist=max_dist, min_dist=min_dist, scaled=scaled)
            return out
        out, idx, segments = occlusion_rays(origins, directions, max_dist, min_dist, scaled)
        if idx is None:
            return out
        out[idx] = embree.occluded(self._scene, self._center, self.threads, segments)
        return out


__all__ = ["SceneUnion"]

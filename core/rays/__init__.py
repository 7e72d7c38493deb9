"""Rays against triangle meshes: the RayScene API (scene), one module per backend (embree through
embreex, with Embree's instancing in embree_direct; numpy_backend, trimesh's intersector, where
embreex is missing), and the scenes kept between calls (scene_cache)."""

from .embree import HAVE_EMBREE
from .scene import RayHits, RayScene, step_past_hit, thread_count, unit_rays
from .scene_union import SceneUnion

__all__ = ["HAVE_EMBREE", "RayHits", "RayScene", "SceneUnion", "step_past_hit", "thread_count", "unit_rays"]

"""Rays against triangle meshes: the RayScene API over Embree (through embreex), with trimesh's
numpy intersector as the fallback, and the scenes kept between calls."""

from .scene import HAVE_EMBREE, RayHits, RayScene, SceneUnion, step_past_hit, thread_count, unit_rays

__all__ = ["HAVE_EMBREE", "RayHits", "RayScene", "SceneUnion", "step_past_hit", "thread_count", "unit_rays"]

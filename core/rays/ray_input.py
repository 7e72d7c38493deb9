"""Rays as the ray engine takes them: checked (finite, of one shape, no zero directions), scaled to
unit length unless the caller did, ranges broadcast per ray; and how far past a hit the next
search of a ray starts."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.vectors import norms


def as_points(name: str, arr, allow_empty: bool = True) -> np.ndarray:
    a = np.asarray(arr, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3), got {a.shape}")
    if not allow_empty and len(a) == 0:
        raise ValueError(f"{name} is empty")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return a


def as_rays(origins, directions, scaled=False) -> tuple[np.ndarray, np.ndarray]:
    o = as_points("origins", origins)
    d = as_points("directions", directions)
    if d.shape != o.shape:
        raise ValueError(f"origins {o.shape} and directions {d.shape} must have the same shape")
    if scaled:
        return o, d
    length = norms(d)
    if len(length) and not (length > 0).all():
        raise ValueError(f"directions has {(length <= 0).sum()} zero-length vectors")
    return o, d / length[:, None] if len(d) else d


def unit_rays(origins, directions) -> tuple[np.ndarray, np.ndarray]:
    """Checked rays as float64 arrays, directions of length one: for callers that trace pieces
    of them several times (``scaled=True`` then skips scaling them each time)."""
    return as_rays(origins, directions)


def as_range(name: str, value, n: int, default: float) -> np.ndarray:
    if value is None:
        return np.full(n, default)
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (n,))
    if np.isnan(arr).any():
        raise ValueError(f"{name} contains NaN")
    return arr


@dataclass(frozen=True)
class Segments:
    """The rays an occlusion query traces: from o + d x lo (``lo`` None: from o) to o + d x tmax."""

    o: np.ndarray
    d: np.ndarray
    lo: np.ndarray | None
    tmax: np.ndarray

    @property
    def span(self) -> np.ndarray:
        """Each ray's length from where it starts."""
        return self.tmax if self.lo is None else self.tmax - self.lo


def occlusion_rays(origins, directions, max_dist, min_dist, scaled):
    """Checked rays of an occlusion query: (all-False answers, the rays with tmax >= tmin as a
    slice or indices and those rays' Segments; both None when there are none)."""
    o, d = as_rays(origins, directions, scaled)
    n = len(o)
    tmax = as_range("max_dist", max_dist, n, np.inf)
    tmin = as_range("min_dist", min_dist, n, 0.0)
    active = tmax >= tmin
    out = np.zeros(n, dtype=bool)
    if not active.any():
        return out, None, None
    # every ray from its own origin (the common case): no gathers, no shifted origins
    idx = slice(None) if active.all() else np.flatnonzero(active)
    return out, idx, Segments(o[idx], d[idx], None if min_dist is None else tmin[idx], tmax[idx])


def step_past_hit(length, lo, hi):
    """How far past a hit the next search of a ray starts (``length`` its reach, lo..hi the box
    its scene works in): float32 tracing could meet the same triangle again any nearer, and
    its round-off grows with the ray's reach and the scene's size."""
    return 1e-6 * (length + float(norms((np.asarray(hi) - np.asarray(lo))[None])[0]))


__all__ = ["Segments", "as_points", "as_range", "as_rays", "occlusion_rays", "step_past_hit", "unit_rays"]

"""The volume spline where pipelines have always imported it (``core.rbf.VolumeSpline``); it lives
in core.geometry.rbf."""

from .geometry.rbf import VolumeSpline

__all__ = ["VolumeSpline"]

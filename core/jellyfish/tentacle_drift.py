"""Tentacles carried by the water the bell pushes (thesis 3.6: "tentacles follow the water").

A tentacle point is tethered to where the bell holds it and dragged by the water around it:
its drift d from rest obeys dd/dt = (u_water - u_bell) - d / tether_time, with the water's
velocity read from a simulated cycle at the point's rest place in the bell's frame. The
equation is linear with a periodic drive, so its periodic answer (the one a bell that has
swum for a while shows) is exact: no warm-up cycles. The drift over the cycle is then
split into a few fixed shapes times weights over time (an SVD), which Blender plays as
shape keys with keyframed values.

Coordinates are the bell's (r, z): r from the axis, z up, the margin at z = 0.
"""

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import map_coordinates


@dataclass
class WaterDrift:
    times: np.ndarray  # (T,) cycle phase in (0, 1] of each sample
    shapes: np.ndarray  # (k, n, 2) drift (dr, dz) per unit weight
    weights: np.ndarray  # (k, T)
    captured: float  # share of the drift's sum of squares the k shapes keep
    drift: np.ndarray  # (T, n, 2) the drift itself, before the split

    def at(self, tau) -> np.ndarray:
        """Drift (n, 2) from the shapes at cycle phase tau (periodic, linear in between)."""
        return np.tensordot(self.weights_at(tau), self.shapes, axes=1)

    def weights_at(self, tau) -> np.ndarray:
        t = np.concatenate([self.times[-1:] - 1.0, self.times])
        return np.array([np.interp(float(tau) % 1.0, t, np.concatenate([w[-1:], w])) for w in self.weights])


def _water_velocity(u, nx, h, points):
    """Velocity on the periodic lattice (``nx`` a row, rows along y, cell-centred) at ``points``, cubic."""
    grid = u.reshape(-1, nx, 2)
    rows, cols = points[:, 1] / h - 0.5, points[:, 0] / h - 0.5
    return np.column_stack([map_coordinates(grid[..., c], [rows, cols], order=3, mode="grid-wrap")
                            for c in range(2)])


def periodic_drift(relative, dt, tether_time):
    """Periodic answer of dd/dt = f - d / tau for f piecewise constant over T steps of length
    ``dt`` (``relative`` (T, ...)); returns d at the end of each step."""
    f = np.asarray(relative, float)
    if not (np.isfinite(tether_time) and tether_time > 0):
        raise ValueError(f"tether_time must be finite and > 0, got {tether_time}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be finite and > 0, got {dt}")
    decay = np.exp(-dt / tether_time)
    gain = tether_time * -np.expm1(-dt / tether_time)

    def sweep(d):
        out = np.empty_like(f)
        for k in range(len(f)):
            d = d * decay + gain * f[k]
            out[k] = d
        return out

    once = sweep(np.zeros_like(f[0]))[-1]  # one cycle from rest: d_T = decay^T d_0 + once
    start = once / -np.expm1(-len(f) * dt / tether_time)
    return sweep(start)


@dataclass(frozen=True)
class DriftSettings:
    """How tentacles follow the water: ``tether_time`` (cycle periods) how long the drift takes to
    forget; at most ``modes`` drift shapes, fewer once they hold ``keep`` of its energy; points
    more than ``reach`` bell diameters below the margin read the water at that depth (deeper, the
    periodic box would show them the water above the bell)."""

    tether_time: float = 0.25
    modes: int = 3
    keep: float = 0.995
    reach: float = 0.6


def water_drift(cycle, config, rest_rz, settings: DriftSettings = DriftSettings()):
    """The periodic drift of points at ``rest_rz`` (n, 2) over ``cycle`` (simulated with
    ``sample_fields=True``), as ``settings`` say. Points near the margin drift less (they are
    held by the bell itself) over a tenth of a diameter."""
    tether_time, modes, keep, reach = settings.tether_time, settings.modes, settings.keep, settings.reach
    if not cycle.fields or cycle.swum is None:
        raise ValueError("the cycle has no sampled water: simulate it with sample_fields=True")
    rz = np.asarray(rest_rz, float).reshape(-1, 2)
    if not np.all(np.isfinite(rz)):
        raise ValueError("tentacle points must be finite")
    if modes < 1:
        raise ValueError(f"modes must be >= 1, got {modes}")
    d = config.bell.diameter
    h = config.box / config.particles
    origin = np.array([0.5 * config.box, 0.5 * config.box - 0.5 * config.bell.height])
    depth = np.clip(rz[:, 1], -reach * d, None)
    ramp = -np.expm1(-np.maximum(-rz[:, 1], 0.0) / (0.1 * d))
    times = np.array([t for t, *_ in cycle.fields]) / config.period
    relative = np.empty((len(times), len(rz), 2))
    for k, (_, u, *_rest) in enumerate(cycle.fields):
        y = origin[1] + cycle.swum[k]
        right = _water_velocity(u, config.particles, h, np.column_stack([origin[0] + rz[:, 0], y + depth]))
        left = _water_velocity(u, config.particles, h, np.column_stack([origin[0] - rz[:, 0], y + depth]))
        # the section is symmetric: average the two sides (the left one's r runs the other way)
        relative[k, :, 0] = 0.5 * (right[:, 0] - left[:, 0])
        relative[k, :, 1] = 0.5 * (right[:, 1] + left[:, 1]) - cycle.speed[k]
    relative *= ramp[None, :, None]
    dt = config.period / len(times)
    drift = periodic_drift(relative, dt, tether_time * config.period)
    flat = drift.reshape(len(times), -1)
    u_, s, vt = np.linalg.svd(flat, full_matrices=False)
    energy = np.cumsum(s**2) / max(float((s**2).sum()), 1e-300)
    k = int(min(modes, len(s), np.searchsorted(energy, keep) + 1))
    shapes = vt[:k].reshape(k, len(rz), 2)
    weights = (u_[:, :k] * s[:k]).T
    return WaterDrift(times, shapes, weights, float(energy[k - 1]) if len(s) else 1.0, drift)

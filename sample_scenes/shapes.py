"""Plain numpy shapes the scene builders share (no bpy)."""

from dataclasses import dataclass

import numpy as np


@dataclass
class Folds:
    """Smooth radial bumps on a tube, like cloth's folds: ``amplitude`` of the first of a few low
    harmonics drawn from ``rng`` (a fixed one if None), never inside ``floor`` (the radius of
    whatever the tube is worn over)."""

    amplitude: float
    rng: np.random.Generator | None = None
    floor: float = 0.0


def tube(radius, z0, z1, grid=(64, 32), capped=False, folds: Folds | None = None):
    """An open cylinder along z (two boundary loops), ``grid`` = (vertices around, rings along),
    optionally with folds. With ``capped`` the ends are closed by fans to a centre vertex (a
    closed surface). Faces wind so normals point outward.
    """
    n_around, n_along = grid
    theta = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    z = np.linspace(z0, z1, n_along)
    tt, zz = np.meshgrid(theta, z)
    r = np.full_like(tt, float(radius))
    if folds is not None and folds.amplitude:
        rng = folds.rng if folds.rng is not None else np.random.default_rng(0)
        # Smooth bumps (a few low harmonics) rather than per-vertex jitter, like real cloth folds.
        for k in range(1, 5):
            a, b, phase = rng.normal(scale=folds.amplitude / k, size=3)
            r += a * np.cos(k * tt + phase) * np.cos(np.pi * k * (zz - z0) / (z1 - z0) + b)
    r = np.maximum(r, 0.0 if folds is None else folds.floor)
    v = np.column_stack([(r * np.cos(tt)).ravel(), (r * np.sin(tt)).ravel(), zz.ravel()])
    i, j = np.meshgrid(np.arange(n_along - 1), np.arange(n_around), indexing="ij")
    a = i * n_around + j
    b = i * n_around + (j + 1) % n_around
    c = a + n_around
    d = b + n_around
    faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
    if capped:
        bottom, top = len(v), len(v) + 1
        v = np.vstack([v, [[0, 0, z0], [0, 0, z1]]])
        ring0 = np.arange(n_around)
        ring1 = (n_along - 1) * n_around + ring0
        nxt = np.roll(ring0, -1)
        faces = np.concatenate([
            faces,
            np.stack([np.full(n_around, bottom), nxt, ring0], -1),
            np.stack([np.full(n_around, top), ring1, (n_along - 1) * n_around + nxt], -1),
        ])
    return v, faces


BODY_RADIUS = 0.15  # the tubes case's body


def tube_body(n=64, height=0.6, radius=BODY_RADIUS):
    """The tubes case's body: a capped tube, ``n`` around. Returns (vertices, faces)."""
    return tube(radius, 0.0, height, grid=(n, n // 2), capped=True)


def sleeves(radii, noise, seed=0, n=64, z0_step=0.08, stagger=0.0):
    """The tubes case's noisy open sleeves over its body (a capped tube of BODY_RADIUS): sleeve k of
    ``radii`` from ``z0_step`` x (k + 1) up to 0.55 less ``stagger`` x k, its noise never within
    6 mm of the body, one generator (``seed``) for them all. Returns [(vertices, faces), ...]."""
    rng = np.random.default_rng(seed)
    folds = Folds(noise, rng, floor=BODY_RADIUS + 0.006)
    return [tube(r, z0_step * (k + 1), 0.55 - stagger * k, grid=(n, n // 2), folds=folds) for k, r in enumerate(radii)]

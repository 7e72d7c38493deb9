"""Hand-built layering cases shared by the tests and benchmarks (numpy + trimesh only)."""

import numpy as np
import trimesh

from sample_scenes.shapes import sleeves, tube, tube_body


def mesh(v, f):
    return trimesh.Trimesh(np.asarray(v, float), np.asarray(f), process=False)


def body_tube(radius=0.15, height=0.6, n=64):
    return mesh(*tube_body(n, height, radius))


def noisy_sleeves(radii=(0.165, 0.17), noise=0.012, seed=0, n=64, z0_step=0.08):
    # tops staggered by 3 mm: exactly coincident rims make grazing rays whose answer is arbitrary
    return [mesh(v, f) for v, f in sleeves(radii, noise, seed, n, z0_step, stagger=0.003)]


def sheet(size=1.0, n=40, z=0.0, height_fn=None):
    """A square grid sheet in the xy plane at height z (optionally z + height_fn(x, y)), normals +z."""
    s = np.linspace(-size / 2, size / 2, n)
    x, y = np.meshgrid(s, s)
    zz = np.full_like(x, z) + (height_fn(x, y) if height_fn else 0.0)
    v = np.column_stack([x.ravel(), y.ravel(), zz.ravel()])
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = i * n + j
    f = np.concatenate([np.stack([a, a + 1, a + n + 1], -1).reshape(-1, 3),
                        np.stack([a, a + n + 1, a + n], -1).reshape(-1, 3)])
    return v, f


def slab_body(size=3.0, thickness=0.4, subdivisions=5):
    """A finely tessellated box whose top face is z=0: the 'body' under flat sheets.

    Fine, so the vertex normals under a 1 m sheet are exactly +z (a plain 8-corner
    box would blend its corner normals across the whole face).
    """
    box = trimesh.creation.box(extents=[size, size, thickness])
    box.apply_translation([0, 0, -thickness / 2])
    v, f = box.vertices, box.faces
    for _ in range(subdivisions):
        v, f = trimesh.remesh.subdivide(v, f)
    return trimesh.Trimesh(v, f, process=False)


def capped_cylinder(radius, height, center=(0.0, 0.0), n=48):
    v, f = tube(radius, -height / 2, height / 2, grid=(n, max(8, int(n * height / (6 * radius)))),
                capped=True)
    return mesh(v + [center[0], center[1], 0.0], f)


def lower_body(n=48):
    """Torso (z 0.5-1.0, r 15 cm) on two legs (r 7 cm at x = -/+9 cm, z 0-0.5), as S5 parts.

    Returns the body mesh and its S5 segment ids (torso 0, right leg 3 at x < 0, left leg 4).
    """
    parts = [capped_cylinder(0.15, 0.5, n=n), capped_cylinder(0.07, 0.5, (-0.09, 0.0), n=n),
             capped_cylinder(0.07, 0.5, (0.09, 0.0), n=n)]
    parts[0].apply_translation([0, 0, 0.75])
    parts[1].apply_translation([0, 0, 0.25])
    parts[2].apply_translation([0, 0, 0.25])
    ids = np.concatenate([np.full(len(p.vertices), s) for p, s in zip(parts, (0, 3, 4), strict=True)])
    return trimesh.util.concatenate(parts), ids

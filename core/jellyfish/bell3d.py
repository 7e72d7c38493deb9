"""The 3D jellyfish for animation (thesis 3.6): the 2D contour turned about the bell's axis,
and a 3D volume spline driven by the creature's control points at several angles around
the axis, which carries the bell, its veins and the tentacles' roots along.

Coordinates: z up along the axis, the margin at z = 0, units of the 2D model scaled by
``size / shape.diameter``. The deformation is linear in the control points' displacement,
so phase s of the stroke is exactly s times the full-contraction field: one shape key,
animated, replays the cycle.
"""

from dataclasses import dataclass

import numpy as np

from ..geometry.normals import vertex_normals as triangle_vertex_normals
from ..geometry.rbf import VolumeSpline
from .bell import BellShape, Creature


def profile(shape: BellShape, per_curve: int):
    """Right half of the section as (r, z): exumbrella apex down to the margin, then the
    subumbrella back up to its apex. Returns (points, index of the margin)."""
    a = 0.5 * shape.diameter
    theta = np.linspace(0.5 * np.pi, 0.0, per_curve)
    upper = np.column_stack([a * np.cos(theta), shape.height * np.sin(theta)])
    lower = np.column_stack([a * np.cos(theta[::-1]), shape.inner_height * np.sin(theta[::-1])])
    upper[0, 0] = lower[-1, 0] = 0.0
    return np.vstack([upper, lower[1:]]), per_curve - 1


def revolve(section, segments):
    """Closed surface of revolution of a section whose first and last points lie on the axis:
    (vertices (n, 3), faces as a list of vertex index tuples, quads and pole triangles).
    Faces are wound so normals point out of the enclosed volume."""
    if segments < 3:
        raise ValueError(f"a surface of revolution needs >= 3 segments, got {segments}")
    sec = np.asarray(section, float)
    if abs(sec[0, 0]) > 1e-12 or abs(sec[-1, 0]) > 1e-12:
        raise ValueError("the section must start and end on the axis (r = 0)")
    ring = sec[1:-1]
    phi = 2 * np.pi * np.arange(segments) / segments
    rings = np.stack([ring[:, 0:1] * np.cos(phi), ring[:, 0:1] * np.sin(phi),
                      np.broadcast_to(ring[:, 1:2], (len(ring), segments))], axis=-1).reshape(-1, 3)
    verts = np.vstack([[0.0, 0.0, sec[0, 1]], rings, [0.0, 0.0, sec[-1, 1]]])
    last = len(verts) - 1

    def at(i, j):
        return 1 + i * segments + j % segments

    faces = [(0, at(0, j + 1), at(0, j)) for j in range(segments)]
    faces += [(at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j))
              for i in range(len(ring) - 1) for j in range(segments)]
    faces += [(last, at(len(ring) - 1, j), at(len(ring) - 1, j + 1)) for j in range(segments)]
    if volume(verts, faces) < 0:
        faces = [f[::-1] for f in faces]
    return verts, faces


def triangles(faces) -> np.ndarray:
    """(m, 3) vertex indices: polygons fan-triangulated; an (m, 3) array is returned as it is,
    so callers that measure one surface many times triangulate it once."""
    if isinstance(faces, np.ndarray) and faces.ndim == 2 and faces.shape[1] == 3:
        return faces
    return np.array([(f[0], f[k], f[k + 1]) for f in faces for k in range(1, len(f) - 1)], dtype=np.int64)


def volume(verts, faces) -> float:
    """Signed volume enclosed by a closed polygon surface (divergence theorem over a fan
    triangulation of each face): positive when the normals point out."""
    v = np.asarray(verts, float)
    tris = triangles(faces)
    a, b, c = v[tris[:, 0]], v[tris[:, 1]], v[tris[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def exact_volume(shape: BellShape) -> float:
    """Between the two half-ellipsoids: 2/3 pi a^2 (h - h_inner)."""
    a = 0.5 * shape.diameter
    return 2.0 / 3.0 * np.pi * a * a * (shape.height - shape.inner_height)


@dataclass
class BellModel:
    verts: np.ndarray  # bell surface, then the velum ring
    faces: list
    bell_vertices: int  # the closed bell surface is verts[:bell_vertices]
    veins: list  # polylines (m, 3) along the subumbrella
    tentacles: list  # polylines (m, 3) hanging from the margin


@dataclass(frozen=True)
class Anatomy:
    """What a 3D jellyfish is made of: ``segments`` round the axis and ``per_curve`` points up its
    profile; a velum ring ``velum`` radii wide (0: none); ``veins`` radial canals; ``tentacles``
    ``tentacle_length`` diameters long, of ``tentacle_points`` points, swaying sideways by up to
    ``sway`` radii at their ends, each in its own phase (from ``seed``)."""

    segments: int = 48
    per_curve: int = 16
    velum: float = 0.12
    veins: int = 8
    tentacles: int = 16
    tentacle_length: float = 1.5
    tentacle_points: int = 24
    sway: float = 0.12
    seed: int = 0


def build(shape: BellShape, anatomy: Anatomy = Anatomy()) -> BellModel:
    """The bell (closed), an inward velum ring at the margin, radial canals on the subumbrella and
    tentacles, in the shape's units."""
    segments, per_curve, velum, veins = anatomy.segments, anatomy.per_curve, anatomy.velum, anatomy.veins
    tentacles, tentacle_length, tentacle_points = anatomy.tentacles, anatomy.tentacle_length, anatomy.tentacle_points
    sway, seed = anatomy.sway, anatomy.seed
    a = 0.5 * shape.diameter
    sec, margin = profile(shape, per_curve)
    verts, faces = revolve(sec, segments)
    n_bell = len(verts)
    if velum > 0:
        # a flat annulus from the margin inwards, a little above it so it does not touch
        phi = 2 * np.pi * np.arange(segments) / segments
        z = 0.02 * shape.inner_height
        outer = np.column_stack([a * np.cos(phi), a * np.sin(phi), np.full(segments, z)])
        inner = outer * [1 - velum, 1 - velum, 1.0]
        verts = np.vstack([verts, outer * [0.995, 0.995, 1.0], inner])
        o, i = n_bell, n_bell + segments
        faces = faces + [(o + j, i + j, i + (j + 1) % segments, o + (j + 1) % segments) for j in range(segments)]
    t = np.linspace(0.0, 0.92, tentacle_points)[:, None]
    sub = sec[margin:][::-1]  # subumbrella from its apex out to the margin
    canals = []
    for k in range(veins):
        phi = 2 * np.pi * (k + 0.5) / max(veins, 1)
        r = np.interp(t[:, 0], [0, 1], [0, a])
        zc = np.interp(r, sub[:, 0], sub[:, 1]) - 0.08 * (shape.height - shape.inner_height)
        canals.append(np.column_stack([r * np.cos(phi), r * np.sin(phi), zc]))
    hanging = []
    s = np.linspace(0.0, 1.0, tentacle_points)
    phases = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, (max(tentacles, 1), 2))
    for k in range(tentacles):
        phi = 2 * np.pi * k / max(tentacles, 1)
        # the root hangs straight from the margin; the wave grows down the tentacle
        wave = sway * a * s**1.5
        r = a * (0.97 + 0.05 * s) + wave * np.sin(2 * np.pi * 1.1 * s + phases[k, 0])
        side = wave * np.sin(2 * np.pi * 0.8 * s + phases[k, 1])
        x, y = r * np.cos(phi) - side * np.sin(phi), r * np.sin(phi) + side * np.cos(phi)
        hanging.append(np.column_stack([x, y, -tentacle_length * shape.diameter * s]))
    return BellModel(verts, faces, n_bell, canals, hanging)


class StrokeField:
    """The creature's full-contraction displacement in 3D: its right-half control points
    turned to ``angles`` places around the axis move radially and vertically as in 2D; the
    two apexes and the corners and face centres of a box ``box_half`` around the bell stay."""

    def __init__(self, shape: BellShape, creature: Creature, box_half: float, angles=8, jitter=None):
        q = np.asarray(creature.controls, float)
        d = np.asarray(creature.destinations, float) - q
        phi = 2 * np.pi * np.arange(angles) / angles
        c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
        centres = np.stack([q[:, 0] * c, q[:, 0] * s, np.broadcast_to(q[:, 1], c.shape[:1] + q[:, 1].shape)], -1)
        moves = np.stack([d[:, 0] * c, d[:, 0] * s, np.broadcast_to(d[:, 1], c.shape[:1] + d[:, 1].shape)], -1)
        centres, moves = centres.reshape(-1, 3), moves.reshape(-1, 3)
        if jitter is not None:
            moves = moves + np.asarray(jitter, float).reshape(moves.shape)
        b = box_half
        box = np.array([(x, y, z) for x in (-b, b) for y in (-b, b) for z in (-b, b)]
                       + [(b, 0, 0), (-b, 0, 0), (0, b, 0), (0, -b, 0), (0, 0, b), (0, 0, -b)], float)
        fixed = np.vstack([box, [(0, 0, shape.height), (0, 0, shape.inner_height)]])
        self.centres = np.vstack([centres, fixed])
        self.spline = VolumeSpline(self.centres, np.vstack([moves, np.zeros((len(fixed), 3))]))
        self.control_count = len(centres)

    def __call__(self, points) -> np.ndarray:
        return self.spline(np.asarray(points, float))


def vertex_normals(verts, faces) -> np.ndarray:
    """Area-weighted unit vertex normals of a polygon surface (fan-triangulated faces)."""
    return triangle_vertex_normals(np.asarray(verts, float), triangles(faces))


def volume_offset(moved, faces, normals, target) -> float:
    """The offset t along ``normals`` that gives ``moved + t * normals`` the ``target`` volume
    (mesoglea is water: the bell keeps its volume while it contracts). Volume is a cubic in t;
    its root nearest zero is taken."""
    ts = np.array([-1.0, -0.5, 0.0, 0.5, 1.0])
    v = np.asarray(moved, float)
    scale = float(np.ptp(v, axis=0).max()) or 1.0
    tris = triangles(faces)
    vols = [volume(v + t * scale * normals, tris) for t in ts]
    coeffs = np.polyfit(ts, vols, 3)  # exact: five samples of a cubic
    coeffs[-1] -= target
    roots = np.roots(coeffs)
    real = roots[np.abs(roots.imag) < 1e-9 * max(1.0, np.abs(roots).max())].real
    if not len(real):
        raise ValueError("no normal offset restores the bell's volume")
    return float(real[np.argmin(np.abs(real))] * scale)

"""The jellyfish bell's 2D cross-section and its contraction by RBF space mapping (thesis 3.3, 3.5).

The bell is two hemi-ellipses over the same diameter, the exumbrella (upper) and the
subumbrella (lower), meeting at the margins. A creature moves k control points on the
right half (mirrored to the left) to destinations d_i; ten anchors stay put (the eight
border points of a square about the bell and the two bell points on the axis, N = 10 + k as in
the thesis; the thesis puts the square on the domain's box, which made the bell's deformation,
and so its swim, depend on how much water it swims in). At phase s in [0, 1] the control points
sit at q + s (d - q) and a thin-plate volume spline carries every bell point along.
"""

from dataclasses import dataclass

import numpy as np

from ..geometry.rbf import VolumeSpline


@dataclass(frozen=True)
class BellShape:
    diameter: float = 0.10  # m, margin to margin
    height: float = 0.035  # exumbrella apex above the margin
    inner_height: float = 0.022  # subumbrella apex above the margin
    nodes: int = 40  # both curves together, margins shared

    def __post_init__(self):
        if not (self.diameter > 0 and np.isfinite(self.diameter)):
            raise ValueError(f"bell diameter must be > 0, got {self.diameter}")
        if not (0 <= self.inner_height < self.height):
            raise ValueError(f"the subumbrella ({self.inner_height}) must lie under the exumbrella ({self.height})")
        if self.nodes < 8 or self.nodes % 2:
            raise ValueError(f"nodes must be an even number >= 8, got {self.nodes}")


def contour(shape: BellShape):
    """Closed polygon, counter-clockwise: exumbrella from the right margin over the apex to the
    left margin, then the subumbrella back. Returns (points (n, 2), index of the left margin)."""
    per_curve = shape.nodes // 2 + 1  # both margins included on each curve
    theta = np.linspace(0.0, np.pi, per_curve)
    a = 0.5 * shape.diameter
    upper = np.column_stack([a * np.cos(theta), shape.height * np.sin(theta)])
    lower = np.column_stack([a * np.cos(theta[::-1]), shape.inner_height * np.sin(theta[::-1])])
    return np.vstack([upper, lower[1:-1]]), per_curve - 1


@dataclass(frozen=True)
class Creature:
    """Control points on the right half (k, 2), where each goes at full contraction (k, 2),
    and the share of the cycle spent contracting."""

    controls: np.ndarray
    destinations: np.ndarray
    contraction: float

    def __post_init__(self):
        c, d = np.asarray(self.controls, float), np.asarray(self.destinations, float)
        if c.shape != d.shape or c.ndim != 2 or c.shape[1] != 2 or not len(c):
            raise ValueError(f"controls and destinations must both be (k, 2), got {c.shape} and {d.shape}")
        if not (np.isfinite(c).all() and np.isfinite(d).all()):
            raise ValueError("control points must be finite")
        if not 0.0 < self.contraction < 1.0:
            raise ValueError(f"contraction must be a share of the cycle in (0, 1), got {self.contraction}")


def anchors(shape: BellShape, half: float):
    """The ten fixed points: corners and edge midpoints of the square of half width ``half``
    about the bell, bell apexes on the axis."""
    b = half
    border = [(-b, -b), (0, -b), (b, -b), (b, 0), (b, b), (0, b), (-b, b), (-b, 0)]
    return np.array(border + [(0.0, shape.height), (0.0, shape.inner_height)], dtype=float)


def mirrored(points):
    """Right-half points with their mirror images on the left (points on the axis kept once)."""
    p = np.asarray(points, float)
    off_axis = p[np.abs(p[:, 0]) > 1e-12]
    return np.vstack([p, off_axis * [-1.0, 1.0]])


def phase(t, contraction):
    """Contraction phase in [0, 1] at cycle time t in [0, 1): a half cosine up over the
    contraction, a half cosine back over the rest; starts and ends at rest with zero speed."""
    t = np.asarray(t, float) % 1.0
    up = 0.5 * (1.0 - np.cos(np.pi * t / contraction))
    down = 0.5 * (1.0 + np.cos(np.pi * (t - contraction) / (1.0 - contraction)))
    return np.where(t < contraction, up, down)


class BellMap:
    """The space map of one creature: ``at(s)`` moves points to contraction phase s."""

    def __init__(self, shape: BellShape, creature: Creature, half: float):
        """``half``: the anchors' square's half width (swimming takes the bell's diameter)."""
        fixed = anchors(shape, half)
        q = mirrored(creature.controls)
        d = mirrored(creature.destinations)
        if len(q) != len(d):
            raise ValueError("a control point on the axis must stay on the axis")
        self.centers = np.vstack([fixed, q])
        self.displacement = np.vstack([np.zeros_like(fixed), d - q])
        self.spline = VolumeSpline(self.centers, self.displacement)

    def bending_energy(self) -> float:
        """E^b of the full contraction: x^T A^-1 x + y^T A^-1 y (thesis 3.5)."""
        return self.spline.bending_energy()

    def displacement_at(self, points, s):
        return s * self.spline(points)

    def rest_of(self, points, s, tol=1e-12, max_iterations=50):
        """Where the points were at rest: X with X + s D(X) = x (fixed point X <- x - s D(X),
        a contraction wherever the map does not fold, |s grad D| < 1). Material velocities are
        ds/dt D(X); D at the moved point x would give the margin another speed than its own."""
        x = np.asarray(points, float)
        rest = x - self.displacement_at(x, s)
        scale = max(1e-300, float(np.abs(self.displacement).max()))
        for _ in range(max_iterations):
            new = x - self.displacement_at(rest, s)
            step = float(np.abs(new - rest).max(initial=0.0))
            rest = new
            if step <= tol * scale:
                break
        return rest


class SolidBell:
    """The bell as living tissue: the space map's shape scaled about its centroid at each phase
    so that the tissue keeps its volume. The thin-plate map alone shrinks the 2D section by 7.5%
    and the bell of revolution by 21% at full contraction (the default stroke): in water that
    cannot be compressed the missing volume is a sink, which the forcing cannot realise and
    which made the path depend on how often the bell is imposed by a factor of two.

    ``water`` (waters.Water) says how the section stands for a volume: turned about the axis
    (scaled as sigma^3) or the section's area (sigma^2)."""

    def __init__(self, shape: BellShape, bell_map: BellMap, water):
        self.map, self.water = bell_map, water
        self.rest, self.left = contour(shape)
        self.volume0, height = self.volume(self.rest)
        self.centre = np.array([0.0, height])

    def volume(self, points):
        """(Area or volume of revolution of a contour like ``contour``'s, its centroid's height)."""
        return self.water.section_volume(np.asarray(points, float), self.left)

    def scale(self, s):
        """sigma at phase s: the mapped tissue times sigma^dim is the rest volume."""
        mapped = self.volume(self.rest + self.map.displacement_at(self.rest, s))[0]
        return (self.volume0 / mapped) ** (1.0 / self.water.dimensions)

    def at(self, points, s):
        """Rest points moved to phase s."""
        return self.centre + self.scale(s) * (points + self.map.displacement_at(points, s) - self.centre)

    def rate(self, points, s, ds=1e-6):
        """d/ds of the material point now at ``points``: the map's displacement where it rests,
        scaled, plus the scaling's own rate."""
        sigma = self.scale(s)
        lo, hi = max(0.0, s - ds), min(1.0, s + ds)
        sigma_rate = (self.scale(hi) - self.scale(lo)) / (hi - lo)
        mapped = self.centre + (np.asarray(points, float) - self.centre) / sigma
        return sigma * self.map.spline(self.map.rest_of(mapped, s)) + sigma_rate * (mapped - self.centre)


def polygon_area(p) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def self_intersections(p) -> int:
    """Pairs of non-adjacent edges of the closed polygon that cross."""
    a, b = p, np.roll(p, -1, axis=0)
    n = len(p)
    i, j = np.triu_indices(n, k=2)
    keep = ~((i == 0) & (j == n - 1))
    i, j = i[keep], j[keep]

    def orient(p0, p1, p2):
        return np.sign((p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p1[:, 1] - p0[:, 1]) * (p2[:, 0] - p0[:, 0]))

    o1, o2 = orient(a[i], b[i], a[j]), orient(a[i], b[i], b[j])
    o3, o4 = orient(a[j], b[j], a[i]), orient(a[j], b[j], b[i])
    return int(((o1 * o2 < 0) & (o3 * o4 < 0)).sum())


def check_folds(shape: BellShape, bell_map: BellMap, steps: int = 16):
    """None if the bell stays a simple polygon of the same orientation through the whole
    contraction, else the reason it does not."""
    rest, _ = contour(shape)
    area0 = polygon_area(rest)
    for s in np.linspace(0.0, 1.0, steps + 1)[1:]:
        p = rest + bell_map.displacement_at(rest, s)
        if not np.isfinite(p).all():
            return f"the map is not finite at phase {s:.2f}"
        area = polygon_area(p)
        if area <= 0.0:
            return f"the bell turns inside out at phase {s:.2f}"
        if self_intersections(p):
            return f"the bell folds through itself at phase {s:.2f}"
        if not 0.5 < area / area0 < 2.0:
            return f"the bell's area changes {area / area0:.2f}x at phase {s:.2f}"
    return None


def resample(points, spacing, left_margin):
    """Even points along both curves (each an open Catmull-Rom spline from margin to margin,
    so the sharp margins stay), about ``spacing`` apart; the closed polygon as from contour()."""
    upper = points[:left_margin + 1]
    lower = np.vstack([points[left_margin:], points[:1]])
    a = _even_on_spline(upper, spacing)
    b = _even_on_spline(lower, spacing)
    return np.vstack([a, b[1:-1]]), len(a) - 1


def _even_on_spline(p, spacing, dense=16):
    ext = np.vstack([2 * p[0] - p[1], p, 2 * p[-1] - p[-2]])
    t = np.linspace(0.0, 1.0, dense, endpoint=False)[:, None, None]
    p0, p1, p2, p3 = ext[:-3], ext[1:-2], ext[2:-1], ext[3:]
    # uniform Catmull-Rom (cardinal spline, tension 0.5)
    c = 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t**2 + (-p0 + 3 * p1 - 3 * p2 + p3) * t**3)
    curve = np.vstack([c.transpose(1, 0, 2).reshape(-1, 2), p[-1:]])
    seg = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    count = max(2, int(round(arc[-1] / spacing)) + 1)
    target = np.linspace(0.0, arc[-1], count)
    return np.column_stack([np.interp(target, arc, curve[:, 0]), np.interp(target, arc, curve[:, 1])])

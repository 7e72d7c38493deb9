"""Swimming cycles of an artificial jellyfish (thesis chapter 3): the bell contracts and relaxes
by its creature's space map inside the particle fluid, and swims by what it pushes. The search
for a stroke is ``stroke_search``.

The bell acts on the fluid by direct forcing: lattice particles inside the bell (or closer to
its contour than half the margin's thickness, so the thin margin still blocks the flow) take the
bell's velocity, its deformation rate (the space map's, scaled so the tissue keeps its volume:
``SolidBell``) plus its swimming speed V along the axis. The water is round the bell's axis
(``fluid="axisymmetric"``, the default) or the thesis' plane (``waters``); it wraps along the axis, and
its sides (periodic, or a free-slip wall round the axis) take no axial momentum, so fluid and
bell (density equal to water's, as in the thesis) keep their total: V follows from it at every step. This
is the thesis' fluid force on the bell (eq. 3.10-3.12) integrated implicitly, which stays
stable although the bell is no heavier than the water it displaces.
"""

import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from .bell import BellMap, BellShape, Creature, SolidBell, check_folds, contour, phase, resample
from .body_projection import ImposedBody
from .fitness import FitnessScales, fitness
from .particle_fluid import LatticeFluid
from .waters import lattice_for, water

# the thinnest the bell's margin is on a coarse lattice, in particle spacings
COVER_SPACINGS = 1.5


@dataclass(frozen=True)
class JellyfishConfig:
    bell: BellShape = field(default_factory=BellShape)
    box: float = 0.20  # m, the domain's width (the cylinder's diameter round an axisymmetric bell)
    particles: int = 100  # per side (across the whole width: half of them out from the axis)
    substeps: int = 14  # steps per contraction-relaxation cycle (the thesis' Table 3.1)
    period: float = 1.0  # s per cycle
    # m^2/s: ten times water's. A 100 x 100 lattice (2 mm) does not resolve water's boundary layers
    # (a Stokes layer sqrt(nu T / pi) of 0.6 mm): its cruising path then depends on the time step by
    # -20% to +55%, set by the advection's own damping. At 1e-5 (a Reynolds number of about 100 on
    # the bell, where 2D jellyfish studies work) steps and corrections agree within 15%; the lattice
    # does not yet (a 400 x 400 one swims 30-40% less far: REPORT, stop 65)
    viscosity: float = 1.0e-5
    density: float = 1000.0
    weights: tuple = (0.4, 0.3, 0.3)  # w_d, w_b, w_e of eq. 3.14
    # the thinnest the bell is taken to be (its margin), a share of its diameter (3 mm of the
    # default 10 cm): particles within half of it of the contour move with the bell, so its thin
    # margin still blocks the flow. The same body on every lattice from the default's (where it is
    # 1.5 spacings) finer; on a coarser one at least COVER_SPACINGS, so that the margin still covers
    # a particle in every row. Held in spacings everywhere, the bell thinned and lightened as the
    # lattice refined (REPORT, stop 65)
    margin_thickness: float = 0.03
    cfl: float = 1.0
    # GMRES corrections of the bell's velocity after each inner step's projection, one projection
    # each, until the bell's imposed velocity is met to forcing_tolerance of its fastest speed (root
    # mean square), at most forcing_corrections (None: always that many). A fixed two missed the
    # bell's velocity by 4.9-12.7 mm/s at 50-200 particles a side. To 3% the six-cycle path at 100
    # moves +0.05% and the first cycle +0.5% when the tolerance tightens tenfold, at 0.54 s a cycle
    # against 0.65 s to 1% and 0.83 s to 0.3% (REPORT, by a sparse LU; 10% moved the path by 18%)
    forcing_corrections: int = 16
    forcing_tolerance: float | None = 0.03
    box_height: float | None = None  # m along the swimming axis; None: the box's width (square)
    max_inner_steps: int = 128  # per substep: a stroke too fast for the lattice is refused, not run for hours
    # cycles each creature swims from rest in a search, its fitness over all of them: one ranks 16
    # random strokes' fitness as 8 do with Spearman 0.991, three 1.000, at three times the cost (REPORT)
    cycles: int = 1
    # the water's key in waters.WATERS: "axisymmetric" (round the axis) or "planar" (the thesis')
    fluid: str = "axisymmetric"
    # how its pressure and viscous steps are solved (fluid_box.Stepping's pressure_solver): "auto"
    # picks Fourier modes along the axis round it (0.41-0.44 s a cycle at the default against
    # 0.55-0.67 s by a sparse LU, the same path to 6 digits; REPORT)
    solver: str = "auto"

    def __post_init__(self):
        if self.substeps < 1:
            raise ValueError(f"substeps must be >= 1, got {self.substeps}")
        if not (np.isfinite(self.period) and self.period > 0):
            raise ValueError(f"period must be finite and > 0, got {self.period}")
        if not (np.isfinite(self.margin_thickness) and 0 < self.margin_thickness < 0.5):
            raise ValueError(f"margin_thickness is a share of the bell's diameter, > 0 and < 0.5, got "
                             f"{self.margin_thickness}")
        if self.box <= self.bell.diameter:
            raise ValueError(f"the box ({self.box} m) must be wider than the bell ({self.bell.diameter} m)")
        water(self.fluid).check(self)
        if int(self.cycles) != self.cycles or self.cycles < 1:
            raise ValueError(f"cycles must be a whole number >= 1, got {self.cycles}")
        if int(self.max_inner_steps) != self.max_inner_steps or self.max_inner_steps < 1:
            raise ValueError(f"max_inner_steps must be a whole number >= 1, got {self.max_inner_steps}")
        height = self.height
        if not (np.isfinite(height) and height > 2 * self.bell.height):
            raise ValueError(f"box_height ({height} m) must be more than twice the bell's height "
                             f"({self.bell.height} m)")
        rows = self.particles * height / self.box
        if abs(rows - round(rows)) > 1e-6 * rows:
            raise ValueError(f"box_height must hold a whole number of particle spacings ({self.box / self.particles:g}"
                             f" m): {height} m holds {rows:.3f}")

    @property
    def height(self) -> float:
        return self.box if self.box_height is None else float(self.box_height)

    @property
    def rows(self) -> int:
        """Particles along the swimming axis."""
        return int(round(self.particles * self.height / self.box))


def default_config(**changes) -> JellyfishConfig:
    """The thesis' Aurelia case: 10 cm bell, 20 x 20 cm domain, 100 x 100 particles, 14 substeps."""
    return replace(JellyfishConfig(), **changes)


def default_creature(config: JellyfishConfig) -> Creature:
    """An Aurelia-like stroke: the margin swings in by a quarter of the radius and down a
    little, the flank of the bell follows; a third of the cycle contracting."""
    b = config.bell
    a = 0.5 * b.diameter
    flank = np.array([0.6 * a, b.height * np.sqrt(1 - 0.36)])
    controls = np.array([[a, 0.0], flank])
    destinations = np.array([[0.75 * a, -0.12 * a], flank + [-0.08 * a, -0.02 * a]])
    return Creature(controls, destinations, 1.0 / 3.0)


@dataclass
class CycleResult:
    """One or more cycles swum in a row: totals over them, and the path of each."""

    path_m: float  # distance swum along the axis over the cycles
    bending_energy: float
    energy_loss: float  # sum over substeps and fluid particles of |v|^2 h^2 (eq. 3.13)
    fitness: float
    reason: str | None = None  # why the creature was refused (fitness -inf)
    timings: dict = field(default_factory=dict)
    speed: np.ndarray | None = None  # bell speed at the end of each substep
    swum: np.ndarray | None = None  # distance swum by the end of each substep
    fields: list = field(default_factory=list)  # sampled (t, u, vorticity, bell mask)
    path_per_cycle_m: np.ndarray | None = None  # one entry per cycle
    energy_loss_per_cycle: np.ndarray | None = None  # likewise


def one_cycle(result: CycleResult, k: int) -> CycleResult:
    """Cycle ``k`` of a run of several (``simulate_cycles``): its path, speeds, the distance swum
    since it began and its sampled water, times counted from its start."""
    count = len(result.path_per_cycle_m)
    if not 0 <= k < count:
        raise ValueError(f"cycle {k} of a run of {count}")
    sub = len(result.speed) // count
    before = result.swum[k * sub - 1] if k else 0.0
    start = result.fields[k * sub - 1][0] if k and result.fields else 0.0
    fields = [(t - start, *rest) for t, *rest in result.fields[k * sub:(k + 1) * sub]]
    path, loss = float(result.path_per_cycle_m[k]), float(result.energy_loss_per_cycle[k])
    return replace(result, path_m=path, energy_loss=loss, speed=result.speed[k * sub:(k + 1) * sub],
                   swum=result.swum[k * sub:(k + 1) * sub] - before, fields=fields, path_per_cycle_m=np.array([path]),
                   energy_loss_per_cycle=np.array([loss]))


class BellForcing:
    """The bell as a body the fluid imposes (``body``) and that swims by momentum balance (``moved``)."""

    def __init__(self, fluid: LatticeFluid, config: JellyfishConfig, bell_map: BellMap, contraction: float):
        self.fluid, self.config, self.map = fluid, config, bell_map
        self.contraction = contraction
        self.rest, self.left = contour(config.bell)
        kind = water(config.fluid)
        # as far from the bottom as in the square box: a taller box leaves the room ahead
        self.offset = np.array([kind.axis_x(config), 0.5 * config.box - 0.5 * config.bell.height])
        self.y = 0.0  # swum so far
        self.speed = 0.0
        self.mask = np.zeros(fluid.n, dtype=bool)
        self.momentum0 = 0.0
        self.reach = 0.5 * max(config.margin_thickness * config.bell.diameter, COVER_SPACINGS * fluid.h)
        self._at, self._covered, self._rate, self._body = None, None, None, None
        self.solid = SolidBell(config.bell, bell_map, kind)

    def outline(self, t):
        s = phase(t / self.config.period, self.contraction)
        pts, _ = resample(self.solid.at(self.rest, s), 0.5 * self.fluid.h, self.left)
        return pts + self.offset + [0.0, self.y]

    def covered(self, polygon):
        """Particles inside the bell or within ``reach`` of its contour, the box being periodic
        along the axis: a bell that swims out at the top comes in at the bottom."""
        height = self.fluid.box.height
        polygon = polygon - [0.0, height * np.floor(polygon[:, 1].min() / height)]
        out = self._covered_once(polygon)
        if polygon[:, 1].max() + self.reach > height:
            out |= self._covered_once(polygon - [0.0, height])
        return out

    def local(self, points):
        """Points in the bell's own frame (its base's centre at rest), the periodic image nearest the bell."""
        height = self.fluid.box.height
        local = points - self.offset - [0.0, self.y]
        middle = 0.5 * self.config.bell.height
        local[:, 1] = (local[:, 1] - middle + 0.5 * height) % height - 0.5 * height + middle
        return local

    def _covered_once(self, polygon):
        """(Sampled at a quarter of the particle spacing: the distance is then off by well under
        a hundredth of it.)"""
        p = self.fluid.points
        out = np.zeros(len(p), dtype=bool)
        box = np.flatnonzero(np.all((p > polygon.min(0) - self.reach) & (p < polygon.max(0) + self.reach), axis=1))
        q = p[box]
        edge = np.roll(polygon, -1, axis=0) - polygon
        count = np.maximum(1, np.ceil(np.linalg.norm(edge, axis=1) / (0.25 * self.fluid.h)).astype(int))
        seg = np.repeat(np.arange(len(polygon)), count)
        frac = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        samples = polygon[seg] + edge[seg] * (frac / count[seg])[:, None]
        dist, _ = cKDTree(samples).query(q, distance_upper_bound=self.reach)
        out[box] = _inside(q, polygon) | np.isfinite(dist)
        return out

    def body(self, t) -> ImposedBody:
        """The bell at time t: the particles it covers, its deformation rate there, free to swim
        along the axis with the momentum of water and bell kept."""
        tau = (t / self.config.period) % 1.0
        if self._at != t:
            self._at, self._covered = t, self.covered(self.outline(t))
            self._rate = self.solid.rate(self.local(self.fluid.points[self._covered]), phase(tau, self.contraction))
        w = _phase_rate(tau, self.contraction) / self.config.period * self._rate
        self._body = ImposedBody(self._covered, w, free_axis=1, momentum=self.momentum0)
        return self._body

    def moved(self, u, dt):
        """The bell swims by the field kept: its speed is what the water on its particles carries
        beyond its own deformation, so water and bell keep their total momentum exactly."""
        mask = self._covered
        if not mask.any():
            return
        volume = self.fluid.volume
        own = self._body.velocity[:, 1] @ volume[mask]
        self.speed = (self.momentum0 - u[~mask, 1] @ volume[~mask] - own) / volume[mask].sum()
        self.y += self.speed * dt
        self.mask = mask


def _phase_rate(tau, contraction):
    """d phase / d tau of bell.phase."""
    tau = np.asarray(tau, float) % 1.0
    up = 0.5 * np.pi / contraction * np.sin(np.pi * tau / contraction)
    down = -0.5 * np.pi / (1.0 - contraction) * np.sin(np.pi * (tau - contraction) / (1.0 - contraction))
    return float(np.where(tau < contraction, up, down))


def _inside(points, polygon):
    """Even-odd rule. The points are lattice points, rows of one height: each row's crossings with
    the polygon's edges are found once and the points counted against them sorted (20 times
    faster than every point against every edge, the same answers)."""
    x, y = points[:, 0], points[:, 1]
    a, b = polygon, np.roll(polygon, -1, axis=0)
    heights, row = np.unique(y, return_inverse=True)
    level = heights[:, None]
    crosses = (a[:, 1] > level) != (b[:, 1] > level)
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = a[:, 0] + (level - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    count = np.zeros(len(points), dtype=np.int64)
    order = np.argsort(row, kind="stable")
    bounds = np.searchsorted(row[order], np.arange(len(heights) + 1))
    for r in range(len(heights)):
        at = order[bounds[r]:bounds[r + 1]]
        cut = np.sort(xs[r, crosses[r]])
        count[at] = len(cut) - np.searchsorted(cut, x[at], side="right")  # crossings right of the point
    return count % 2 == 1


def simulate_cycle(creature: Creature, config: JellyfishConfig | None = None, sample_fields=False,
                   scales: FitnessScales | None = None, stop=None) -> CycleResult:
    """One contraction-relaxation cycle from rest (``simulate_cycles`` with one cycle)."""
    return simulate_cycles(creature, config, 1, sample_fields, scales, stop)


def simulate_cycles(creature: Creature, config: JellyfishConfig | None = None, cycles: int = 1,
                    sample_fields=False, scales: FitnessScales | None = None, stop=None) -> CycleResult:
    """``cycles`` contraction-relaxation cycles in a row from rest, the fluid and the bell carried
    from each into the next. A creature whose bell would fold through itself, or whose stroke is
    too fast for the lattice (more than ``config.max_inner_steps`` inner steps a substep), is
    refused with its reason and fitness -inf; a fluid blow-up raises FluidBlowUp. ``stop()`` is
    polled every substep and a True raises evaluation.Cancelled."""
    config = config or default_config()
    if int(cycles) != cycles or cycles < 1:
        raise ValueError(f"cycles must be a whole number >= 1, got {cycles}")
    cycles = int(cycles)
    t0 = time.perf_counter()
    # the map's far field is the bell's own size, not the water's: a wider box swam 16-23% less
    # with its anchors on the box's border (the same stroke, another deformation of the bell)
    bell_map = BellMap(config.bell, creature, config.bell.diameter)
    energy_b = bell_map.bending_energy()

    def refused(reason):
        return CycleResult(np.nan, energy_b, np.nan, -np.inf, reason, {"total_s": time.perf_counter() - t0})

    reason = check_folds(config.bell, bell_map)
    if reason is not None:
        return refused(reason)
    fluid = lattice_for(config)
    dt = config.period / config.substeps
    # the bell's own fastest point may not cross more than a Courant number of particles per
    # inner step either (the fluid only sees its speed once it has moved)
    reach = float(np.abs(bell_map.displacement).max())
    peak_rate = 0.5 * np.pi / min(creature.contraction, 1.0 - creature.contraction) / config.period
    split = max(1, int(np.ceil(dt * reach * peak_rate / (config.cfl * fluid.h))))
    if split > config.max_inner_steps:
        return refused(f"the stroke is too fast for the lattice: {split} inner steps a substep, at most "
                       f"{config.max_inner_steps} (a longer contraction share, more substeps or max_inner_steps)")
    forcing = BellForcing(fluid, config, bell_map, creature.contraction)
    forcing.mask = forcing.covered(forcing.outline(0.0))
    loss, speeds, swum, fields, inner, per_cycle, loss_per_cycle = 0.0, [], [], [], 0, [], []
    for k in range(cycles * config.substeps):
        if stop is not None and stop():
            from .evaluation import Cancelled

            raise Cancelled(per_cycle)
        for _ in range(split):
            inner += fluid.step(dt / split, forcing, max_inner=config.max_inner_steps)
        fluid_part = ~forcing.mask
        loss += float((fluid.u[fluid_part] ** 2).sum(1) @ fluid.volume[fluid_part])
        speeds.append(forcing.speed)
        swum.append(forcing.y)
        if (k + 1) % config.substeps == 0:
            per_cycle.append(forcing.y - sum(per_cycle))
            loss_per_cycle.append(loss - sum(loss_per_cycle))
        if sample_fields:
            u = np.column_stack([fluid.whole_section(fluid.u[:, 0], odd=True), fluid.whole_section(fluid.u[:, 1])])
            fields.append(((k + 1) * dt, u, fluid.whole_section(fluid.vorticity(), odd=True),
                           fluid.whole_section(forcing.mask.copy())))
    timings = {**fluid.timings, "inner_steps": inner, "total_s": time.perf_counter() - t0}
    return CycleResult(forcing.y, energy_b, loss, fitness(forcing.y, energy_b, loss, config, scales), None, timings,
                       np.array(speeds), np.array(swum), fields, np.array(per_cycle), np.array(loss_per_cycle))



"""Add a jellyfish, optimise its stroke (in the background, Esc keeps the best so far), bake it."""

import bpy

from ..addon.jellyfish import animal as jellyfish
from ..core.jellyfish.bell3d import Anatomy
from ..core.jellyfish.keyframes import FrameRange
from ..core.jellyfish.stroke_search import GOAL_WEIGHTS, Running, Search, optimize
from ..core.jellyfish.swimming import default_config
from ..core.jellyfish.waters import WATERS as WATER_KINDS
from .base import BackgroundOperator, DeformRTOperator

METHODS = (
    ("ga-sa", "Genetic + Annealing", "Breeds strokes from the best so far, now and then keeping a worse one "
     "early on so the search does not settle too soon"),
    ("de", "Differential Evolution", "Mixes the differences between strokes into new ones, on the same budget"),
    ("random", "Random Search", "Strokes drawn at random, to compare"),
)
GOALS = (
    ("EFFICIENT", "Far for Little Effort", "The farthest swim for the bending and the wake's energy it costs"),
    ("FASTEST", "Farthest", "The farthest swim, whatever it costs"),
)
WATERS = tuple((w.key, w.label, w.description) for w in WATER_KINDS.values())


class _NeedsJellyfish:
    @classmethod
    def unavailable(cls, context):
        if jellyfish.jellyfish_of(context.active_object) is None:
            return "Select a jellyfish made with Add Jellyfish"
        return None


class DEFORMRT_OT_add_jellyfish(DeformRTOperator, bpy.types.Operator):
    """Add a jellyfish: a bell turned about its axis, with a velum, veins and tentacles"""

    bl_idname = "deformrt.add_jellyfish"
    bl_label = "Jellyfish"
    bl_options = {"REGISTER", "UNDO"}

    size: bpy.props.FloatProperty(name="Diameter", default=0.3, min=0.001, soft_max=2.0, subtype="DISTANCE",
                                  unit="LENGTH")
    segments: bpy.props.IntProperty(name="Segments", default=48, min=8, max=256)
    tentacles: bpy.props.IntProperty(name="Tentacles", default=16, min=0, max=128)
    tentacle_length: bpy.props.FloatProperty(name="Tentacle Length", description="In bell diameters", default=1.5,
                                             min=0.0, soft_max=5.0)
    veins: bpy.props.IntProperty(name="Veins", default=8, min=0, max=64)
    velum: bpy.props.FloatProperty(name="Velum", description="Inward rim, as a share of the radius", default=0.12,
                                   min=0.0, max=0.6)

    def execute(self, context):
        bell = jellyfish.add(context, self.size, Anatomy(segments=self.segments, velum=self.velum, veins=self.veins,
                                                         tentacles=self.tentacles,
                                                         tentacle_length=self.tentacle_length))
        for obj in context.selected_objects:
            obj.select_set(False)
        bell.select_set(True)
        context.view_layer.objects.active = bell
        self.report({"INFO"}, f"Added {bell.name}: {self.size:.3g} m bell, {self.tentacles} tentacles")
        return {"FINISHED"}


class DEFORMRT_OT_optimize_jellyfish(_NeedsJellyfish, BackgroundOperator, bpy.types.Operator):
    """Search the stroke that swims farthest for its effort and keep it on the jellyfish; Esc keeps the best so far"""

    bl_idname = "deformrt.optimize_jellyfish"
    bl_label = "Optimize Stroke"
    bl_options = {"REGISTER", "UNDO"}

    method: bpy.props.EnumProperty(name="Method", items=METHODS, default="ga-sa")
    population: bpy.props.IntProperty(name="Population", default=10, min=2, max=200, step=2)
    generations: bpy.props.IntProperty(name="Generations", default=30, min=1, max=1000)
    particles: bpy.props.IntProperty(name="Resolution", description="Fluid particles per side (an odd count "
                                     "is rounded up). 100 is quick, not converged: its path is about 1.5 "
                                     "times that of 280, which is within about 5% of converged and "
                                     "about 50 times slower", default=100, min=20, max=400)
    water: bpy.props.EnumProperty(name="Water", items=WATERS, default="axisymmetric")
    viscosity: bpy.props.FloatProperty(
        name="Water Viscosity", default=default_config().viscosity, min=jellyfish.VISCOSITY[0],
        max=jellyfish.VISCOSITY[1], precision=7, step=0.0001,
        description="How thick the water is, in m²/s. The default, ten times water's, swims as a 3 cm medusa does "
        "in water (the same Reynolds number); water's own 0.000001 needs a finer lattice than Resolution gives, "
        "and the path it finds then depends on the lattice")
    goal: bpy.props.EnumProperty(name="Goal", items=GOALS, default="EFFICIENT")
    seed: bpy.props.IntProperty(name="Seed", default=0, min=0)
    workers: bpy.props.IntProperty(name="Processes", description="0 uses every core", default=0, min=0, max=256)

    status = "DeformRT: optimizing (Esc keeps the best so far)"
    keeps_partial = True
    interval = 0.2

    def prepare(self, context):
        population = self.population + self.population % 2  # pairs of parents
        return {"bell": jellyfish.jellyfish_of(context.active_object).name, "population": population,
                "config": default_config(particles=self.particles + self.particles % 2, fluid=self.water,
                                         viscosity=self.viscosity, weights=GOAL_WEIGHTS[self.goal])}

    def work(self, job, progress, stop):
        search = Search(self.method, self.seed, population=job["population"], generations=self.generations)
        running = Running(workers=self.workers or None, stop=stop,
                          progress=lambda done, total, best: progress(done, total, best=best))
        result = optimize(job["config"], search=search, running=running)
        return result

    def status_text(self, state) -> str:
        best = state.get("best", float("nan"))
        return (f"DeformRT: {state['done']}/{state['total']} trial cycles, best score {best:+.3f}"
                + (" (stopping)" if state["stop"] else " (Esc keeps the best so far)"))

    def finish(self, context, job, result):
        bell = bpy.data.objects.get(job["bell"])
        if bell is None:
            return self.fail(RuntimeError("The jellyfish was deleted while optimizing"))
        config = job["config"]
        stored = jellyfish.store_stroke(bell, result, config)
        how = {"cancelled": "stopped early, kept the best", "agreement": "the strokes tried agreed",
               "generations": "all generations tried", "budget": "all trials spent"}.get(result.stopped, result.stopped)
        default = result.scales.path / config.cycles / config.bell.diameter
        self.report({"INFO"}, f"Best stroke: {stored['diameters_per_cycle']:.3f} bell diameters a cycle (the "
                              f"default stroke {default:.3f}), wake energy {100 * stored['energy_share']:.0f}% of "
                              f"the default's "
                              f"({result.evaluations} trial cycles in {result.seconds:.0f} s, {how})")
        return {"FINISHED"}


class DEFORMRT_OT_bake_jellyfish(_NeedsJellyfish, DeformRTOperator, bpy.types.Operator):
    """Animate the jellyfish with its stroke as shape keys and keyframes that play without DeformRT"""

    bl_idname = "deformrt.bake_jellyfish"
    bl_label = "Bake Swimming"
    bl_options = {"REGISTER", "UNDO"}

    frame_start: bpy.props.IntProperty(name="Start", default=1)
    frame_end: bpy.props.IntProperty(name="End", default=96)
    cycle_frames: bpy.props.IntProperty(name="Frames per Cycle", default=24, min=2, max=10000)
    wobble: bpy.props.FloatProperty(name="Wobble", description="Random variation, share of the radius",
                                    default=0.03, min=0.0, max=0.3)
    seed: bpy.props.IntProperty(name="Seed", default=0, min=0)
    water: bpy.props.FloatProperty(name="Water Drag", description="How far the tentacles go with the water the "
                                   "stroke pushes past them (1 is as simulated)", default=1.0, min=0.0,
                                   soft_max=10.0)

    def execute(self, context):
        bell = jellyfish.jellyfish_of(context.active_object)
        try:
            frames = FrameRange(self.frame_start, self.frame_end, self.cycle_frames)
            message = jellyfish.bake(context.scene, bell, frames, self.wobble, self.seed, self.water)
        except (ValueError, RuntimeError) as exc:
            return self.fail(exc)
        self.report({"INFO"}, message)
        return {"FINISHED"}


def menu_add(self, _context):
    self.layout.operator(DEFORMRT_OT_add_jellyfish.bl_idname, icon="OUTLINER_OB_META")


CLASSES = (DEFORMRT_OT_add_jellyfish, DEFORMRT_OT_optimize_jellyfish, DEFORMRT_OT_bake_jellyfish)

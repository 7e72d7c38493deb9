"""Add a jellyfish, optimise its stroke (in the background, Esc keeps the best so far), bake it."""

import bpy

from ..addon.jellyfish import animal as jellyfish
from ..core.jellyfish.swimming import default_config, optimize
from . import background

METHODS = (
    ("ga-sa", "Genetic + Annealing", "The seed's genetic algorithm with simulated-annealing selection"),
    ("de", "Differential Evolution", "scipy's differential evolution on the same budget"),
    ("random", "Random Search", "Uniform random strokes (the baseline)"),
)


class _NeedsJellyfish:
    @classmethod
    def poll(cls, context):
        if jellyfish.jellyfish_of(context.active_object) is None:
            cls.poll_message_set("Select a jellyfish made with Add Jellyfish")
            return False
        return True


class DEFORMRT_OT_add_jellyfish(bpy.types.Operator):
    """Add a jellyfish: the seed's bell turned about its axis, with a velum, veins and tentacles"""

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
        bell = jellyfish.add(context, self.size, self.segments, self.tentacles, self.tentacle_length, self.velum,
                             self.veins)
        for obj in context.selected_objects:
            obj.select_set(False)
        bell.select_set(True)
        context.view_layer.objects.active = bell
        self.report({"INFO"}, f"Added {bell.name}: {self.size:.3g} m bell, {self.tentacles} tentacles")
        return {"FINISHED"}


class DEFORMRT_OT_optimize_jellyfish(_NeedsJellyfish, bpy.types.Operator):
    """Find the stroke that swims best for its effort (seed eq. 3.14) and keep it on the jellyfish;
    in the UI it runs in the background and Esc keeps the best stroke found so far"""

    bl_idname = "deformrt.optimize_jellyfish"
    bl_label = "Optimize Stroke"
    bl_options = {"REGISTER", "UNDO"}

    method: bpy.props.EnumProperty(name="Method", items=METHODS, default="ga-sa")
    population: bpy.props.IntProperty(name="Population", default=10, min=2, max=200, step=2)
    generations: bpy.props.IntProperty(name="Generations", default=30, min=1, max=1000)
    particles: bpy.props.IntProperty(name="Resolution", description="Fluid particles per side", default=100,
                                     min=20, max=400)
    seed: bpy.props.IntProperty(name="Seed", default=0, min=0)
    workers: bpy.props.IntProperty(name="Processes", description="0 uses every core", default=0, min=0, max=256)

    def _run(self, progress=None, stop=None):
        population = self.population + self.population % 2  # pairs of parents
        config = default_config(particles=self.particles)
        result = optimize(config, self.method, self.seed, population=population, generations=self.generations,
                          workers=self.workers or None, progress=progress, stop=stop)
        return result, config

    def execute(self, context):
        bell = jellyfish.jellyfish_of(context.active_object)
        wm = context.window_manager
        wm.progress_begin(0, 100)
        try:
            result, config = self._run(progress=lambda done, total, _best: wm.progress_update(int(100 * done / total)))
        except (ValueError, RuntimeError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        return self._done(bell, result, config)

    def invoke(self, context, _event):
        if context.window is None:
            return self.execute(context)
        self._bell_name = jellyfish.jellyfish_of(context.active_object).name
        self._state = {"done": 0, "total": 1, "stop": False}
        return background.start(self, context, self._work, "DeformRT: optimising (Esc keeps the best so far)",
                                interval=0.2)

    def _work(self):
        def progress(done, total, best):
            self._state.update(done=done, total=total, best=best)

        try:
            self._state["result"] = self._run(progress, lambda: self._state["stop"])
        except (ValueError, RuntimeError) as exc:
            self._state["error"] = exc

    def modal(self, context, event):
        st = self._state
        if event.type == "ESC":
            st["stop"] = True  # the search ends after its running cycles and keeps its best
        if event.type != "TIMER":
            return {"RUNNING_MODAL"} if event.type == "ESC" else {"PASS_THROUGH"}
        wm = context.window_manager
        if self._thread.is_alive():
            wm.progress_update(int(100 * st["done"] / max(st["total"], 1)))
            context.workspace.status_text_set(
                f"DeformRT: {st['done']}/{st['total']} cycles, best fitness {st.get('best', float('nan')):+.3f}"
                + (" (stopping)" if st["stop"] else " (Esc keeps the best so far)"))
            return {"RUNNING_MODAL"}
        background.finish(self, context)
        if "error" in st:
            self.report({"ERROR"}, str(st["error"]))
            return {"CANCELLED"}
        bell = bpy.data.objects.get(self._bell_name)
        if bell is None:
            self.report({"ERROR"}, "The jellyfish was deleted while optimising")
            return {"CANCELLED"}
        return self._done(bell, *st["result"])

    def _done(self, bell, result, config):
        jellyfish.store_stroke(bell, result, config)
        how = "stopped early, kept the best" if result.stopped == "cancelled" else result.stopped
        self.report({"INFO"}, f"Best stroke: fitness {result.fitness:+.3f}, "
                              f"{result.cycle.path_m / config.bell.diameter:.3f} bell diameters per cycle "
                              f"({result.evaluations} cycles in {result.seconds:.0f} s, {how})")
        return {"FINISHED"}


class DEFORMRT_OT_bake_jellyfish(_NeedsJellyfish, bpy.types.Operator):
    """Animate the jellyfish with its stroke: shape keys and keyframes that play and render
    without DeformRT (baking again replaces them)"""

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
            message = jellyfish.bake(context.scene, bell, self.frame_start, self.frame_end, self.cycle_frames,
                                     self.wobble, self.seed, self.water)
        except (ValueError, RuntimeError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, message)
        return {"FINISHED"}


def menu_add(self, _context):
    self.layout.operator(DEFORMRT_OT_add_jellyfish.bl_idname, icon="OUTLINER_OB_META")


CLASSES = (DEFORMRT_OT_add_jellyfish, DEFORMRT_OT_optimize_jellyfish, DEFORMRT_OT_bake_jellyfish)

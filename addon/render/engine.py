"""DeformRT Layered: a render engine that shows garments in layer order without moving them
(thesis 4.4, the image-space mode), shaded Whitted-style by core.whitted.

Objects tagged as body or garments are layered (global normals from the stored
``deformrt_global_normal`` attribute, else each mesh's own normals); everything else is drawn as
it is. Materials come from the Principled BSDF, slot by slot: base colour (or an Image Texture
feeding it straight, read at the UV map that renders), metallic as mirror, transmission and IOR,
roughness as Blinn-Phong shininess, emission (it shows, it lights nothing else). Sun, point,
spot and area lights (area lights sampled on a grid for soft shadows; a light's Shadow switch is
followed). Light strengths are divided by pi on the way in, so the thesis' Lambert term (albedo
times N.L, no 1/pi) gives the radiance Cycles gives: a white surface facing a sun of strength 1
is 1/pi.

With Persistent Data on (Render Properties > Performance), the ray scenes of the last render are
kept while the meshes stay the same, so the next render builds none.

Passes: Combined; Depth and object index (the objects' pass_index) when the view layer asks for
them, written as Cycles writes them; and "DeformRT Fixed", 1 where layered tracing changed what
a pixel shows (for compositing or checking a scene).
"""

import time

import bpy
import numpy as np

from ...core.render.surfaces import Surfaces
from ...core.render.whitted import Image, RenderSettings, camera_rays, render
from ..layers import staleness
from .camera import SUPPORTED, image_shift, ortho_height, render_window, vertical_fov
from .lights import lights, world_colour
from .scene_reading import PERSISTENT, scene_arrays

FIXED_PASS = "DeformRT Fixed"  # 1 where a probe ray changed what the pixel shows
# A frame is traced in bands of about this many pixels: each shows as soon as it is done, Esc
# stops between them. Each band pays the layered loop's rounds of a few rays and the shadow rays'
# thread hand-offs again (Fig 4.12 at 800x800: three bands of 256k pixels took 40-60 ms more
# than one), and a band's working arrays take about 300 bytes a pixel: 1M pixels keeps a band
# near 300 MB and renders 800x800 in one (Cycles' default tile is 2048 x 2048).
BAND_PIXELS = 1 << 20
BACKGROUND_DEPTH = 1e10  # what Cycles writes where no surface is
CAMERA_KINDS = {"PANO": "panoramic", "PERSP": "perspective", "ORTHO": "orthographic"}


# Hard limits, the panel's too: 32 x 32 shadow rays per area light per shaded point is past what
# the eye tells apart; 3000 took about 12,000 s on a 64 x 48 frame
MAX_AREA_SAMPLES = 32
MAX_BOUNCES = 16


class FrameTracer:
    """The scene camera's view as this engine renders it, with the scene's DeformRT settings,
    band by band: the scene is read and its ray scenes built once, then any run of rows is
    traced on its own (so a render can show progress and stop between bands). The world's
    colour lights every surface as ambient (a uniform sky of radiance L gives a Lambert
    surface albedo L), as it does in Cycles, without occlusion."""

    def __init__(self, depsgraph, width, height, window=None):
        """``window``: (left, top, width, height) in pixels from the frame's top left, the part
        of the width x height frame to trace (a render border); None for all of it."""
        scene = depsgraph.scene
        settings = scene.deformrt
        t0 = time.perf_counter()
        read = scene_arrays(depsgraph, settings.render_layered)
        self.scene, self.pass_index, self.kept, self.warnings, self.holdout = (
            read.scene, read.pass_index, read.kept, read.warnings, read.holdout)
        # Ray Visibility off for the camera, shadows, glossy and transmission rays: None where all are on
        self._unseen, self._shadowless, self._unreflected, self._unrefracted = (
            np.array(mask, bool) if any(mask) else None
            for mask in (read.unseen, read.shadowless, read.unreflected, read.unrefracted))
        # once for every band
        self.surfaces = Surfaces.build(self.scene, read.materials, read.slots, read.uvs, read.shading)
        self.seconds = {"read_build_s": time.perf_counter() - t0, "trace_s": 0.0}
        m = np.array(scene.camera.matrix_world)
        cam = scene.camera.data
        shift = image_shift(cam, width, height)
        if cam.type == "ORTHO":
            self.origins, self.directions = camera_rays(m, None, width, height, shift,
                                                       ortho_height=ortho_height(cam, width, height))
        else:
            self.origins, self.directions = camera_rays(m, vertical_fov(cam, width, height), width, height, shift)
        self.width, self.height = width, height
        if window is not None and tuple(window) != (0, 0, width, height):
            left, top, self.width, self.height = window
            pick = ((np.arange(top, top + self.height) * width)[:, None] + np.arange(left, left + self.width)).ravel()
            self.origins, self.directions = self.origins[pick], self.directions[pick]
        # distance along the ray -> along the camera's axis, as Cycles writes depth
        self._to_depth = self.directions @ -m[:3, 2] / np.linalg.norm(m[:3, 2])
        # the clipping planes lie at depths along the camera's axis, as Cycles takes them
        self._clip = (cam.clip_start / self._to_depth, cam.clip_end / self._to_depth)
        self.sky = world_colour(scene.world)
        samples = self._bounded("Area Light Samples", settings.render_area_samples, 1, MAX_AREA_SAMPLES)
        self.lights = lights(depsgraph, samples)
        self.max_depth = self._bounded("Max Bounces", settings.render_max_depth, 0, MAX_BOUNCES)
        self.layered = settings.render_layered
        # what this tracer does not do, said rather than silently left out
        if scene.render.use_motion_blur:
            self.warnings = [*self.warnings, "Motion Blur is on but this engine renders each frame sharp "
                                             "(render with Cycles or Eevee for motion blur)"]
        if cam.dof.use_dof:
            self.warnings = [*self.warnings, f"{scene.camera.name}'s Depth of Field is on but this engine renders "
                                             "everything in focus (render with Cycles or Eevee for it)"]

    def _bounded(self, name, value, low, high) -> int:
        """A setting as the panel allows it; one out of range (a file made so) is named and clamped."""
        if low <= value <= high:
            return value
        clamped = min(max(value, low), high)
        self.warnings = [*self.warnings, f"{name} {value} is outside {low}-{high}: rendered with {clamped}"]
        return clamped

    def rows(self, start, stop) -> tuple[Image, np.ndarray]:
        """(image, depth) of rows start..stop-1, counted from the top."""
        t0 = time.perf_counter()
        sl = slice(start * self.width, stop * self.width)
        settings = RenderSettings(background=self.sky, ambient=np.asarray(self.sky), max_depth=self.max_depth,
                                  layered=self.layered, clip=(self._clip[0][sl], self._clip[1][sl]),
                                  unseen=self._unseen, shadowless=self._shadowless, unreflected=self._unreflected,
                                  unrefracted=self._unrefracted)
        img = render(self.scene, self.surfaces, self.lights, self.origins[sl], self.directions[sl], settings)
        self.seconds["trace_s"] += time.perf_counter() - t0
        return img, img.depth * self._to_depth[sl]


class DEFORMRT_PT_layered_render(bpy.types.Panel):
    bl_idname = "DEFORMRT_PT_layered_render"
    bl_label = "DeformRT Layered"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {"DEFORMRT_LAYERED"}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        settings = context.scene.deformrt
        layout = self.layout
        layout.use_property_split = True
        layout.prop(settings, "render_layered")
        layout.prop(settings, "render_max_depth")
        layout.prop(settings, "render_area_samples")
        layout.prop(settings, "probe_distance")
        layout.prop(settings, "offset")
        layout.prop(context.scene.render, "use_persistent_data")  # Blender's own switch, as Cycles shows it
        # what a user would otherwise read as faults of the picture
        layout.label(text="A quick preview: one ray a pixel, so edges are jagged and seams may show dark", icon="INFO")
        layout.label(text="For the final picture, render the resolved scene with Cycles or Eevee")


class DEFORMRT_RE_layered(bpy.types.RenderEngine):
    bl_idname = "DEFORMRT_LAYERED"
    bl_label = "DeformRT Layered"
    bl_use_preview = False

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        if renderlayer.use_pass_z:
            self.register_pass(scene, renderlayer, "Depth", 1, "Z", "VALUE")
        if renderlayer.use_pass_object_index:
            self.register_pass(scene, renderlayer, "IndexOB", 1, "X", "VALUE")
        self.register_pass(scene, renderlayer, FIXED_PASS, 1, "X", "VALUE")

    def render(self, depsgraph):
        scene = depsgraph.scene
        scale = scene.render.resolution_percentage / 100.0
        w, h = int(scene.render.resolution_x * scale), int(scene.render.resolution_y * scale)
        # with a render border Blender asks for its pixels only, and the results' rows and
        # columns count from its corner: the frame traced here is the border's
        left, bottom_row, bw, bh = render_window(scene.render, w, h)
        self.add_pass(FIXED_PASS, 1, "X")
        cam = scene.camera
        if cam is None or cam.type != "CAMERA" or cam.data.type not in SUPPORTED:
            kind = ("no scene camera" if cam is None or cam.type != "CAMERA"
                    else f"a {CAMERA_KINDS.get(cam.data.type, cam.data.type.lower())} camera")
            self.report({"ERROR"}, f"DeformRT Layered renders perspective and orthographic cameras, the scene has "
                                   f"{kind}: set one as the scene camera, or render with Cycles")
            self.end_result(self.begin_result(0, 0, w, h))
            return
        self.update_stats("", "DeformRT: reading the scene")
        try:
            tracer = FrameTracer(depsgraph, w, h, window=(left, h - bottom_row - bh, bw, bh))
            if tracer.kept:
                self.update_stats("", "DeformRT: ray scenes kept from the last render (Persistent Data)")
            for warning in tracer.warnings:
                self.report({"WARNING"}, f"DeformRT Layered: {warning}")
            for garment, reason in staleness.stale_garments(scene):
                self.report({"WARNING"}, f"DeformRT Layered: {garment.name} renders as fitted: {reason} since the "
                                         "last resolve (Resolve Layers again)")
        except ValueError as exc:  # meshes or settings it cannot trace: say so, not a blank frame
            self.report({"ERROR"}, f"DeformRT Layered: {exc}")
            self.end_result(self.begin_result(0, 0, w, h))
            return
        pass_index = np.array([*tracer.pass_index, 0], np.float32)
        holdout = np.array([*tracer.holdout, False])  # where camera rays first meet a holdout: a hole
        w, h = bw, bh
        transparent = scene.render.film_transparent
        band = max(1, min(h, BAND_PIXELS // max(w, 1)))
        rays = fixed = 0
        for top in range(0, h, band):
            bottom = min(h, top + band)
            img, depth = tracer.rows(top, bottom)
            n = len(img.index)
            hit = img.index >= 0
            colour = img.colour
            if transparent:  # Film > Transparent: what camera rays see of the world is alpha 0, as in Cycles
                colour = np.where(hit[:, None], colour, 0.0)
            alpha = hit.astype(float) if transparent else np.ones(n)
            held = holdout[img.index]
            if held.any():  # a holdout object cuts a hole, (0, 0, 0, 0), film transparent or not, as in Cycles
                colour = np.where(held[:, None], 0.0, colour)
                alpha = np.where(held, 0.0, alpha)
            planes = {"Combined": np.column_stack([colour, alpha]),
                      "Depth": np.where(hit, depth, BACKGROUND_DEPTH)[:, None],
                      "IndexOB": pass_index[img.index][:, None], FIXED_PASS: img.fixed[:, None]}
            # Blender's rows run bottom-up
            # Blender renders each view layer with its own depsgraph: its passes go to that layer
            result = self.begin_result(0, h - bottom, w, bottom - top, layer=depsgraph.view_layer.name)
            for p in result.layers[0].passes:
                if p.name in planes:
                    # foreach_set copies in one go (assigning rect goes pixel by pixel: 0.25 s per
                    # 800x800 pass)
                    rect = planes[p.name].reshape(bottom - top, w, -1)[::-1].astype(np.float32)
                    p.rect.foreach_set(np.ascontiguousarray(rect).ravel())
            self.end_result(result)
            rays, fixed = rays + img.stats["rays"], fixed + int(img.fixed.sum())
            self.update_progress(bottom / h)
            self.update_stats("", f"DeformRT: {rays:,} rays, {fixed:,} pixels fixed")
            if self.test_break():
                break


def _panels():
    """Blender's own panels that work with this engine (render size, output, camera, lights)."""
    keep = {"RENDER_PT_format", "RENDER_PT_output", "RENDER_PT_dimensions", "DATA_PT_lens", "DATA_PT_camera",
            "DATA_PT_light", "DATA_PT_EEVEE_light", "MATERIAL_PT_preview", "EEVEE_MATERIAL_PT_surface",
            "WORLD_PT_context_world", "EEVEE_WORLD_PT_surface", "VIEWLAYER_PT_layer_passes",
            "VIEWLAYER_PT_layer_passes_data"}
    return [getattr(bpy.types, name) for name in keep if hasattr(getattr(bpy.types, name, None), "COMPAT_ENGINES")]


def register():
    bpy.utils.register_class(DEFORMRT_RE_layered)
    bpy.utils.register_class(DEFORMRT_PT_layered_render)
    for panel in _panels():
        panel.COMPAT_ENGINES.add(DEFORMRT_RE_layered.bl_idname)


def unregister():
    PERSISTENT.clear()
    for panel in _panels():
        panel.COMPAT_ENGINES.discard(DEFORMRT_RE_layered.bl_idname)
    bpy.utils.unregister_class(DEFORMRT_PT_layered_render)
    bpy.utils.unregister_class(DEFORMRT_RE_layered)

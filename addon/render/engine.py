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
from dataclasses import replace

import bpy
import numpy as np

from ...core.geometry.cache import Cache
from ...core.geometry.keys import digest
from ...core.layering.probes import body_probes
from ...core.render.layered_trace import LayeredScene
from ...core.render.whitted import Image, Light, Material, Surfaces, camera_rays, render
from ..io import blender_versions, mesh_io
from ..layers import staleness
from ..layers.layer_resolve import GLOBAL_NORMAL_ATTRIBUTE, body_parts, probe_distances

FIXED_PASS = "DeformRT Fixed"  # 1 where a probe ray changed what the pixel shows
# A frame is traced in bands of about this many pixels: each shows as soon as it is done, Esc
# stops between them. Each band pays the layered loop's rounds of a few rays and the shadow rays'
# thread hand-offs again (Fig 4.12 at 800x800: three bands of 256k pixels took 40-60 ms more
# than one), and a band's working arrays take about 300 bytes a pixel: 1M pixels keeps a band
# near 300 MB and renders 800x800 in one (Cycles' default tile is 2048 x 2048).
BAND_PIXELS = 1 << 20
BACKGROUND_DEPTH = 1e10  # what Cycles writes where no surface is


def _materials(obj, depsgraph, known):
    """The Materials of the object's slots as it is evaluated (geometry nodes may set some), in
    slot order. A slot without a material, or an object without slots, takes the object's
    colour where one was set (Object > Viewport Display), else Cycles' default grey of 0.8.
    ``known``: Blender material -> Material, for this frame (each texture read once, however
    many objects or instances wear it)."""
    ev = obj.evaluated_get(depsgraph)
    own = tuple(ev.color[:3])
    fallback = Material(colour=own if own != (1.0, 1.0, 1.0) else (0.8, 0.8, 0.8))
    out = []
    for slot in ev.material_slots:
        mat = slot.material
        key = None if mat is None else mat.as_pointer()
        if key not in known:
            known[key] = _material(mat)
        out.append(known[key] or fallback)
    return out or [fallback]


def _material(mat):
    """The Material of a Blender material; None for no material."""
    if mat is None:
        return None
    bsdf = mat.node_tree.nodes.get("Principled BSDF") if blender_versions.uses_nodes(mat) else None
    if bsdf is None:
        return Material(colour=tuple(mat.diffuse_color[:3]))
    value = lambda name: bsdf.inputs[name].default_value  # noqa: E731
    rough = float(value("Roughness"))
    return Material(colour=tuple(value("Base Color")[:3]), texture=_base_texture(bsdf),
                    specular=0.5 * float(value("Specular IOR Level")),
                    shininess=2.0 / max(rough**4, 1e-4), mirror=float(value("Metallic")),
                    transmission=float(value("Transmission Weight")), ior=float(value("IOR")),
                    emission=tuple(float(value("Emission Strength")) * np.array(value("Emission Color")[:3])))


def _base_texture(bsdf):
    """The (h, w, 3) linear RGB of an Image Texture node whose colour feeds the Base Color straight,
    read at the UV map that renders (its Vector unlinked, or from a UV Map node left on the
    default map or a Texture Coordinate node's UV); None for anything else, which leaves the
    socket's own colour."""
    links = bsdf.inputs["Base Color"].links
    node = links[0].from_node if links else None
    if node is None or node.type != "TEX_IMAGE" or node.image is None or links[0].from_socket.name != "Color":
        return None
    vector = node.inputs["Vector"].links
    source = vector[0].from_node if vector else None
    if source is not None and not ((source.type == "UVMAP" and not source.uv_map)
                                   or (source.type == "TEX_COORD" and vector[0].from_socket.name == "UV")):
        return None  # another map, or coordinates of another kind
    image = node.image
    w, h = image.size
    channels = image.channels
    if not w or not h or channels < 3:
        return None
    pixels = np.empty(w * h * channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)  # rows bottom up, as UV v runs
    rgb = np.ascontiguousarray(pixels.reshape(h, w, channels)[..., :3])  # float32: a 4k image is 190 MB
    del pixels
    if image.colorspace_settings.name == "sRGB":
        low = rgb <= 0.04045
        rgb = np.where(low, rgb / np.float32(12.92), ((rgb + np.float32(0.055)) / np.float32(1.055)) ** np.float32(2.4))
    return rgb


def _lights(depsgraph, area_samples=4):
    out = []
    for inst in depsgraph.object_instances:
        obj = inst.object
        if obj.type != "LIGHT":
            continue
        m = np.array(inst.matrix_world)
        light = obj.data
        # a Lambert surface sends E albedo / pi; power as Blender takes it: colour (times the
        # blackbody colour of its temperature when that is on) x strength x 2^exposure
        colour = np.array(light.color) * blender_versions.light_power(light) / np.pi
        tint = blender_versions.light_tint(light)
        if tint is not None:
            colour = colour * np.array(tint)
        if light.type == "SUN":
            out.append(Light("SUN", tuple(-m[:3, 2]), tuple(colour), shadow=light.use_shadow))
        elif light.type == "POINT":
            # a point lamp of P watts sends P / (4 pi) per steradian
            out.append(Light("POINT", tuple(m[:3, 3]), tuple(colour / (4 * np.pi)), shadow=light.use_shadow))
        elif light.type == "SPOT":
            # as bright as a point lamp of its power inside its cone, which points down its local -z
            out.append(Light("SPOT", tuple(m[:3, 3]), tuple(colour / (4 * np.pi)), axis=tuple(-m[:3, 2]),
                             spot_size=float(light.spot_size), spot_blend=float(light.spot_blend),
                             shadow=light.use_shadow))
        elif light.type == "AREA":
            # P watts off a Lambertian patch: P / pi per steradian along its normal (local -z)
            sx = light.size
            sy = light.size if light.shape in ("SQUARE", "DISK") else light.size_y
            u, v = m[:3, 0] * sx / 2, -m[:3, 1] * sy / 2  # u x v = -z: the side it lights
            disk = light.shape in ("DISK", "ELLIPSE")
            if not light.normalize:  # its strength is per square metre: the power grows with its area
                colour = colour * float(np.linalg.norm(np.cross(u, v))) * (np.pi if disk else 4.0)
            out.append(Light("AREA", tuple(m[:3, 3]), tuple(colour / np.pi), edges=(tuple(u), tuple(v)),
                             disk=disk, samples=area_samples, shadow=light.use_shadow))
    return out


def _meshes(depsgraph):
    """(object, its MeshArrays in world space, whether it stays outside the layering: an instance,
    the Materials of its slots) of every mesh the depsgraph shows: in a render, what renders (an
    object off for rendering is not there, one only hidden in the viewport is), the meshes
    collections and geometry nodes instance, and what curves, text and surfaces evaluate to."""
    known = {}
    for inst in depsgraph.object_instances:
        # a curve, text or surface object comes as its own entry and, what renders of it, as
        # an instance of the mesh it evaluates to: only meshes are read
        if inst.object.type != "MESH":
            continue
        obj = inst.object if inst.is_instance else inst.object.original
        mats = _materials(obj, depsgraph, known)
        textured = any(m.texture is not None for m in mats)  # UVs only where a texture reads them
        if not inst.is_instance:
            yield obj, mesh_io.read_mesh(obj, depsgraph, slots=len(mats) > 1, shading=True, uvs=textured), False, mats
            continue
        # the instanced object's mesh, placed by the instance (read now: the iterator moves on)
        a = mesh_io.read_mesh(obj, depsgraph, world=False, slots=len(mats) > 1, shading=True, uvs=textured)
        m = np.array(inst.matrix_world, dtype=np.float64)
        normals = (None if a.triangle_normals is None
                   else mesh_io.world_normals(a.triangle_normals.reshape(-1, 3), m).reshape(-1, 3, 3))
        yield obj, mesh_io.MeshArrays(a.vertices @ m[:3, :3].T + m[:3, 3], a.triangles, a.triangle_polygon,
                                      a.n_polygons, m, a.triangle_material, a.triangle_uv, normals), True, mats


def finite_part(a):
    """(``a`` without the triangles that have a corner at no finite position, how many went): a
    cloth solver that blew up or a driver dividing by zero leaves NaN or infinite vertices, and
    Cycles renders the rest of such a mesh. The lost vertices, which no triangle then uses, take
    a finite vertex's place so that boxes and searches over the mesh stay finite; corner
    normals Blender blended from a lost neighbour take their triangle's own normal."""
    lost = ~np.isfinite(a.vertices).all(axis=1)
    if not lost.any():
        return a, 0
    keep = ~lost[a.triangles].any(axis=1)
    vertices = a.vertices.copy()
    vertices[lost] = vertices[~lost][0] if (~lost).any() else 0.0
    tris = a.triangles[keep]
    normals = None
    if a.triangle_normals is not None:
        normals = a.triangle_normals[keep].copy()
        odd = ~np.isfinite(normals).all(axis=2)
        if odd.any():
            c = vertices[tris]
            flat = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
            flat /= np.maximum(np.linalg.norm(flat, axis=1, keepdims=True), 1e-300)
            normals[odd] = np.broadcast_to(flat[:, None], normals.shape)[odd]
    pick = lambda x: None if x is None else x[keep]  # noqa: E731
    return replace(a, vertices=vertices, triangles=tris, triangle_polygon=a.triangle_polygon[keep],
                   triangle_material=pick(a.triangle_material), triangle_uv=pick(a.triangle_uv),
                   triangle_normals=normals), int((~keep).sum())


# With the scene's Persistent Data on (Render Properties > Performance, as Cycles has it), the
# last frame's ray scenes (the BVHs, what is worn over each layer) are kept for the next render
# of the same meshes: look-development renders of a still pose build nothing again.
PERSISTENT = Cache(max_entries=1)


def _scene_key(objects, layers, normals, probe, offset):
    """A digest of all a LayeredScene is made from."""
    parts = [np.array([float(offset)]), np.array([-1 if lay is None else lay for lay in layers])]
    probes = probe if isinstance(probe, (list, tuple)) else [probe] * len(objects)
    for (v, f), n, p in zip(objects, normals, probes, strict=True):
        parts += [v, f, np.zeros(0) if n is None else n, np.full(1, np.nan) if p is None else np.atleast_1d(p)]
    return digest(*parts)


def layered_scene(objects, layers, normals, probe, offset, keep=False):
    """(LayeredScene, whether it was kept from the last render): with ``keep``, the last one if it
    was made from the same arrays, else a new one kept in its place; without, a new one, and
    nothing is held."""
    if not keep:
        PERSISTENT.clear()
        return LayeredScene(objects, layers, normals, probe_distance=probe, offset=offset), False
    key = _scene_key(objects, layers, normals, probe, offset)
    found = PERSISTENT.get(key)
    if found is not None:
        return found, True
    PERSISTENT.clear()  # the old scene's memory goes before the new one's comes
    made = LayeredScene(objects, layers, normals, probe_distance=probe, offset=offset)
    PERSISTENT.put(key, made)
    return made, False


def scene_arrays(depsgraph, layered=True):
    """(LayeredScene, materials, face slots, face UVs, corner normals, pass indices, whether the
    LayeredScene was kept from the last render: ``layered_scene``, what it left out to say so:
    ``finite_part``, per object whether it is hidden from the camera) of the meshes
    the depsgraph shows, in world space: per object the Materials of its slots, each triangle's
    slot, for textured materials its corners' UVs, its corners' shading normals as Blender
    gives them (None for a mesh smooth all over), and its pass index. Instances are drawn as
    they are, outside the layering. Without ``layered`` (plain ray tracing) the global
    normals, body parts and probe distances that only layering uses are not read."""
    objects, layers, normals, materials, slots, uvs, shading, pass_index, warnings, unseen = ([] for _ in range(10))
    settings = depsgraph.scene.deformrt
    parts = None
    for obj, a, outside, mats in _meshes(depsgraph):
        a, lost = finite_part(a)
        if lost:
            warnings.append(f"{obj.name}: {lost} triangles at no finite position (NaN or infinite) left out")
        if not len(a.triangles):
            continue
        role = "NONE" if outside else obj.deformrt.role
        if role == "GARMENT" and not obj.visible_camera:
            role = "NONE"  # a garment the camera does not see covers nothing it sees
        objects.append((a.vertices, a.triangles))
        layers.append(None if role == "NONE" else (0 if role == "BODY" else obj.deformrt.layer))
        n = mesh_io.read_point_vectors(obj, GLOBAL_NORMAL_ATTRIBUTE, depsgraph) if layered and role != "NONE" else None
        # stored in object space; normals turn with the inverse transpose
        normals.append(None if n is None or len(n) != len(a.vertices) else n @ np.linalg.inv(a.matrix_world[:3, :3]))
        materials.append(mats)
        slots.append(a.triangle_material if len(mats) > 1 else None)
        uvs.append(a.triangle_uv)
        shading.append(a.triangle_normals)
        pass_index.append(obj.pass_index)  # read now: an instance's object lasts while it is iterated
        unseen.append(not obj.visible_camera)
        if layered and role == "BODY":
            # no vertex groups: reading them adds a modifier, and a render must not write to the scene
            parts, _ = body_parts(obj, settings.scheme, a.vertices, groups=False, depsgraph=depsgraph)
            if parts is not None and len(parts) != len(a.vertices):
                parts = None
    scheme = settings.scheme if parts is not None else None  # body_parts finds none without a scheme
    probe = 0.0
    if layered:
        top = max((lay for lay in layers if lay is not None), default=0)
        probe = body_probes(objects, layers, probe_distances(settings, parts is not None), parts, scheme,
                            traced=[lay is not None and lay < top for lay in layers])
    made, kept = layered_scene(objects, layers, normals, probe, settings.offset,
                               keep=depsgraph.scene.render.use_persistent_data)
    return made, materials, slots, uvs, shading, pass_index, kept, warnings, unseen


def _background(world):
    if world is not None and blender_versions.uses_nodes(world) and "Background" in world.node_tree.nodes:
        node = world.node_tree.nodes["Background"]
        return tuple(np.array(node.inputs["Color"].default_value[:3]) * node.inputs["Strength"].default_value)
    return tuple(world.color) if world is not None else (0.05, 0.05, 0.05)


def _fitted_half(cam, width, height):
    """(tan of half the field of view across the dimension the sensor fits, whether that is the
    width) for a width x height image, as Blender fits the sensor."""
    if cam.type != "PERSP":
        raise ValueError(f"DeformRT Layered renders perspective cameras only, not {cam.type.lower()}")
    fit = cam.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if width >= height else "VERTICAL"
        half = cam.sensor_width / (2 * cam.lens)  # AUTO fits the sensor width to the longer side
    else:
        half = (cam.sensor_width if fit == "HORIZONTAL" else cam.sensor_height) / (2 * cam.lens)
    return half, fit == "HORIZONTAL"


def vertical_fov(cam, width, height):
    """The camera's vertical field of view for a width x height image (sensor fit as Blender)."""
    half, horizontal = _fitted_half(cam, width, height)
    return 2 * np.arctan(half * height / width if horizontal else half)


def image_shift(cam, width, height):
    """The camera's lens shift as an offset of the image's centre on the image plane at distance
    1: Blender's shift_x and shift_y count in whole widths of the fitted dimension."""
    half, _ = _fitted_half(cam, width, height)
    return 2 * half * cam.shift_x, 2 * half * cam.shift_y


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
        self.scene, materials, slots, uvs, shading, self.pass_index, self.kept, self.warnings, unseen = scene_arrays(
            depsgraph, settings.render_layered)
        self._unseen = np.array(unseen, bool) if any(unseen) else None  # hidden from the camera
        self.surfaces = Surfaces.build(self.scene, materials, slots, uvs, shading)  # once for every band
        self.seconds = {"read_build_s": time.perf_counter() - t0, "trace_s": 0.0}
        m = np.array(scene.camera.matrix_world)
        self.origins, self.directions = camera_rays(m, vertical_fov(scene.camera.data, width, height), width, height,
                                                   shift=image_shift(scene.camera.data, width, height))
        self.width, self.height = width, height
        if window is not None and tuple(window) != (0, 0, width, height):
            left, top, self.width, self.height = window
            pick = ((np.arange(top, top + self.height) * width)[:, None] + np.arange(left, left + self.width)).ravel()
            self.origins, self.directions = self.origins[pick], self.directions[pick]
        # distance along the ray -> along the camera's axis, as Cycles writes depth
        self._to_depth = self.directions @ -m[:3, 2] / np.linalg.norm(m[:3, 2])
        # the clipping planes lie at depths along the camera's axis, as Cycles takes them
        cam = scene.camera.data
        self._clip = (cam.clip_start / self._to_depth, cam.clip_end / self._to_depth)
        self.sky = _background(scene.world)
        self.lights = _lights(depsgraph, settings.render_area_samples)
        self.max_depth, self.layered = settings.render_max_depth, settings.render_layered

    def rows(self, start, stop) -> tuple[Image, np.ndarray]:
        """(image, depth) of rows start..stop-1, counted from the top."""
        t0 = time.perf_counter()
        sl = slice(start * self.width, stop * self.width)
        img = render(self.scene, self.surfaces, self.lights, self.origins[sl], self.directions[sl],
                     background=self.sky, ambient=np.asarray(self.sky), max_depth=self.max_depth,
                     layered=self.layered, clip=(self._clip[0][sl], self._clip[1][sl]), unseen=self._unseen)
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
        if cam is None or cam.type != "CAMERA" or cam.data.type != "PERSP":
            self.report({"ERROR"}, "DeformRT Layered needs a perspective scene camera")
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
            planes = {"Combined": np.column_stack([colour, hit if transparent else np.ones(n)]),
                      "Depth": np.where(hit, depth, BACKGROUND_DEPTH)[:, None],
                      "IndexOB": pass_index[img.index][:, None], FIXED_PASS: img.fixed[:, None]}
            # Blender's rows run bottom-up
            result = self.begin_result(0, h - bottom, w, bottom - top)
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


def render_window(rd, width, height):
    """(left, bottom, width, height) in pixels of what a render asks for: the render border's
    pixels when one is on (as Blender rounds it: float32 fractions of the frame, truncated), else
    the whole width x height frame."""
    if not rd.use_border:
        return 0, 0, width, height
    edge = [int(np.float32(f) * np.float32(size)) for f, size in ((rd.border_min_x, width), (rd.border_max_x, width),
                                                                  (rd.border_min_y, height), (rd.border_max_y, height))]
    return edge[0], edge[2], max(edge[1] - edge[0], 0), max(edge[3] - edge[2], 0)


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

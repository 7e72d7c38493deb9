"""The DEFORMRT_LAYERED render engine through bpy.ops.render.render in background mode."""

import importlib

import bpy
import numpy as np
import pytest


@pytest.fixture
def studio(extension):
    return importlib.import_module(f"{extension.__name__}.sample_scenes.studio")


def _render(studio, scene, tmp_path, size=(32, 32), passes=("Image",)):
    """The named passes of one render (one pass: its array)."""
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    planes = studio.render_passes(scene, tmp_path / "passes", passes)
    return planes[passes[0]] if len(passes) == 1 else planes


def _material(obj, colour):
    mat = bpy.data.materials.new(f"M{colour}")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = 1.0
    obj.data.materials.append(mat)


def _stage(scene, sun_strength=2.0):
    world = bpy.data.worlds.new("Black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.world = world
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = sun_strength  # shines down -z at rest
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.location = (0, 0, 5)  # looks down -z at rest
    scene.collection.objects.link(cam)
    scene.camera = cam


def _engine(scene):
    scene.render.engine = "DEFORMRT_LAYERED"
    return scene


def test_engine_is_registered_and_shades_a_sphere_by_lambert(studio, clean_scene, tmp_path):
    assert "DEFORMRT_LAYERED" in {getattr(e, "bl_idname", None) for e in bpy.types.RenderEngine.__subclasses__()}
    scene = _engine(clean_scene)
    _stage(scene)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    _material(bpy.context.active_object, (0.5, 0.4, 0.3))
    px = _render(studio, scene, tmp_path)
    # straight under the sun and the camera: E albedo cos(0) / pi, as Cycles shades a Lambert surface
    centre = px[15:17, 15:17, :3].reshape(-1, 3)
    np.testing.assert_allclose(centre, np.tile([1.0, 0.8, 0.6], (4, 1)) / np.pi, rtol=0.01)
    np.testing.assert_allclose(px[0, 0, :3], 0.0)  # the corner sees the black world
    # the 50 mm lens on a 36 mm sensor at 5 m sees 3.6 m across: the sphere is 2 m wide
    covered = px[..., 0] > 0
    assert abs(covered[16].sum() / 32 - 2.0 / 3.6) < 0.08


def _garment_pair(scene):
    """A tagged shirt whose bumps poke through a flat jacket over it, and an empty body."""
    made = []
    for name, layer, colour, bump in (("Shirt", 1, (1.0, 0.0, 0.0), 0.004), ("Jacket", 2, (0.0, 0.0, 1.0), 0.0)):
        bpy.ops.mesh.primitive_grid_add(x_subdivisions=24, y_subdivisions=24, size=2.0)
        obj = bpy.context.active_object
        obj.name = name
        co = np.empty(len(obj.data.vertices) * 3)
        obj.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        co[:, 2] += bump * np.sin(29 * co[:, 0]) * np.cos(31 * co[:, 1])  # the shirt pokes through
        obj.data.vertices.foreach_set("co", co.ravel())
        obj.data.update()
        obj.deformrt.role, obj.deformrt.layer = "GARMENT", layer
        _material(obj, colour)
        made.append(obj)
    body = bpy.data.objects.new("Body", bpy.data.meshes.new("Body"))
    scene.collection.objects.link(body)
    body.deformrt.role = "BODY"
    scene.deformrt.probe_distance = 0.02
    return made


def test_coincident_garments_show_the_outer_layer_only(studio, clean_scene, tmp_path):
    scene = _engine(clean_scene)
    _stage(scene)
    _garment_pair(scene)
    px = _render(studio, scene, tmp_path)
    covered = px[..., :3].sum(-1) > 0
    assert covered.mean() > 0.1
    assert (px[covered, 0] < 1e-6).all() and (px[covered, 2] > 0.5).all()  # only the jacket's blue
    # the same scene untagged is plain ray tracing: the shirt's red shows where it pokes out
    for name in ("Shirt", "Jacket"):
        bpy.data.objects[name].deformrt.role = "NONE"
    px = _render(studio, scene, tmp_path)
    assert (px[..., 0] > 0.3).mean() > 0.05
    # as does the Layered switch off
    for name in ("Shirt", "Jacket"):
        bpy.data.objects[name].deformrt.role = "GARMENT"
    scene.deformrt.render_layered = False
    np.testing.assert_array_equal(_render(studio, scene, tmp_path), px)


def test_depth_object_index_and_fixed_passes(extension, studio, clean_scene, tmp_path, monkeypatch):
    """A floor 5 m below the camera (depth 5 everywhere: Depth is along the camera's axis) and a
    sphere on it; the sphere's pass index where it shows; the fixed pass where a covered shirt
    would have shown."""
    scene = _engine(clean_scene)
    _stage(scene)
    view = scene.view_layers[0]
    view.use_pass_z = view.use_pass_object_index = True
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    floor = bpy.context.active_object
    floor.pass_index = 3
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0, 0, 0.5), segments=64, ring_count=32)
    ball = bpy.context.active_object
    ball.pass_index = 7
    # 1024 x 300 in bands of 256 rows: two (256 rows, then 44), both must land where they belong
    engine = importlib.import_module(f"{extension.__name__}.addon.render.engine")
    monkeypatch.setattr(engine, "BAND_PIXELS", 1024 * 256)
    bands = []
    monkeypatch.setattr(engine.FrameTracer, "rows", lambda self, a, b, rows=engine.FrameTracer.rows: (
        bands.append((a, b)), rows(self, a, b))[1])
    px = _render(studio, scene, tmp_path, size=(1024, 300), passes=("Depth", "IndexOB", "DeformRT Fixed"))
    assert bands == [(0, 256), (256, 300)]
    monkeypatch.undo()
    on_floor = px["IndexOB"] == 3
    assert on_floor.mean() > 0.6 and (px["IndexOB"] == 7).sum() > 20
    np.testing.assert_allclose(px["Depth"][on_floor], 5.0, rtol=1e-5)
    # the sphere's top (z = 1), straight below the camera: 4 m, in the middle of the image
    assert abs(px["Depth"][149:151, 511:513].mean() - 4.0) < 0.01
    rows = np.flatnonzero((px["IndexOB"] == 7).any(1))
    assert abs(rows.mean() - 149.5) < 1.0
    assert set(np.unique(px["IndexOB"])) == {3.0, 7.0}
    assert not px["DeformRT Fixed"].any()
    # two coincident tagged garments: fixed exactly where the plain render shows the lower one
    for obj in (floor, ball):
        bpy.data.objects.remove(obj)
    shirt, jacket = _garment_pair(scene)
    shirt.pass_index, jacket.pass_index = 1, 2
    layered = _render(studio, scene, tmp_path, passes=("IndexOB", "DeformRT Fixed"))
    scene.deformrt.render_layered = False
    plain = _render(studio, scene, tmp_path, passes=("IndexOB", "DeformRT Fixed"))
    assert not plain["DeformRT Fixed"].any()
    shows_shirt = plain["IndexOB"] == 1
    assert 0.05 < shows_shirt.mean() < 0.9
    np.testing.assert_array_equal(layered["DeformRT Fixed"] > 0.5, shows_shirt)
    assert not (layered["IndexOB"] == 1).any()


def test_the_cameras_clipping_planes_cut_what_it_sees_at_their_depths(studio, clean_scene, tmp_path):
    """A sheet 5 cm in front of the lens (nearer than the default 0.1 m clip start) is not seen and
    a 40 m floor 5 m below is, to its corners: the planes lie at depths along the camera's axis,
    as Cycles takes them (along each ray, a clip end of 5.2 m would cut the corners, 5.5 m away).
    With the clip start at 1 cm the sheet covers the view; with the clip end at 4.9 m nothing shows."""
    scene = _engine(clean_scene)
    _stage(scene)
    view = scene.view_layers[0]
    view.use_pass_z = view.use_pass_object_index = True
    for index, z in ((1, 4.95), (2, 0.0)):
        bpy.ops.mesh.primitive_plane_add(size=40.0, location=(0, 0, z))
        bpy.context.active_object.pass_index = index
    cam = scene.camera.data
    cam.clip_end = 5.2
    px = _render(studio, scene, tmp_path, passes=("Depth", "IndexOB"))
    np.testing.assert_array_equal(px["IndexOB"], 2)
    np.testing.assert_allclose(px["Depth"], 5.0, rtol=1e-5)
    cam.clip_start = 0.01
    px = _render(studio, scene, tmp_path, passes=("Depth", "IndexOB"))
    np.testing.assert_array_equal(px["IndexOB"], 1)
    np.testing.assert_allclose(px["Depth"], 0.05, rtol=1e-4)
    cam.clip_start, cam.clip_end = 0.1, 4.9
    px = _render(studio, scene, tmp_path, passes=("IndexOB",))
    np.testing.assert_array_equal(px, 0)


@pytest.mark.parametrize("size", [(64, 40), (40, 64)])
def test_a_shifted_lens_frames_the_view_as_cycles_does(studio, clean_scene, tmp_path, size):
    """Spheres in a row seen through a lens shifted right and down, on a landscape frame (the
    sensor fits its width) and a portrait one (its height): every object shows where Cycles
    shows it, all but the pixels along their edges, which Cycles' pixel filter blends."""
    scene = _engine(clean_scene)
    _stage(scene)
    scene.view_layers[0].use_pass_object_index = True
    for i, x in enumerate((-1.6, -0.4, 0.8, 2.0)):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.45, location=(x, 0.3 * i - 0.5, 0.0))
        bpy.context.active_object.pass_index = i + 1
    cam = scene.camera.data
    cam.shift_x, cam.shift_y = 0.3, -0.2
    ours = _render(studio, scene, tmp_path, size=size, passes=("IndexOB",))
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.filter_width = 1, 0.01
    cycles = _render(studio, scene, tmp_path, size=size, passes=("IndexOB",))
    assert len(np.unique(cycles)) >= 3  # the shift keeps most of the row in view
    covered = (ours > 0) | (cycles > 0)
    assert (ours[covered] == cycles[covered]).mean() > 0.97  # 1.0 here
    cam.shift_x = cam.shift_y = 0.0
    scene.render.engine = "DEFORMRT_LAYERED"
    assert (_render(studio, scene, tmp_path, size=size, passes=("IndexOB",)) != ours).mean() > 0.05


@pytest.mark.parametrize("size, fit", [((64, 40), "AUTO"), ((40, 64), "AUTO"), ((64, 40), "VERTICAL")])
def test_an_orthographic_camera_frames_the_view_as_cycles_does(studio, clean_scene, tmp_path, size, fit):
    """The same row of spheres, orthographic, its lens shifted: every object where Cycles shows it,
    and the depth pass the distance from the camera's plane."""
    scene = _engine(clean_scene)
    _stage(scene)
    scene.view_layers[0].use_pass_object_index = True
    scene.view_layers[0].use_pass_z = True
    for i, x in enumerate((-1.6, -0.4, 0.8, 2.0)):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.45, location=(x, 0.3 * i - 0.5, 0.0))
        bpy.context.active_object.pass_index = i + 1
    cam = scene.camera.data
    cam.type, cam.ortho_scale, cam.sensor_fit = "ORTHO", 5.0, fit
    cam.shift_x, cam.shift_y = 0.1, -0.05
    ours = _render(studio, scene, tmp_path, size=size, passes=("IndexOB", "Depth"))
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.filter_width = 1, 0.01
    cycles = _render(studio, scene, tmp_path, size=size, passes=("IndexOB", "Depth"))
    assert len(np.unique(cycles["IndexOB"])) >= 4
    covered = (ours["IndexOB"] > 0) | (cycles["IndexOB"] > 0)
    assert (ours["IndexOB"][covered] == cycles["IndexOB"][covered]).mean() > 0.97
    both = (ours["IndexOB"] > 0) & (ours["IndexOB"] == cycles["IndexOB"])
    np.testing.assert_allclose(ours["Depth"][both], cycles["Depth"][both], atol=0.02)  # faceted spheres
    assert ours["Depth"][both].min() > 4.5 - 1e-6  # the nearest sphere point lies 4.55 below the camera


def test_an_empty_scene_renders_the_world_and_a_panoramic_camera_is_refused(studio, clean_scene, tmp_path):
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=1.0)
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.2, 0.3, 0.4, 1)
    px = _render(studio, scene, tmp_path)
    np.testing.assert_allclose(px[..., :3], np.broadcast_to([0.2, 0.3, 0.4], px[..., :3].shape), atol=1e-3)
    scene.camera.data.type = "PANO"
    with pytest.raises(RuntimeError, match="perspective and orthographic cameras.*panoramic"):
        _render(studio, scene, tmp_path)


def test_a_render_border_renders_its_pixels_of_the_frame(studio, clean_scene, tmp_path):
    """With a render border (Ctrl+B), the frame holds that border's pixels of the full render and
    nothing else, where Cycles writes them; cropped to it, the image is just those pixels."""
    scene = _engine(clean_scene)
    _stage(scene)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.2, location=(0.3, -0.2, 0.0))
    full = _render(studio, scene, tmp_path, size=(64, 48))
    rd = scene.render
    rd.use_border = True
    rd.border_min_x, rd.border_max_x, rd.border_min_y, rd.border_max_y = 0.3, 0.8, 0.25, 0.7
    # Blender's pixels of it: float32 fractions of the frame, truncated; rows counted from the bottom
    x0, x1, y0, y1 = (int(np.float32(f) * np.float32(n)) for f, n in ((0.3, 64), (0.8, 64), (0.25, 48), (0.7, 48)))
    inside = np.zeros((48, 64), bool)
    inside[48 - y1:48 - y0, x0:x1] = True
    framed = _render(studio, scene, tmp_path, size=(64, 48))
    np.testing.assert_array_equal(framed[inside], full[inside])
    assert (full[inside][:, :3] > 0).any() and (framed[~inside] == 0).all()
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    np.testing.assert_array_equal(_render(studio, scene, tmp_path, size=(64, 48))[..., 3] > 0, inside)
    scene.render.engine = "DEFORMRT_LAYERED"
    rd.use_crop_to_border = True
    np.testing.assert_array_equal(_render(studio, scene, tmp_path, size=(64, 48)),
                                  full[inside].reshape(y1 - y0, x1 - x0, 4))


def test_a_transparent_film_makes_the_world_alpha_zero_as_cycles_does(studio, clean_scene, tmp_path):
    """Film > Transparent: pixels whose camera ray meets nothing are (0, 0, 0, 0), premultiplied,
    where Cycles' are; the rest are as before, opaque."""
    scene = _engine(clean_scene)
    _stage(scene)
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.4, 0.5, 1)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.2)
    opaque = _render(studio, scene, tmp_path)
    scene.render.film_transparent = True
    clear = _render(studio, scene, tmp_path)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.filter_width = 1, 0.01
    cycles = _render(studio, scene, tmp_path)
    empty = cycles[..., 3] == 0
    assert 0.2 < empty.mean() < 0.9
    np.testing.assert_array_equal(clear[empty], 0.0)
    np.testing.assert_array_equal(clear[~empty], opaque[~empty])
    np.testing.assert_allclose(opaque[empty][:, :3], np.tile([0.3, 0.4, 0.5], (int(empty.sum()), 1)), rtol=1e-6)


def test_an_object_hidden_from_the_camera_still_casts_its_shadow(studio, clean_scene, tmp_path):
    """A ball over a floor with Ray Visibility > Camera off: camera rays pass through it to the
    floor, whose object index shows everywhere as in Cycles, and its shadow stays: the floor
    under it gets the world's light only."""
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=2.0)
    scene.view_layers[0].use_pass_object_index = True
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    bpy.context.active_object.pass_index = 1
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(0, 0, 1.5))
    ball = bpy.context.active_object
    ball.pass_index = 2
    seen = _render(studio, scene, tmp_path, passes=("IndexOB",))
    assert (seen == 2).mean() > 0.05
    ball.visible_camera = False
    px = _render(studio, scene, tmp_path, passes=("Image", "IndexOB"))
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.filter_width = 1, 0.01
    np.testing.assert_array_equal(px["IndexOB"], _render(studio, scene, tmp_path, passes=("IndexOB",)))
    np.testing.assert_array_equal(px["IndexOB"], 1)
    # the floor point each pixel sees (5 m below the 50 mm lens: 1.8 m from the middle to the
    # edge); the sun straight down casts the ball's shadow as a disc of its radius
    c = ((np.arange(32) + 0.5) / 32 * 2 - 1) * 1.8
    r = np.hypot(c[None, :], c[::-1, None])
    np.testing.assert_allclose(px["Image"][r < 0.75][:, :3], 0.0, atol=1e-6)  # a black world lights nothing
    np.testing.assert_allclose(px["Image"][r > 0.85][:, :3], 2.0 * 0.8 / np.pi, rtol=1e-5)
    assert (r < 0.75).sum() > 20 and ((r > 0.85) & (seen == 2)).sum() > 20  # seen past its shadow, too


def test_an_object_that_casts_no_shadow_leaves_the_floor_lit_as_cycles_does(studio, clean_scene, tmp_path):
    """The same ball with Ray Visibility > Shadow off: it is seen, and the floor under it is lit
    by the sun as everywhere else; Cycles agrees where its shadow was."""
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=2.0)
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(0, 0, 1.5))
    ball = bpy.context.active_object
    ball.visible_camera = False  # to see the floor where the shadow would fall
    shadowed = _render(studio, scene, tmp_path)
    ball.visible_shadow = False
    lit = _render(studio, scene, tmp_path)
    c = ((np.arange(32) + 0.5) / 32 * 2 - 1) * 1.8
    r = np.hypot(c[None, :], c[::-1, None])
    np.testing.assert_allclose(shadowed[r < 0.75][:, :3], 0.0, atol=1e-6)
    np.testing.assert_allclose(lit[..., :3], 2.0 * 0.8 / np.pi, rtol=1e-5)  # lit all over, as the open floor
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.filter_width = 4, 0.01
    cycles = _render(studio, scene, tmp_path)
    assert cycles[r < 0.75][:, :3].min() > 0.5 * 2.0 * 0.8 / np.pi  # Cycles: no shadow there either


def test_a_holdout_cuts_a_hole_where_cycles_does(studio, clean_scene, tmp_path):
    """A holdout ball in front of a lit floor: (0, 0, 0, 0) where it is the first thing seen, as
    Cycles leaves it, the rest as before."""
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=2.0)
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(0, 0, 1.5))
    ball = bpy.context.active_object
    before = _render(studio, scene, tmp_path)
    ball.is_holdout = True
    ours = _render(studio, scene, tmp_path)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.filter_width = 1, 0.01
    cycles = _render(studio, scene, tmp_path)
    hole = cycles[..., 3] < 0.5
    assert 0.05 < hole.mean() < 0.6
    covered = (ours[..., 3] == 0) | hole
    assert ((ours[..., 3] == 0) == hole)[covered].mean() > 0.95  # the ball's outline, as Cycles draws it
    np.testing.assert_array_equal(ours[ours[..., 3] == 0], 0.0)
    np.testing.assert_array_equal(ours[ours[..., 3] > 0], before[ours[..., 3] > 0])


def test_each_view_layer_gets_its_own_passes(clean_scene, tmp_path):
    """Two view layers, the second without the ball's collection: the first's object index shows
    the ball, the second's does not (each layer's render used to land in the first)."""
    scene = _engine(clean_scene)
    _stage(scene)
    props = bpy.data.collections.new("Props")
    scene.collection.children.link(props)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0)
    ball = bpy.context.active_object
    for c in ball.users_collection:
        c.objects.unlink(ball)
    props.objects.link(ball)
    ball.pass_index = 3
    first = scene.view_layers[0]
    second = scene.view_layers.new("Without props")
    second.layer_collection.children["Props"].exclude = True
    scene.render.resolution_x = scene.render.resolution_y = 16
    scene.render.resolution_percentage = 100
    scene.use_nodes = True
    tree = scene.node_tree
    tree.nodes.clear()
    for k, layer in enumerate((first, second)):
        first.use_pass_object_index = second.use_pass_object_index = True
        node = tree.nodes.new("CompositorNodeRLayers")
        node.layer = layer.name
        out = tree.nodes.new("CompositorNodeOutputFile")
        out.base_path = str(tmp_path / f"layer{k}") + "/"
        out.format.file_format = "OPEN_EXR"
        out.file_slots[0].path = "IndexOB"  # (its own slot: one removed is never freed)
        tree.links.new(node.outputs["IndexOB"], out.inputs[0])
    assert bpy.ops.render.render() == {"FINISHED"}
    ball_pixels = []
    for k in range(2):
        img = bpy.data.images.load(str(tmp_path / f"layer{k}" / "IndexOB0001.exr"))
        px = np.empty(16 * 16 * 4, np.float32)
        img.pixels.foreach_get(px)
        bpy.data.images.remove(img)
        ball_pixels.append(int((px.reshape(-1, 4)[:, 0] == 3).sum()))
    scene.node_tree.nodes.clear()
    scene.use_nodes = False
    assert ball_pixels[0] > 20 and ball_pixels[1] == 0


def test_a_garment_hidden_from_the_camera_hides_nothing_under_it(studio, clean_scene, tmp_path):
    """The jacket of a poking pair hidden from the camera: the shirt shows wherever it is, as it
    does with the jacket left out of the render (a garment the camera does not see covers
    nothing, though it still shades what is under it)."""
    scene = _engine(clean_scene)
    _stage(scene)
    scene.view_layers[0].use_pass_object_index = True
    shirt, jacket = _garment_pair(scene)
    shirt.pass_index, jacket.pass_index = 1, 2
    jacket.hide_render = True
    alone = _render(studio, scene, tmp_path, passes=("IndexOB",))
    assert (alone == 1).mean() > 0.1
    jacket.hide_render, jacket.visible_camera = False, False
    np.testing.assert_array_equal(_render(studio, scene, tmp_path, passes=("IndexOB",)), alone)


def _white_floor(scene):
    """No sun, a 40 m white floor under the camera: a stage for one light's own light."""
    _stage(scene, sun_strength=0.0)
    bpy.ops.mesh.primitive_plane_add(size=40.0)
    _material(bpy.context.active_object, (1.0, 1.0, 1.0))


def _square_view_factor(x, y):
    """From the point under the centre of a rectangle of half sides x, y at height 1 to it: the
    parallel-rectangle view factor (Howell's catalogue B-3) summed over its four corner quarters."""
    corner = (x / np.sqrt(1 + x**2) * np.arctan(y / np.sqrt(1 + x**2))
              + y / np.sqrt(1 + y**2) * np.arctan(x / np.sqrt(1 + y**2))) / (2 * np.pi)
    return 4 * corner


def test_area_light_lights_one_side_as_blender_sizes_it(studio, clean_scene, tmp_path):
    """A 1 m square area light of P watts 1 m over a white floor: under its centre E = pi L F,
    with L = P / (pi A) and F the parallel-rectangle view factor (Howell's catalogue B-3); the
    floor sends E / pi back (Cycles: 2.246 at 256 samples for 30 W, this formula 2.287 at the
    point, less the pixel's spread)."""
    scene = _engine(clean_scene)
    _white_floor(scene)
    light = bpy.data.objects.new("Panel", bpy.data.lights.new("Panel", "AREA"))
    light.data.energy, light.data.size, light.location = 30.0, 1.0, (0, 0, 1.0)
    scene.collection.objects.link(light)
    scene.deformrt.render_area_samples = 24
    px = _render(studio, scene, tmp_path, size=(15, 15))  # the centre pixel looks straight down
    np.testing.assert_allclose(px[7, 7, :3], (30.0 / np.pi) * _square_view_factor(0.5, 0.5), rtol=2e-3)
    assert px[0, 0, 0] < px[7, 7, 0]
    light.rotation_euler = (np.pi, 0.0, 0.0)  # turned to face up: the floor is dark
    np.testing.assert_array_equal(_render(studio, scene, tmp_path, size=(15, 15))[..., :3], 0.0)


def test_each_face_takes_the_material_of_its_slot(studio, clean_scene, tmp_path):
    """Two quads of one mesh in two material slots, red and green, under a sun of strength 2
    straight above: each shows its own slot's Lambert colour 2 albedo / pi (not the active
    slot's on both); a slot index past the last slot takes the last, as Blender clamps it."""
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=2.0)
    mesh = bpy.data.meshes.new("Two")
    mesh.from_pydata([(-1, -0.5, 0), (0, -0.5, 0), (1, -0.5, 0), (-1, 0.5, 0), (0, 0.5, 0), (1, 0.5, 0)], [],
                     [(0, 1, 4, 3), (1, 2, 5, 4)])
    obj = bpy.data.objects.new("Two", mesh)
    scene.collection.objects.link(obj)
    for colour in ((0.9, 0.1, 0.1), (0.1, 0.8, 0.2)):
        _material(obj, colour)
    obj.active_material_index = 0
    size = 41
    half = 5.0 * 18 / 50

    def shown(index):
        mesh.polygons.foreach_set("material_index", np.array(index, np.int32))
        mesh.update()
        px = _render(studio, scene, tmp_path, size=(size, size))[size // 2, :, :3]
        return px[int((-0.5 / half + 1) / 2 * size)], px[int((0.5 / half + 1) / 2 * size)]

    left, right = shown([0, 1])
    np.testing.assert_allclose(left, 2 * np.array([0.9, 0.1, 0.1]) / np.pi, rtol=1e-6)
    np.testing.assert_allclose(right, 2 * np.array([0.1, 0.8, 0.2]) / np.pi, rtol=1e-6)
    left, right = shown([1, 7])
    np.testing.assert_allclose([left, right], [2 * np.array([0.1, 0.8, 0.2]) / np.pi] * 2, rtol=1e-6)


def test_what_renders_is_what_blender_renders(studio, clean_scene, tmp_path):
    """An object switched off for rendering is not drawn, one only hidden in the viewport is, and
    so is a collection instance (as Cycles does); a mesh with no material has Cycles' default
    surface, a diffuse grey of 0.8 (under a sun of strength 2 at normal incidence 2 x 0.8 / pi),
    unless its object colour was set."""
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=2.0)
    places = {"off for rendering": (-1.0, 0.0), "hidden in the viewport": (1.0, 0.0), "instanced": (0.0, 1.2)}
    made = {}
    for name, (x, y) in places.items():
        bpy.ops.mesh.primitive_plane_add(size=1.0, location=(x, y, 0.0))
        made[name] = bpy.context.active_object
    made["off for rendering"].hide_render = True
    made["hidden in the viewport"].hide_set(True)
    props = bpy.data.collections.new("Props")  # not in the scene: seen only through its instance
    props.objects.link(made["instanced"])
    scene.collection.objects.unlink(made["instanced"])
    made["instanced"].location = (0.0, 0.0, 0.0)
    holder = bpy.data.objects.new("Holder", None)
    holder.instance_type, holder.instance_collection, holder.location = "COLLECTION", props, (0.0, 1.2, 0.0)
    scene.collection.objects.link(holder)
    size = 41
    px = _render(studio, scene, tmp_path, size=(size, size))[..., 0]
    half = 5.0 * 18 / 50  # half the floor seen from 5 m: the default 50 mm lens on a 36 mm sensor

    def at(x, y):
        return px[int((1 - (y / half + 1) / 2) * size), int((x / half + 1) / 2 * size)]

    grey = 2.0 * 0.8 / np.pi
    assert at(*places["off for rendering"]) == 0.0
    np.testing.assert_allclose([at(*places["hidden in the viewport"]), at(*places["instanced"])], grey, rtol=1e-6)
    made["hidden in the viewport"].color = (0.2, 0.4, 0.6, 1.0)
    px = _render(studio, scene, tmp_path, size=(size, size))
    np.testing.assert_allclose(px[int((1 - (0 / half + 1) / 2) * size), int((1.0 / half + 1) / 2 * size)],
                               [*(2.0 * np.array([0.2, 0.4, 0.6]) / np.pi), 1.0], rtol=1e-6)


def test_spot_light_lights_its_cone_as_blender_shapes_it(extension, studio, clean_scene, tmp_path):
    """A 30 W spot 1 m over a white floor, pointing down, cone edge 0.5 m from its foot, blend
    0.4: inside, a point lamp's P / (4 pi) per steradian; at the edge Cycles' smoothstep mask.
    Each pixel centre's floor point against E cos / r^2 times the mask, E albedo / pi sent back
    (Cycles at 1024 samples, tilted and turned: the same picture to 0.5% in sum; its edge
    pixels differ by its pixel filter)."""
    engine = importlib.import_module(f"{extension.__name__}.addon.render.engine")
    whitted = importlib.import_module(f"{extension.__name__}.core.render.whitted")
    scene = _engine(clean_scene)
    _white_floor(scene)
    spot = bpy.data.objects.new("Spot", bpy.data.lights.new("Spot", "SPOT"))
    spot.data.energy, spot.data.spot_size, spot.data.spot_blend = 30.0, 2 * np.arctan(0.5), 0.4
    spot.location = (0, 0, 1.0)  # shines down its local -z at rest
    scene.collection.objects.link(spot)
    size = 41
    px = _render(studio, scene, tmp_path, size=(size, size))[::-1, :, 0].ravel()  # rows bottom to top, as rays
    o, d = whitted.camera_rays(np.array(scene.camera.matrix_world), engine.vertical_fov(scene.camera.data, size, size),
                               size, size)
    floor = o - d * (o[:, 2] / d[:, 2])[:, None]
    r2 = 1.0 + (floor[:, :2] ** 2).sum(1)
    cos, cos_half = 1 / np.sqrt(r2), np.cos(np.arctan(0.5))
    x = np.clip((cos - cos_half) / ((1 - cos_half) * 0.4), 0, 1)
    expected = 30.0 / (4 * np.pi) / np.pi * cos / r2 * x * x * (3 - 2 * x)
    assert (expected == 0).any() and ((expected > 0) & (x < 1)).any()  # the cone's edge and its ramp are seen
    np.testing.assert_allclose(px, expected, rtol=1e-4, atol=1e-6)


def test_probe_distance_zero_takes_the_body_radius_under_each_vertex(extension):
    """Probe Distance 0: l_s is the body's radius under each vertex, as in the resolve. For a
    sphere that is its radius everywhere (half the chord through the centre)."""
    import trimesh

    rule = importlib.import_module(f"{extension.__name__}.core.layering.probes")
    body = trimesh.creation.icosphere(subdivisions=4, radius=0.1)
    shirt = trimesh.creation.icosphere(subdivisions=3, radius=0.12)
    objects = [(body.vertices, body.faces), (shirt.vertices, shirt.faces), (shirt.vertices + 1.0, shirt.faces)]
    probes = rule.body_probes(objects, [0, 1, None])
    np.testing.assert_allclose(probes[0], 0.1, rtol=0.01)
    np.testing.assert_allclose(probes[1], 0.1, rtol=0.01)
    assert probes[2] is None  # a prop: the default
    assert rule.body_probes(objects[1:], [1, None]) is None  # no body: the default everywhere
    assert rule.body_probes(objects, [0, 1, None], given=0.03) == 0.03  # one distance for all


def test_probe_distance_follows_the_body_parts_and_their_overrides(extension):
    """With body parts, each part's radius (its median), as the resolve takes l_s: a body of a
    10 cm and a 4 cm ball, a garment over each, and a per-part override replacing one."""
    import trimesh

    rule = importlib.import_module(f"{extension.__name__}.core.layering.probes")
    big = trimesh.creation.icosphere(subdivisions=4, radius=0.1)
    small = trimesh.creation.icosphere(subdivisions=4, radius=0.04)
    shift = np.array([0.5, 0.0, 0.0])
    body_v = np.vstack([big.vertices, small.vertices + shift])
    body_f = np.vstack([big.faces, small.faces + len(big.vertices)])
    parts = np.repeat([0, 1], [len(big.vertices), len(small.vertices)])
    # a stretched shell over the small ball: its vertices' nearest body points are all on it
    shell = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    shell_v = shell.vertices * [1.0, 1.3, 1.0] + shift
    objects = [(body_v, body_f), (big.vertices * 1.2, big.faces), (shell_v, shell.faces)]
    probes = rule.body_probes(objects, [0, 1, 2], parts=rule.BodyParts(parts))
    np.testing.assert_allclose(probes[1], 0.1, rtol=0.01)
    np.testing.assert_allclose(probes[2], 0.04, rtol=0.01)
    np.testing.assert_allclose(probes[0][parts == 1], 0.04, rtol=0.01)
    np.testing.assert_allclose(probes[0][parts == 0], 0.1, rtol=0.01)
    # what sends no probe (the outermost layer) is not looked up: the default
    skipped = rule.body_probes(objects, [0, 1, 2], parts=rule.BodyParts(parts), traced=[True, True, False])
    assert skipped[2] is None
    np.testing.assert_array_equal(skipped[1], probes[1])
    probes = rule.body_probes(objects, [0, 1, 2], given=np.array([np.nan, 0.02]), parts=rule.BodyParts(parts))
    np.testing.assert_allclose(probes[1], 0.1, rtol=0.01)  # NaN: the part keeps its radius
    np.testing.assert_array_equal(probes[2], 0.02)
    with pytest.raises(ValueError, match="need the body's parts"):
        rule.body_probes(objects, [0, 1, 2], given=np.array([np.nan, 0.02]))
    # each garment's nearest body vertices are kept for the next frame, by content: the shell
    # moved in place onto the big ball takes the big ball's radius; one part for the whole body,
    # the median radius of both balls
    shell_v -= shift
    np.testing.assert_allclose(rule.body_probes(objects, [0, 1, 2], parts=rule.BodyParts(parts))[2], 0.1, rtol=0.01)
    one = rule.body_probes(objects, [0, 1, 2], parts=rule.BodyParts(np.zeros_like(parts)))
    np.testing.assert_array_equal(one[2], np.median(one[0]))
    assert 0.04 < one[2][0] < 0.1


def test_a_skirt_probes_as_far_as_the_resolve_takes_it_and_its_override_counts(extension):
    """S5 lower body: a 15 cm torso on 7 cm legs. A skirt's points on the legs are in the
    skirt segment, which reaches as far as the torso (its farthest linked part), as in the
    resolve; a trouser leg keeps its leg's radius. The panel's Skirt override reaches them."""
    from scipy.spatial import cKDTree

    from sample_scenes.shapes import tube
    from tests.core.layered_cases import lower_body, mesh

    rule = importlib.import_module(f"{extension.__name__}.core.layering.probes")
    body, parts = lower_body()
    skirt = mesh(*tube(0.18, 0.2, 0.62, grid=(64, 24)))
    trouser = mesh(*tube(0.085, 0.05, 0.49, grid=(32, 12)))
    trouser.apply_translation([-0.09, 0.0, 0.0])
    objects = [(body.vertices, body.faces), (skirt.vertices, skirt.faces), (trouser.vertices, trouser.faces)]
    probes = rule.body_probes(objects, [0, 1, 2], parts=rule.BodyParts(parts, "S5"))
    on_legs = np.isin(parts[cKDTree(body.vertices).query(skirt.vertices)[1]], (3, 4))
    assert on_legs.sum() > len(on_legs) / 3
    np.testing.assert_allclose(probes[1][on_legs], 0.15, rtol=0.05)
    np.testing.assert_allclose(probes[2][trouser.vertices[:, 2] < 0.45], 0.07, rtol=0.05)
    given = np.full(6, np.nan)
    given[5] = 0.03  # S5's skirt
    probes = rule.body_probes(objects, [0, 1, 2], given=given, parts=rule.BodyParts(parts, "S5"))
    np.testing.assert_array_equal(probes[1][on_legs], 0.03)
    np.testing.assert_allclose(probes[2][trouser.vertices[:, 2] < 0.45], 0.07, rtol=0.05)


def test_emission_shows_and_a_light_without_shadows_lights_through(studio, clean_scene, tmp_path):
    """An emissive quad (Emission Color x Strength: radiance, as Cycles shows it with no light)
    over a white floor, under a sun of strength 2 at 45 degrees: the quad shows its emission plus
    its own lit Lambert colour; the floor is dark in its shadow until the sun's Shadow switch is
    off, then lit as the open floor."""
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=2.0)
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    _material(bpy.context.active_object, (1.0, 1.0, 1.0))
    bpy.ops.mesh.primitive_plane_add(size=0.4, location=(-1.0, 0.0, 0.5))
    lamp = bpy.context.active_object
    _material(lamp, (0.2, 0.2, 0.2))
    bsdf = lamp.active_material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 3.0
    scene.objects["Sun"].rotation_euler = (0.0, np.radians(-45), 0.0)  # travels to +x and down
    size, half = 81, 5.0 * 18 / 50

    def at(px, x, y, z=0.0):  # the pixel that sees (x, y, z) from the camera 5 m up
        s = 5.0 / (5.0 - z)
        return px[int((1 - (s * y / half + 1) / 2) * size), int((s * x / half + 1) / 2 * size), :3]

    lit = 2 * np.cos(np.radians(45)) / np.pi
    px = _render(studio, scene, tmp_path, size=(size, size))
    np.testing.assert_allclose(at(px, -1.0, 0.0, 0.5), 3.0 * np.array([1.0, 0.5, 0.25]) + 0.2 * lit, rtol=1e-5)
    np.testing.assert_allclose(at(px, -0.5, 0.0), 0.0, atol=1e-7)  # the shadow of the quad's centre
    np.testing.assert_allclose(at(px, 1.0, 0.0), lit, rtol=1e-5)
    scene.objects["Sun"].data.use_shadow = False
    px = _render(studio, scene, tmp_path, size=(size, size))
    np.testing.assert_allclose(at(px, -0.5, 0.0), lit, rtol=1e-5)


def test_light_power_follows_exposure_temperature_and_unnormalized_areas(studio, clean_scene, tmp_path):
    """Straight under a light 1 m over a white floor: a 30 W point lamp at exposure 1 and 3000 K
    gives 2 x 30 / (4 pi) x its blackbody colour / pi; a 1 m square area light of 30 W/m^2 with
    Normalize off sends what one of 30 W does, times its area (here 4 m^2 by object scale 2).
    (Cycles agrees to about 1% on each, the same as on the plain lights.)"""
    scene = _engine(clean_scene)
    _white_floor(scene)
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    lamp.data.energy, lamp.data.exposure, lamp.location = 30.0, 1.0, (0, 0, 1.0)
    lamp.data.use_temperature, lamp.data.temperature = True, 3000.0
    scene.collection.objects.link(lamp)
    px = _render(studio, scene, tmp_path, size=(15, 15))  # the centre pixel looks straight down
    warm = np.array(lamp.data.temperature_color)
    assert warm[0] > warm[2]
    np.testing.assert_allclose(px[7, 7, :3], 2 * 30.0 / (4 * np.pi) * warm / np.pi, rtol=1e-4)
    bpy.data.objects.remove(lamp)
    panel = bpy.data.objects.new("Panel", bpy.data.lights.new("Panel", "AREA"))
    panel.data.energy, panel.data.size, panel.data.normalize = 30.0, 1.0, False
    panel.location, panel.scale = (0, 0, 1.0), (2.0, 2.0, 1.0)
    scene.collection.objects.link(panel)
    scene.deformrt.render_area_samples = 24
    px = _render(studio, scene, tmp_path, size=(15, 15))
    # the 2 m square, 1 m up: 120 W over 4 m^2
    np.testing.assert_allclose(px[7, 7, :3], (4.0 * 30.0 / (np.pi * 4.0)) * _square_view_factor(1.0, 1.0), rtol=3e-3)


def test_an_image_texture_on_the_base_colour_is_drawn_at_the_uvs(studio, clean_scene, tmp_path):
    """A plane (UVs 0..1 across it) whose Base Color comes from an 8 x 8 sRGB image of four
    coloured quarters: under a sun of strength 2 straight above, the pixel over the middle of
    each quarter shows its colour, made linear, times 2 / pi (Cycles: the same within its noise)."""
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=2.0)
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    _material(plane, (0.5, 0.5, 0.5))
    image = bpy.data.images.new("Quarters", 8, 8)
    texels = np.array([[0.9, 0.2, 0.1, 1], [0.1, 0.7, 0.2, 1], [0.2, 0.3, 0.9, 1], [1, 1, 1, 1]], np.float32)
    quarters = texels.reshape(2, 2, 1, 1, 4).transpose(0, 2, 1, 3, 4)  # (row half, 1, column half, 1, rgba)
    image.pixels.foreach_set(np.broadcast_to(quarters, (2, 4, 2, 4, 4)).reshape(-1))  # rows bottom up
    tree = plane.active_material.node_tree
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = image
    tree.links.new(node.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    size, half = 41, 5.0 * 18 / 50

    def at(px, x, y):
        return px[int((1 - (y / half + 1) / 2) * size), int((x / half + 1) / 2 * size), :3]

    px = _render(studio, scene, tmp_path, size=(size, size))
    stored = np.empty(8 * 8 * 4, np.float32)
    image.pixels.foreach_get(stored)  # as the image keeps them: 8 bits a channel
    srgb = stored.reshape(8, 8, 4)[[2, 2, 6, 6], [2, 6, 2, 6], :3].astype(float)
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    for (x, y), want in zip([(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)], linear, strict=True):
        np.testing.assert_allclose(at(px, x, y), 2 * want / np.pi, rtol=1e-5)


def test_curves_and_text_are_drawn_as_cycles_draws_them(studio, clean_scene, tmp_path):
    """A bevelled Bézier circle and a text object render as surfaces, once each (they come as
    their own entries and as instances of what they evaluate to): the pixels each covers (object
    index) match Cycles' but along the edges."""
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=2.0)
    scene.view_layers[0].use_pass_object_index = True
    bpy.ops.curve.primitive_bezier_circle_add(radius=1.0, location=(-0.4, 0.0, 0.0))
    bpy.context.active_object.data.bevel_depth = 0.15
    bpy.context.active_object.pass_index = 1
    bpy.ops.object.text_add(location=(0.2, -0.3, 0.0))
    bpy.context.active_object.data.extrude = 0.05
    bpy.context.active_object.pass_index = 2
    size = 48
    ours = _render(studio, scene, tmp_path, size=(size, size), passes=("IndexOB",))
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.filter_width = 1, 0.01  # one ray through each pixel centre
    theirs = _render(studio, scene, tmp_path, size=(size, size), passes=("IndexOB",))
    # a pixel next to one of another object in Cycles' image is an edge pixel
    pad = np.pad(theirs, 1, mode="edge")
    edge = np.zeros(theirs.shape, bool)
    for dy, dx in ((0, 1), (2, 1), (1, 0), (1, 2)):
        edge |= pad[dy:dy + size, dx:dx + size] != theirs
    for index in (1, 2):
        assert (theirs == index).sum() > 20
        differ = (ours == index) != (theirs == index)
        assert not (differ & ~edge).any()


def test_a_flat_shaded_cube_shows_flat_faces(studio, clean_scene, tmp_path):
    """A flat-shaded cube (Blender's default) under a tilted sun: every pixel of its top face shows
    the Lambert term of the face's own normal, as Cycles does (the vertex normals of a cube point
    along its diagonals and would shade the face as a blob); shaded smooth it varies, and with
    its edges marked sharp it is flat again."""
    scene = _engine(clean_scene)
    _stage(scene, sun_strength=2.0)
    sun = scene.objects["Sun"]
    sun.rotation_euler = (0.0, np.radians(-30), 0.0)
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    cube = bpy.context.active_object
    _material(cube, (1.0, 1.0, 1.0))
    size = 41
    top = _render(studio, scene, tmp_path, size=(size, size))[15:26, 15:26, 0]  # inside the top face
    np.testing.assert_allclose(top, 2 * np.cos(np.radians(30)) / np.pi, rtol=1e-5)
    bpy.ops.object.shade_smooth()
    smooth = _render(studio, scene, tmp_path, size=(size, size))[15:26, 15:26, 0]
    assert np.ptp(smooth) > 0.05
    # smooth faces, every edge marked sharp: flat again (Blender's corner normals split there)
    sharp = cube.data.attributes.new("sharp_edge", "BOOLEAN", "EDGE")
    sharp.data.foreach_set("value", np.ones(len(cube.data.edges), bool))
    cube.data.update()
    top = _render(studio, scene, tmp_path, size=(size, size))[15:26, 15:26, 0]
    np.testing.assert_allclose(top, 2 * np.cos(np.radians(30)) / np.pi, rtol=1e-5)


def test_triangles_at_nan_positions_are_left_out_as_if_blender_had_deleted_them(extension, studio, clean_scene,
                                                                              tmp_path):
    """A vertex a cloth solver blew up to NaN: the frame renders (as Cycles renders it), without
    the triangles around that vertex, exactly as the mesh renders with the vertex deleted, and
    the render says what it left out."""
    import bmesh

    engine = importlib.import_module(f"{extension.__name__}.addon.render.engine")
    scene = _engine(clean_scene)
    _stage(scene)
    _, jacket = _garment_pair(scene)
    intact = _render(studio, scene, tmp_path)
    co = np.empty(len(jacket.data.vertices) * 3)
    jacket.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    lost = int(np.argmin(np.linalg.norm(co[:, :2] - [0.1, -0.05], axis=1)))  # inside the grid, in view
    broken = co.copy()
    broken[lost] = np.nan
    jacket.data.vertices.foreach_set("co", broken.ravel())
    jacket.data.update()
    shown = _render(studio, scene, tmp_path)
    warnings = engine.FrameTracer(bpy.context.evaluated_depsgraph_get(), 32, 32).warnings
    jacket.data.calc_loop_triangles()  # Blender's own triangles around the vertex
    around = sum(lost in t.vertices[:] for t in jacket.data.loop_triangles)
    assert around >= 4
    assert warnings == [f"Jacket: {around} triangles at no finite position (NaN or infinite) left out"]
    assert np.isfinite(shown).all() and not np.array_equal(shown, intact)  # the shirt shows through the hole
    jacket.data.vertices.foreach_set("co", co.ravel())
    bm = bmesh.new()
    bm.from_mesh(jacket.data)
    bm.verts.ensure_lookup_table()
    bmesh.ops.delete(bm, geom=[bm.verts[lost]], context="VERTS")
    bm.to_mesh(jacket.data)
    bm.free()
    jacket.data.update()
    np.testing.assert_allclose(shown, _render(studio, scene, tmp_path), atol=1e-6)


def test_persistent_data_keeps_the_ray_scenes_while_the_meshes_stay_the_same(extension, studio, clean_scene,
                                                                            tmp_path, monkeypatch):
    """With Blender's Persistent Data on, a second render of the same meshes builds no ray scene and
    shows the same picture; a mesh that moved is built again; with it off nothing is kept."""
    reading = importlib.import_module(f"{extension.__name__}.addon.render.scene_reading")
    made = []
    real = reading.LayeredScene

    def counting(*args, **kwargs):
        made.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(reading, "LayeredScene", counting)
    scene = _engine(clean_scene)
    _stage(scene)
    _garment_pair(scene)
    scene.render.use_persistent_data = True
    first = _render(studio, scene, tmp_path)
    again = _render(studio, scene, tmp_path)
    assert len(made) == 1 and len(reading.PERSISTENT) == 1
    np.testing.assert_array_equal(again, first)
    shirt = bpy.data.objects["Shirt"]
    shirt.location.x += 0.3  # the shirt's evaluated mesh moves in world space: a new scene
    moved = _render(studio, scene, tmp_path)
    assert len(made) == 2 and not np.array_equal(moved, first)
    scene.render.use_persistent_data = False
    _render(studio, scene, tmp_path)
    assert len(made) == 3 and len(reading.PERSISTENT) == 0


def test_motion_blur_and_depth_of_field_it_does_not_render_are_said(studio, clean_scene, tmp_path, capsys):
    """Motion Blur and a camera's Depth of Field were left out without a word: the frame is the
    same sharp one, and the render says so."""
    scene = _engine(clean_scene)
    _white_floor(scene)
    sharp = _render(studio, scene, tmp_path, size=(8, 8))
    capsys.readouterr()
    scene.render.use_motion_blur, scene.camera.data.dof.use_dof = True, True
    np.testing.assert_array_equal(_render(studio, scene, tmp_path, size=(8, 8)), sharp)
    said = capsys.readouterr()
    assert "Motion Blur is on but this engine renders each frame sharp" in said.out + said.err
    assert f"{scene.camera.name}'s Depth of Field is on" in said.out + said.err


def test_settings_a_file_stores_out_of_range_are_named_and_clamped(studio, clean_scene, tmp_path, capsys):
    """Area Light Samples 0 and Max Bounces -1 stored in a file (the panel allows 1-32 and 0-16):
    the frame renders as with the nearest allowed values and the render says which it changed;
    3000 samples (hours a frame) render as 32."""
    scene = _engine(clean_scene)
    _white_floor(scene)
    light = bpy.data.objects.new("Panel", bpy.data.lights.new("Panel", "AREA"))
    light.data.energy, light.location = 30.0, (0, 0, 1.0)
    scene.collection.objects.link(light)
    scene.deformrt.render_area_samples, scene.deformrt.render_max_depth = 1, 0
    allowed = _render(studio, scene, tmp_path, size=(8, 8))
    scene.deformrt["render_area_samples"], scene.deformrt["render_max_depth"] = 0, -1  # as a crafted file holds them
    assert (scene.deformrt.render_area_samples, scene.deformrt.render_max_depth) == (0, -1)
    capsys.readouterr()
    np.testing.assert_array_equal(_render(studio, scene, tmp_path, size=(8, 8)), allowed)
    said = capsys.readouterr()
    assert "Area Light Samples 0 is outside 1-32: rendered with 1" in said.out + said.err
    assert "Max Bounces -1 is outside 0-16: rendered with 0" in said.out + said.err
    scene.deformrt["render_area_samples"] = 3000
    huge = _render(studio, scene, tmp_path, size=(8, 8))
    scene.deformrt.render_area_samples = 32
    np.testing.assert_array_equal(huge, _render(studio, scene, tmp_path, size=(8, 8)))

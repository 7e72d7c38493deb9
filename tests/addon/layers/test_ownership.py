"""DeformRT writes only into data it made for the garment at hand and deletes nothing else: a
Result Data field pointed at a user's object, a modifier copied to another garment, a linked
duplicate, another file's copy of the node group, a Multires that leaves the result no place, a
cache path that is a folder or a disk that is too full. And a result that does not fit is
decided from what the scene is now: a change undone is forgotten."""

import importlib
import json
import shutil

import bpy
import numpy as np
import pytest

from tests.addon.render_capture import overlapping_pairs, rendered_meshes, without_result


def sub(ext, path):
    return importlib.import_module(f"{ext.__name__}.{path}")




def own_state(obj):
    """What the user made: the object's mesh (positions, faces) or, for others, its type and place."""
    if obj.type != "MESH":
        return obj.type, tuple(obj.location)
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    return co.round(9).tobytes(), len(obj.data.polygons), obj.data.name


def _field(extension, obj):
    results, nodes = sub(extension, "addon.layers.results"), sub(extension, "addon.layers.result_nodes")
    mod = results.result_modifier(obj)
    return mod, nodes.data_socket_id(mod.node_group)


def _point_field_at(extension, garment, target):
    versions = sub(extension, "addon.io.blender_versions")
    mod, key = _field(extension, garment)
    versions.set_modifier_input(mod, key, target)
    garment.update_tag()  # as the field in the UI does


@pytest.mark.parametrize("target", ["Jacket", "Body", "Camera"])
def test_a_user_object_in_the_result_field_is_never_written_or_deleted(extension, tubes, target):
    body, (shirt, jacket) = tubes
    if bpy.data.objects.get("Camera") is None:
        cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        bpy.context.scene.collection.objects.link(cam)
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    victim = bpy.data.objects[target]
    before = own_state(victim)
    _point_field_at(extension, shirt, victim)  # a mis-click, the eyedropper, or a file made so
    bpy.context.view_layer.update()
    assert own_state(victim) == before
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert own_state(bpy.data.objects[target]) == before
    results = sub(extension, "addon.layers.results")
    assert results.data_object(shirt) not in (None, victim)  # the shirt got data of its own again
    shown = rendered_meshes(bpy.context.scene)
    assert overlapping_pairs(shown["Shirt"], shown["Jacket"]) == 0
    _point_field_at(extension, shirt, bpy.data.objects[target])
    assert bpy.ops.deformrt.clear_results() == {"FINISHED"}
    assert bpy.data.objects.get(target) is not None and own_state(bpy.data.objects[target]) == before
    assert bpy.data.collections.get("DeformRT Data") is None  # ours all went


def test_a_copied_modifier_or_linked_duplicate_never_shares_a_result(extension, tubes):
    body, (shirt, jacket) = tubes
    results = sub(extension, "addon.layers.results")
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    shirt_data = results.data_object(shirt)
    # Copy Modifiers (Ctrl+L) from the shirt to the jacket
    with bpy.context.temp_override(active_object=shirt, object=shirt, selected_objects=[shirt, jacket],
                                   selected_editable_objects=[shirt, jacket]):
        assert bpy.ops.object.make_links_data(type="MODIFIERS") == {"FINISHED"}
    assert results.result_modifier(jacket) is not None  # the copy, whose field held the shirt's data
    bpy.context.view_layer.update()
    # the jacket no longer shows the shirt's offsets by index: its field is emptied, the shirt keeps its own
    assert results.linked_data(jacket) is None and results.data_object(shirt) == shirt_data
    staleness = sub(extension, "addon.layers.staleness")
    assert staleness.stale_garments(bpy.context.scene) == []
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert results.data_object(jacket) not in (None, shirt_data)
    shown = rendered_meshes(bpy.context.scene)
    assert overlapping_pairs(shown["Shirt"], shown["Jacket"]) == 0
    assert staleness.stale_garments(bpy.context.scene) == []
    # a linked duplicate (Alt+D) points at the original's data: it shows as fitted, the original stays
    twin = shirt.copy()
    bpy.context.scene.collection.objects.link(twin)
    twin.deformrt.role = "NONE"
    bpy.context.view_layer.update()
    staleness.check_scene(bpy.context.scene)
    assert results.linked_data(twin) is None and results.data_object(shirt) == shirt_data
    assert staleness.stale_garments(bpy.context.scene) == []
    # clearing the twin's (empty) result removes nothing of the shirt's
    assert results.clear(twin)
    assert results.data_object(shirt) == shirt_data


def test_another_files_copy_of_the_group_is_recognised_and_never_doubles_the_move(extension, tubes):
    body, (shirt, jacket) = tubes
    results, nodes = sub(extension, "addon.layers.results"), sub(extension, "addon.layers.result_nodes")
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    once = rendered_meshes(bpy.context.scene)["Shirt"][0]
    # an appended garment brings its group as "DeformRT Result.001" beside the file's own
    bpy.data.node_groups[nodes.GROUP_NAME].name = "DeformRT Result.001"
    nodes.node_group()
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert [m.name for m in shirt.modifiers if m.type == "NODES"] == ["DeformRT"]
    np.testing.assert_allclose(rendered_meshes(bpy.context.scene)["Shirt"][0], once, atol=1e-6)
    assert "DeformRT Result.001" not in bpy.data.node_groups
    assert results.result_modifier(shirt).node_group.name == nodes.GROUP_NAME
    assert bpy.ops.deformrt.clear_results() == {"FINISHED"}
    assert not any(m.type == "NODES" for g in (shirt, jacket) for m in g.modifiers)


def test_a_multires_that_leaves_no_place_is_refused_before_anything_is_written(extension, tubes):
    body, (shirt, jacket) = tubes
    multires = jacket.modifiers.new("Multires", "MULTIRES")
    with bpy.context.temp_override(object=jacket, active_object=jacket):
        bpy.ops.object.multires_subdivide(modifier="Multires", mode="CATMULL_CLARK")
    multires.levels, multires.render_levels = 0, 1
    names = set(bpy.data.objects.keys())
    with pytest.raises(RuntimeError, match="Multires.*Viewport level 0 and Render level 1"):
        bpy.ops.deformrt.resolve_layers()
    assert set(bpy.data.objects.keys()) == names  # nothing half-written: the shirt got nothing either
    assert not any(m.type == "NODES" for g in (body, shirt, jacket) for m in g.modifiers)
    multires.levels = 1  # both levels alike: the result follows the Multires
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert [m.type for m in jacket.modifiers] == ["MULTIRES", "NODES"]
    shown = rendered_meshes(bpy.context.scene)
    assert overlapping_pairs(shown["Shirt"], shown["Jacket"]) == 0


def test_bake_frames_refuses_a_folder_or_a_full_disk_and_makes_a_missing_folder(extension, tubes, tmp_path,
                                                                                 monkeypatch):
    body, _ = tubes
    with pytest.raises(RuntimeError, match="is a folder"):
        bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=2, filepath=str(tmp_path))
    total, used, _free = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(shutil, "disk_usage", lambda _p: shutil._ntuple_diskusage(total, used, 1 << 20))
    target = tmp_path / "new" / "layers.abc"
    with pytest.raises(RuntimeError, match="MB free"):
        bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=2, filepath=str(target))
    assert not target.exists() and not any(tmp_path.rglob("*.abc"))
    monkeypatch.undo()
    assert bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=2, filepath=str(target)) == {"FINISHED"}
    assert target.is_file()


def test_a_change_undone_is_forgotten_and_a_renamed_body_is_no_change(extension, tubes):
    body, (shirt, jacket) = tubes
    staleness = sub(extension, "addon.layers.staleness")
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    resolved = rendered_meshes(bpy.context.scene)
    body.name = "Figure"
    bpy.context.view_layer.update()
    assert staleness.stale_garments(bpy.context.scene) == []
    # a drag cancelled: moved, then put back exactly
    jacket.location.z += 0.02
    bpy.context.view_layer.update()
    assert [g.name for g, _ in staleness.stale_garments(bpy.context.scene)] == ["Jacket"]
    jacket.location.z -= 0.02
    bpy.context.view_layer.update()
    assert staleness.stale_garments(bpy.context.scene) == []
    np.testing.assert_allclose(rendered_meshes(bpy.context.scene)["Jacket"][0], resolved["Jacket"][0], atol=1e-6)
    # a garment carried by an animated parent: animation is followed, not a change
    rig = bpy.data.objects.new("Rig", None)
    bpy.context.scene.collection.objects.link(rig)
    shirt.parent = jacket.parent = rig  # the body stays: they move against it
    rig.keyframe_insert("location", frame=1)
    rig.location.x += 0.3
    rig.keyframe_insert("location", frame=10)
    bpy.context.scene.frame_set(10)
    assert staleness.check_scene(bpy.context.scene) == []  # as a render of frame 10 checks
    bpy.context.scene.frame_set(1)
    assert staleness.stale_garments(bpy.context.scene) == []


def test_the_bodys_own_edits_make_every_result_stale_and_its_animation_does_not(extension, tubes):
    body, (shirt, jacket) = tubes
    staleness = sub(extension, "addon.layers.staleness")
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    co = np.empty(len(body.data.vertices) * 3)
    body.data.vertices.foreach_get("co", co)
    moved = co.copy()
    moved[2::3] += 0.001  # the whole body 1 mm up, in its mesh
    body.data.vertices.foreach_set("co", moved)
    body.data.update()
    bpy.context.view_layer.update()
    stale = dict((g.name, r) for g, r in staleness.stale_garments(bpy.context.scene))
    assert stale.get("Shirt") == "Body's mesh or shape keys changed"
    body.data.vertices.foreach_set("co", co)  # undone: forgotten
    body.data.update()
    bpy.context.view_layer.update()
    assert staleness.stale_garments(bpy.context.scene) == []
    # the body animated (keyed: it breathes 5 mm up and down under its garments): animation is what
    # Resolve on Frame Change follows, not an edit that switches the result off
    body.keyframe_insert("location", frame=1)
    body.location.z += 0.005
    body.keyframe_insert("location", frame=10)
    bpy.context.scene.frame_set(1)
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    bpy.context.scene.frame_set(10)
    assert staleness.check_scene(bpy.context.scene) == []  # as a render of frame 10 checks


def _lattice(shirt):
    lat = bpy.data.objects.new("Lattice", bpy.data.lattices.new("Lattice"))
    bpy.context.scene.collection.objects.link(lat)
    lat.scale = (0.5, 0.5, 0.8)
    lat.location = (0, 0, 0.3)
    mod = shirt.modifiers.new("Lattice", "LATTICE")
    mod.object = lat
    return lambda: setattr(lat.data.points[0], "co_deform", (lat.data.points[0].co_deform[0] - 0.3, 0, 0))


def _hook(shirt):
    target = bpy.data.objects.new("Target", None)
    bpy.context.scene.collection.objects.link(target)
    mod = shirt.modifiers.new("Hook", "HOOK")
    mod.object = target
    group = shirt.vertex_groups.new(name="hooked")
    group.add(list(range(10)), 1.0, "REPLACE")
    mod.vertex_group = "hooked"
    return lambda: setattr(target, "location", (0.0, 0.0, 0.02))


def _nodes(shirt):
    group = bpy.data.node_groups.new("Nudge", "GeometryNodeTree")
    group.interface.new_socket(name="Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket(name="Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    src, dst = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    move = group.nodes.new("GeometryNodeSetPosition")
    offset = group.nodes.new("FunctionNodeInputVector")  # a value inside the group, not on the modifier
    group.links.new(src.outputs[0], move.inputs["Geometry"])
    group.links.new(offset.outputs[0], move.inputs["Offset"])
    group.links.new(move.outputs[0], dst.inputs[0])
    mod = shirt.modifiers.new("Nudge", "NODES")
    mod.node_group = group
    return lambda: setattr(offset, "vector", (0.0, 0.0, 0.01))


def _driven(shirt):
    mod = shirt.modifiers.new("Displace", "DISPLACE")
    mod.strength = 0.0
    fcurve = mod.driver_add("strength")
    fcurve.driver.expression = "frame * 0.0"
    return lambda: setattr(fcurve.driver, "expression", "0.01")


@pytest.mark.parametrize("make", [_lattice, _hook, _nodes, _driven], ids=["lattice", "hook", "node value", "driver"])
def test_whatever_moves_the_vertices_above_the_result_passes_it_through_and_undone_shows_it(extension, tubes, make):
    """The correction is for the vertices as they were: a lattice's points, a hook's target, a value
    inside a node group or a driver moving them afterwards (none of which the modifier's own
    settings show) makes the garment show as fitted, and says why; put back, the result shows."""
    body, (shirt, jacket) = tubes
    change = make(shirt)
    shirt.modifiers.move(len(shirt.modifiers) - 1, 0)
    bpy.context.view_layer.update()
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    shown = rendered_meshes(bpy.context.scene)["Shirt"][0]
    staleness = sub(extension, "addon.layers.staleness")
    before = without_result(shirt).copy()
    change()
    shirt.update_tag()
    bpy.context.view_layer.update()
    now = without_result(shirt)
    assert np.abs(now - before).max() > 1e-3  # the change did move vertices
    from tests.addon.render_capture import evaluated_points
    np.testing.assert_allclose(evaluated_points(shirt), now, atol=1e-7)  # shown as fitted, not corrected
    stale = dict((g.name, r) for g, r in staleness.check_scene(bpy.context.scene))
    # a driven setting is seen on the modifier itself; the rest only by where the vertices went
    assert stale.get("Shirt") in ("Shirt's vertices above DeformRT moved", "Shirt's modifiers above DeformRT changed")
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    again = rendered_meshes(bpy.context.scene)
    assert overlapping_pairs(again["Shirt"], again["Jacket"]) == 0
    assert staleness.check_scene(bpy.context.scene) == []
    assert not np.allclose(again["Shirt"][0], shown)


@pytest.mark.parametrize("gpu", [True, False], ids=["subdivision left to the GPU", "subdivided on the CPU"])
def test_the_check_after_an_edit_never_makes_blender_subdivide_what_the_gpu_would(extension, tubes, gpu):
    """Reading a garment's evaluated mesh makes Blender subdivide on the CPU a last Subdivision the
    viewport leaves to the GPU (seconds a garment: Fig 4.13's resolve took 32 s, 31 of them in the
    check after Blender's update). So the check after an edit reads the result group's verdict only
    where the viewport subdivides on the CPU anyway; Inspect, which reads the shown meshes, always
    does. The garment shows as fitted either way (the group passes moved vertices through)."""
    body, (shirt, jacket) = tubes
    staleness, inspect = sub(extension, "addon.layers.staleness"), sub(extension, "addon.layers.inspect_layers")
    system = bpy.context.preferences.system
    was, system.use_gpu_subdivision = system.use_gpu_subdivision, gpu
    try:
        change = _hook(shirt)
        shirt.modifiers.move(len(shirt.modifiers) - 1, 0)
        shirt.modifiers.new("Subdivision", "SUBSURF").levels = 1
        assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
        before = without_result(shirt).copy()
        change()
        shirt.update_tag()
        bpy.context.view_layer.update()  # Blender's update: the add-on's check runs here
        named = "Shirt's vertices above DeformRT moved"
        assert dict((g.name, r) for g, r in staleness.stale_garments(bpy.context.scene)).get("Shirt") == \
            (None if gpu else named)
        report = inspect.inspect_scene(bpy.context.scene)
        assert named in json.dumps(report.stale) and staleness.stale_garments(bpy.context.scene)
        now = without_result(shirt)
        assert np.abs(now - before).max() > 1e-3
        from tests.addon.render_capture import evaluated_points
        np.testing.assert_allclose(evaluated_points(shirt), now, atol=1e-7)  # shown as fitted
    finally:
        system.use_gpu_subdivision = was


def test_a_modifier_that_moves_the_corrected_garment_after_the_result_is_named(extension, tubes, capfd):
    """A Displace added after a resolve lands below DeformRT (Blender appends it) and moves what was
    corrected: a render says so; Resolve puts the result after it (it is then resolved with). One
    after a Subdivision cannot be: the resolve's message names it."""
    body, (shirt, jacket) = tubes
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    shirt.modifiers.new("Displace", "DISPLACE").strength = 0.004  # 2 mm out: through the jacket here and there
    assert [m.name for m in shirt.modifiers] == ["DeformRT", "Displace"]
    capfd.readouterr()
    rendered_meshes(bpy.context.scene)
    said = capfd.readouterr()
    assert "Shirt's Displace runs after DeformRT and moves what it corrected" in said.out + said.err
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert [m.name for m in shirt.modifiers] == ["Displace", "DeformRT"]
    assert "run after DeformRT" not in json.loads(bpy.context.scene.deformrt.last_report)["message"]
    shown = rendered_meshes(bpy.context.scene)
    assert overlapping_pairs(shown["Shirt"], shown["Jacket"]) == 0
    # after a Subdivision (viewport 1, render 2) it stays after the result: named in the message
    jacket.modifiers.new("Subdivision", "SUBSURF").render_levels = 2
    jacket.modifiers.new("Wave", "DISPLACE").strength = 0.01
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert [m.name for m in jacket.modifiers] == ["DeformRT", "Subdivision", "Wave"]
    message = json.loads(bpy.context.scene.deformrt.last_report)["message"]
    assert "Jacket's Wave run after DeformRT and move what it corrected" in message

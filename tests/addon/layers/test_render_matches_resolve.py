"""What F12 renders is what was resolved: garments with the modifiers artists use (Subdivision at
viewport 1 / render 2, Solidify, Mirror, Bevel), read from the render's own depsgraph; and a
result that no longer fits its garment (edited, modifiers changed) is never applied to it."""

import importlib
import json

import bmesh
import bpy
import numpy as np
import pytest

from tests.addon import render_capture
from tests.addon.render_capture import evaluated_points, overlapping_pairs, rendered_meshes, without_result


def sub(ext, path):
    return importlib.import_module(f"{ext.__name__}.{path}")




def longest_edge(mesh) -> float:
    v, f = mesh
    return float(max(np.linalg.norm(v[f[:, i]] - v[f[:, (i + 1) % 3]], axis=1).max() for i in range(3)))


def viewport_mesh(obj):
    return evaluated_points(obj)


def add_stack(obj, stack):
    render_capture.add_stack(obj, stack, solidify_m=0.002, bevel_m=0.002)  # cloth a couple of mm thick


# A Solidify after Subdivision thickens the corrected jacket inward, behind its own surface: the shirt
# crosses that inner shell where it lies within the thickness, hidden (poke-through is what shows).
# Grown outward, the shirt's shell is given room, except where the tubes' jacket comes within 6 mm of
# the body: no room there for the shirt, its 2 mm shell and the gap.
STACKS = [(["subdivision"], 0), (["solidify", "subdivision"], 0), (["subdivision", "solidify"], None),
          (["subdivision", "solidify_out"], 0.05), (["mirror", "subdivision"], 0), (["bevel", "subdivision"], 0)]


@pytest.mark.parametrize(("stack", "crossing_share"), STACKS, ids=["+".join(s) for s, _ in STACKS])
def test_f12_renders_the_resolved_layers_under_the_artists_modifiers(extension, tubes, stack, crossing_share):
    body, (shirt, jacket) = tubes
    metrics = sub(extension, "core.layering.metrics")
    for g in (shirt, jacket):
        add_stack(g, stack)
    scene = bpy.context.scene
    before = rendered_meshes(scene)
    crossing_before = overlapping_pairs(before["Shirt"], before["Jacket"])
    assert crossing_before > 0
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    after = rendered_meshes(scene)
    # render level 2: four times the faces of the viewport's level 1 (the render was not read at viewport level)
    assert len(after["Jacket"][1]) > 3 * len(sub(extension, "addon.io.mesh_io").read_mesh(jacket).triangles)
    if crossing_share is not None:
        assert overlapping_pairs(after["Shirt"], after["Jacket"]) <= crossing_share * crossing_before
    assert overlapping_pairs(after["Body"], after["Shirt"]) == 0
    layers = [after[n] for n in ("Body", "Shirt", "Jacket")]
    poke, _, covered = metrics.poke_through(layers, cameras=metrics.camera_ring(*metrics.layer_bounds(layers),
                                                                                 views=8, resolution=96))
    assert covered > 0 and poke < 0.001
    for name in ("Shirt", "Jacket"):  # a correction applied by the wrong index scrambles the surface
        assert longest_edge(after[name]) < 2.0 * longest_edge(before[name])
    # the user's modifiers keep their order; the result sits where viewport and render agree
    assert [m.type for m in jacket.modifiers if m.name != "DeformRT"] == \
           [m.type for m in shirt.modifiers if m.name != "DeformRT"]
    names = [m.name for m in jacket.modifiers]
    assert names.index("DeformRT") == names.index("Subdivision") - 1


def test_fig_4_13_subdivided_renders_with_no_poke_through(extension, dressed_figure):
    metrics = sub(extension, "core.layering.metrics")
    dressed_figure("fig_4_13")
    scene = bpy.context.scene
    roles = sub(extension, "addon.layers.scene_roles")
    body, garments = roles.bodies(scene)[0], roles.garments(scene)
    for g in garments:
        add_stack(g, ["subdivision"])
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    after = rendered_meshes(scene)
    layers = [after[o.name] for o in (body, *garments)]
    cams = metrics.camera_ring(*metrics.layer_bounds(layers), views=8, resolution=64)
    poke, _, covered = metrics.poke_through(layers, cameras=cams)
    assert covered > 0 and poke < 0.005
    for g in garments:
        assert longest_edge(after[g.name]) < 0.05  # no scrambled face spans the figure


def _edit(obj, how):
    me = obj.data
    if how == "moved":
        co = np.empty(len(me.vertices) * 3)
        me.vertices.foreach_get("co", co)
        co.reshape(-1, 3)[:40] *= 1.05
        me.vertices.foreach_set("co", co)
        me.update()
        return
    bm = bmesh.new()
    bm.from_mesh(me)
    if how == "deleted":
        bmesh.ops.delete(bm, geom=list(bm.verts)[:40], context="VERTS")
    else:
        bmesh.ops.subdivide_edges(bm, edges=list(bm.edges)[:40], cuts=1)
    bm.to_mesh(me)
    bm.free()
    me.update()


@pytest.mark.parametrize("how", ["moved", "deleted", "added"])
def test_a_garment_edited_after_resolve_is_marked_stale_and_shown_as_fitted(extension, tubes, how):
    body, (shirt, jacket) = tubes
    staleness = sub(extension, "addon.layers.staleness")
    bpy.ops.deformrt.resolve_layers()
    assert staleness.stale_garments(bpy.context.scene) == []
    _edit(shirt, how)
    bpy.context.view_layer.update()
    stale = staleness.stale_garments(bpy.context.scene)
    assert [g.name for g, _ in stale] == ["Shirt"] and "edited" in stale[0][1]
    np.testing.assert_array_equal(viewport_mesh(shirt), without_result(shirt))
    rendered = rendered_meshes(bpy.context.scene)["Shirt"][0]
    mw = np.array(shirt.matrix_world)
    np.testing.assert_allclose(rendered, without_result(shirt) @ mw[:3, :3].T + mw[:3, 3], atol=1e-6)
    # Inspect says so too, and resolving again brings the result back
    bpy.ops.deformrt.inspect_layers()
    assert "out of date, shown as fitted: Shirt" in json.loads(bpy.context.scene.deformrt.last_report)["message"]
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert staleness.stale_garments(bpy.context.scene) == []
    assert overlapping_pairs(rendered_meshes(bpy.context.scene)["Shirt"],
                             rendered_meshes(bpy.context.scene)["Jacket"]) == 0


@pytest.mark.parametrize("how", ["moved", "deleted", "added"])
def test_an_edited_mesh_is_passed_through_by_the_result_group_itself(extension, tubes, how):
    """A file edited where DeformRT is not installed: no handler marks anything, and the group
    still refuses to apply offsets to a mesh with other counts, or whose vertices moved."""
    body, (shirt, jacket) = tubes
    staleness = sub(extension, "addon.layers.staleness")
    bpy.ops.deformrt.resolve_layers()
    staleness.unregister()
    try:
        _edit(shirt, how)
        bpy.context.view_layer.update()
        assert staleness.stale_garments(bpy.context.scene) == []
        np.testing.assert_array_equal(viewport_mesh(shirt), without_result(shirt))
    finally:
        staleness.register()


def test_modifier_changes_above_the_result_make_it_stale_and_below_do_not(extension, tubes):
    body, (shirt, jacket) = tubes
    staleness = sub(extension, "addon.layers.staleness")
    bpy.ops.deformrt.resolve_layers()
    jacket.modifiers.new("Subdivision", "SUBSURF")  # after the result: it smooths the corrected garment
    bpy.context.view_layer.update()
    assert staleness.stale_garments(bpy.context.scene) == []
    displace = shirt.modifiers.new("Displace", "DISPLACE")
    displace.strength = 0.01
    shirt.modifiers.move(len(shirt.modifiers) - 1, 0)
    bpy.context.view_layer.update()
    assert [(g.name, r) for g, r in staleness.stale_garments(bpy.context.scene)] == \
           [("Shirt", "Shirt's modifiers above DeformRT changed")]
    jacket.location.z += 0.01
    bpy.context.view_layer.update()
    assert ("Jacket", "Jacket was moved against Body") in \
           [(g.name, r) for g, r in staleness.stale_garments(bpy.context.scene)]


def test_with_resolve_on_frame_change_an_edit_is_resolved_again(extension, tubes):
    body, (shirt, jacket) = tubes
    staleness = sub(extension, "addon.layers.staleness")
    bpy.context.scene.deformrt.resolve_on_frame_change = True
    bpy.context.scene.frame_set(1)
    _edit(shirt, "deleted")
    bpy.context.view_layer.update()
    assert staleness.stale_garments(bpy.context.scene) == []
    after = rendered_meshes(bpy.context.scene)
    assert overlapping_pairs(after["Shirt"], after["Jacket"]) == 0
    bpy.context.scene.deformrt.resolve_on_frame_change = False


def _tight_outfit(extension):
    """A capped body and two coarse tight sleeves that dip a few millimetres into it."""
    shapes, io = sub(extension, "sample_scenes.shapes"), sub(extension, "addon.io.mesh_io")
    col = bpy.context.scene.collection
    body = io.new_mesh_object("Body", *shapes.tube(0.15, 0.0, 0.6, grid=(64, 32), capped=True), col)
    body.deformrt.role, body.deformrt.layer = "BODY", 0
    made = []
    for layer, (name, radius, seed) in enumerate((("Leggings", 0.1495, 1), ("Top", 0.1505, 2)), start=1):
        v, f = shapes.tube(radius, 0.05 * layer, 0.55, grid=(20, 12),
                           folds=shapes.Folds(0.004, np.random.default_rng(seed)))
        obj = io.new_mesh_object(name, v, f, col)
        obj.deformrt.role, obj.deformrt.layer = "GARMENT", layer
        made.append(obj)
    sub(extension, "sample_scenes.studio").camera_and_lights(bpy.context.scene, target=(0.0, 0.0, 0.3), distance=1.3)
    return body, made


def _skin_through(extension, meshes):
    """Share of covered pixels where the body is seen in front of a garment within 2 cm."""
    metrics = sub(extension, "core.layering.metrics")
    layers = [meshes[n] for n in ("Body", "Leggings", "Top")]
    cams = metrics.camera_ring(*metrics.layer_bounds(layers), views=8, resolution=96)
    return metrics.poke_through(layers, cameras=cams, depth=0.02)[0]


def test_skin_covered_by_tight_garments_is_hidden_in_what_renders_and_off_leaves_the_body(extension, clean_scene):
    body, garments = _tight_outfit(extension)
    faces = len(body.data.polygons)
    before = rendered_meshes(bpy.context.scene)
    assert _skin_through(extension, before) > 0.01
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    after = rendered_meshes(bpy.context.scene)
    assert _skin_through(extension, after) < 0.001
    assert len(after["Body"][1]) < len(before["Body"][1])  # skin under the cloth left out ...
    assert len(body.data.polygons) == faces  # ... by a modifier: the body's mesh keeps every face
    bpy.context.scene.deformrt.hide_covered_skin = False
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert not body.modifiers
    np.testing.assert_array_equal(rendered_meshes(bpy.context.scene)["Body"][1], before["Body"][1])

"""A rigged MakeHuman character (Armature modifiers, MakeHuman's weights) played with Resolve on
Frame Change: every frame resolved on its own pose, nothing crossing in what renders."""

import importlib

import bpy
import numpy as np

from tests.addon.render_capture import overlapping_pairs, rendered_meshes


def sub(ext, path):
    return importlib.import_module(f"{ext.__name__}.{path}")


def test_the_rigged_outfit_deforms_as_its_skin_weights_say_and_plays_resolved(extension, clean_scene):
    makehuman, posed = sub(extension, "sample_scenes.makehuman"), sub(extension, "sample_scenes.posed")
    body, (sports, casual), arm = makehuman.build_animated(subdivision=False)
    scene = bpy.context.scene
    rig = posed.Rig()
    run = rig.animations["ramp_run01"]
    scene.frame_set(21)  # a keyed frame: the Armature modifier against linear blend skinning in numpy
    shown = rendered_meshes(scene)
    expected, _ = rig.frame(run[20])
    np.testing.assert_allclose(shown["Body"][0], expected + makehuman.FLOOR_SHIFT, atol=2e-4)
    fitted = overlapping_pairs(shown["Sports suit"], shown["Casual suit"])
    assert fitted > 0
    # between keys each bone turns the short way: its keyed quaternions on one side (q and -q are one
    # rotation, but Blender interpolates the numbers), so a frame between keys of the handstand ramp
    # stays near the poses' own blend (57 mm at frame 63; 286 mm with keys on both sides)
    for pb in arm.pose.bones:
        curves = [arm.animation_data.action.fcurves.find(f'pose.bones["{pb.name}"].rotation_quaternion', index=i)
                  for i in range(4)]
        keys = np.array([[k.co[1] for k in c.keyframe_points] for c in curves]).T
        assert (np.einsum("ij,ij->i", keys[1:], keys[:-1]) >= 0).all(), pb.name
    frames = np.concatenate([rig.animations[n][::-1] if back else rig.animations[n] for n, back in makehuman.RAMPS])
    scene.frame_set(63)
    between, _ = rig.frame(frames[62])
    assert np.linalg.norm(rendered_meshes(scene)["Body"][0] - between - makehuman.FLOOR_SHIFT, axis=1).max() < 0.1
    scene.frame_set(1)
    scene.deformrt.resolve_on_frame_change = True
    try:
        for f in range(1, 22):
            scene.frame_set(f)
        assert scene.deformrt.resolve_on_frame_change  # no frame stopped it
        after = rendered_meshes(scene)
        assert overlapping_pairs(after["Sports suit"], after["Casual suit"]) == 0  # 1,367 pairs as posed
        # the pose is followed: the resolved body is the posed one
        np.testing.assert_allclose(after["Body"][0][:100], shown["Body"][0][:100], atol=1e-6)
    finally:
        scene.deformrt.resolve_on_frame_change = False

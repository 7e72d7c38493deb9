"""Motion past the rig's ramps: the skeleton read back from the rig's matrices, checked against
MakeHuman's own ramps (made by turning every bone by the same share of its final turn each frame),
and the new motions' ends and cycles."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sample_scenes.motions import HARD_POSES, Skeleton, motions, ramp, travelling
from sample_scenes.posed import Rig


@pytest.fixture(scope="module")
def rig_and_skeleton():
    rig = Rig()
    return rig, Skeleton(rig)


@pytest.mark.parametrize("name, tolerance_mm", [("ramp_run01", 0.05), ("ramp_gym01", 2.5)])
def test_the_rigs_own_ramps_are_made_again_from_their_last_frame(rig_and_skeleton, name, tolerance_mm):
    """Each bone's turn in the ramp's last frame (relative to its parent, all relative to the root),
    ramped by forward kinematics on the read-back skeleton: the skinned body of every frame on the
    given one's. A wrong parent or a head off its joint moves the in-between frames by centimetres."""
    rig, skeleton = rig_and_skeleton
    given = rig.animations[name]
    given = np.einsum("fij,fbjk->fbik", np.linalg.inv(given[:, 0]), given)  # relative to the root
    last = given[-1]
    turns = {bone: last[p, :3, :3].T @ last[b, :3, :3]
             for b, (bone, p) in enumerate(zip(rig.bones, skeleton.parent, strict=True)) if p >= 0}
    turns = {bone: r for bone, r in turns.items() if Rotation.from_matrix(r).magnitude() > 1e-9}
    assert len(turns) > 100
    made = [skeleton.pose(t) for t in ramp(turns)]
    worst = max(np.abs(rig.frame(m)[0] - rig.frame(g)[0]).max() for m, g in zip(made, given, strict=True))
    assert worst * 1000 < tolerance_mm
    # the same ramp with every joint 3 cm in front of where it was read is centimetres off
    moved = Skeleton(rig)
    moved.head += [0.0, -0.03, 0.0]
    middle = len(made) // 2
    off = np.abs(rig.frame(moved.pose(ramp(turns)[middle]))[0] - rig.frame(given[middle])[0]).max()
    assert off > 0.01 and off > 4 * worst


def test_each_ramp_ends_in_its_pose_and_the_gaits_repeat(rig_and_skeleton):
    """A ramp starts at rest and ends turned wholly into its pose, a step's share between; the walk
    repeats every 30 frames and the jog every 18; every motion moves the body by decimetres."""
    rig, skeleton = rig_and_skeleton
    found = motions(skeleton)
    assert {f"rest to {p}" for p in HARD_POSES} <= set(found)
    for pose, turns in HARD_POSES.items():
        frames = found[f"rest to {pose}"]
        np.testing.assert_allclose(frames[0], skeleton.pose({}), atol=1e-12)
        np.testing.assert_allclose(frames[-1], skeleton.pose(turns), atol=1e-12)
        half = {b: Rotation.from_rotvec(0.5 * Rotation.from_matrix(r).as_rotvec()).as_matrix()
                for b, r in turns.items()}
        halfway = ramp(turns, frames=3)[1]
        for bone, r in half.items():
            np.testing.assert_allclose(halfway[bone], r, atol=1e-12)
    np.testing.assert_allclose(found["walk"][30], found["walk"][0], atol=1e-12)
    np.testing.assert_allclose(found["jog"][18], found["jog"][0], atol=1e-12)
    for name, frames in found.items():
        travel = max(np.abs(rig.frame(m)[0] - rig.body.rest).max() for m in frames[::6])
        assert travel > 0.1, name


def test_a_pose_given_for_the_left_side_is_mirrored_on_the_right(rig_and_skeleton):
    """MakeHuman's base body is mirror-symmetric (each vertex's mirror image in x is a vertex of
    it, found by a nearest-neighbour search): posed with turns given for the left side and
    mirrored, it stays so to the millimetre; the right side left at rest is a decimetre off."""
    from scipy.spatial import cKDTree

    from sample_scenes.motions import _mirrored, _y

    rig, skeleton = rig_and_skeleton
    rest = rig.body.rest
    gap, partner = cKDTree(rest).query(rest * [-1.0, 1.0, 1.0])
    assert gap.max() < 1e-6

    def asymmetry(turns):
        v = rig.frame(skeleton.pose(turns))[0]
        return np.abs(v[partner] * [-1.0, 1.0, 1.0] - v).max()

    for pose in ("arms_up", "sit_chair", "kneel", "deep_seat", "hug_knees", "flying", "cross_legs"):
        assert asymmetry(HARD_POSES[pose]) < 0.002, pose
    left = {"upperarm01.L": _y(-150), "clavicle.L": _y(-15)}
    assert asymmetry(_mirrored(left)) < 0.002 and asymmetry(left) > 0.1


def test_the_travelling_walk_is_the_walk_carried_rigidly_through_the_world(rig_and_skeleton):
    """Frame k of the travelling walk puts the body where the walk in place puts it, turned by k
    turns about the vertical and moved k steps forward (-Y) and by the bob: every vertex against
    that rigid motion applied to the in-place body (Rotation's own matrices). Carried the other way
    round (the world move inside the bones') the body comes apart by decimetres."""
    rig, skeleton = rig_and_skeleton
    walk = motions(skeleton)["walk"]
    speed, turn, bob = 1.2, 2.0, 0.03
    moving = travelling(walk, speed=speed, turn=turn, bob=bob)
    assert moving.shape == walk.shape
    for k in (0, 7, 30, 47):
        still = rig.frame(walk[k])[0]
        spin = Rotation.from_euler("z", turn * k, degrees=True)
        shift = np.array([0.0, -speed / 24.0 * k, bob * np.sin(4.0 * np.pi * k / 30.0)])
        np.testing.assert_allclose(rig.frame(moving[k])[0], spin.apply(still) + shift, atol=1e-6)  # a micrometre
    wrong = walk[30] @ np.linalg.inv(walk[0][0]) @ moving[30][0]  # the world move on the bones' side
    assert np.abs(rig.frame(wrong)[0] - rig.frame(moving[30])[0]).max() > 0.1

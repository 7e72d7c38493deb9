"""The posed MakeHuman figure: linear blend skinning against a bone-by-bone dense evaluation, and
the rest pose against the bundled fitted meshes."""

import numpy as np

from sample_scenes.posed import ANIMATIONS, OUTFIT, POSES, RIG, Rig


def test_skinning_matches_a_bone_by_bone_evaluation_and_the_rest_pose_is_the_fitted_outfit():
    rig = Rig()
    assert set(rig.poses) == set(POSES) and set(rig.animations) == set(ANIMATIONS)
    matrices = rig.poses["run01"]
    for mesh in [rig.body, *rig.garments]:
        dense = mesh.weights.toarray()
        h = np.c_[mesh.rest, np.ones(len(mesh.rest))]
        expected = sum(dense[:, b, None] * (h @ matrices[b].T)[:, :3] for b in range(len(matrices)))
        np.testing.assert_allclose(mesh.posed(matrices), expected, atol=1e-12)
    body, garments = rig.frame(rig.poses["rest"])
    for v, name in zip([body, *garments], ["body_female", *OUTFIT], strict=True):
        fitted = np.load(RIG.parent / f"{name}.npz")["vertices"].astype(np.float64)
        np.testing.assert_allclose(v, fitted, atol=2e-5)
    moved, _ = rig.frame(rig.animations["ramp_run01"][-1])
    assert np.abs(moved - body).max() > 0.1  # the run pose moves limbs by decimetres

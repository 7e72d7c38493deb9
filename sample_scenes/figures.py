"""Human figures as plain numpy data (no bpy), in Blender's axes: metres, z up, facing -y,
the figure's left side at +x, feet on z = 0.

- ``wooden()``: the Apache-2.0 "wooden" skinned mannequin of the mannequin-x package
  (assets/mannequin_x/, licence beside it), read straight from its .npz: 24k vertices,
  48k triangles in 29 closed parts, a 54-joint SMPL-X skeleton, 8 skin weights per vertex.
  T-pose, slim.
- ``stick_figure()``: the skeleton and per-joint radii of a stockier figure in an A-pose,
  which the Skin modifier turns into a smooth body (sample_scenes/bodies.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ASSETS = Path(__file__).parent / "assets"
WOODEN_NPZ = ASSETS / "mannequin_x" / "wooden.npz"

# The limbs the garment cutter measures positions along, by the figure-independent role name.
LIMB_ROLES = ("upper_arm.L", "upper_arm.R", "forearm.L", "forearm.R", "thigh.L", "thigh.R", "shin.L", "shin.R")


@dataclass
class Figure:
    name: str
    vertices: np.ndarray  # (n, 3), empty for a stick figure until Blender skins it
    faces: np.ndarray  # (m, 3)
    joint_names: list
    joints: np.ndarray  # (J, 3) joint (bone head) positions
    parents: np.ndarray  # (J,) parent joint index, -1 for the root
    weights: np.ndarray | None = None  # (n, J) skin weights, rows sum to 1
    limbs: dict = field(default_factory=dict)  # role -> (head joint index, tail joint index)
    heights: dict = field(default_factory=dict)  # landmark -> z: hip, waist, chest, armpit, neck, knee
    radii: np.ndarray | None = None  # (J, 2) Skin-modifier radii per joint (stick figures)

    def bone_tails(self) -> np.ndarray:
        """Each joint's bone ends at its first child (or continues its parent's direction)."""
        tails = np.zeros_like(self.joints)
        for j in range(len(self.joints)):
            kids = np.flatnonzero(self.parents == j)
            kids = [k for k in kids if np.linalg.norm(self.joints[k] - self.joints[j]) > 1e-4]
            if kids:
                tails[j] = self.joints[kids[0]]
            else:
                p = self.parents[j]
                d = self.joints[j] - self.joints[p] if p >= 0 else np.array([0.0, 0.0, 1.0])
                n = np.linalg.norm(d)
                tails[j] = self.joints[j] + (d / n if n > 1e-4 else np.array([0.0, 0.0, 1.0])) * 0.05
        return tails


def _to_blender(p: np.ndarray) -> np.ndarray:
    # SMPL-X: y up, facing +z, left at +x  ->  Blender: z up, facing -y, left at +x
    return np.column_stack([p[:, 0], -p[:, 2], p[:, 1]])


def wooden() -> Figure:
    with np.load(WOODEN_NPZ, allow_pickle=False) as z:
        v = _to_blender(z["vertices"].astype(np.float64))
        # the joints are in the vertices' frame (checked: joint = centre of the limb's cross-section)
        joints = _to_blender(z["skin_source_joint_positions"].astype(np.float64))
        names = [str(s) for s in z["joint_names"]]
        parents = z["parents"].astype(np.int64)
        idx, w = z["skin_joint_indices"].astype(np.int64), z["skin_weights"].astype(np.float64)
        faces = z["faces"].astype(np.int64)
    floor = v[:, 2].min()
    v[:, 2] -= floor
    joints[:, 2] -= floor
    weights = np.zeros((len(v), len(names)))
    np.add.at(weights, (np.repeat(np.arange(len(v)), idx.shape[1]), idx.ravel()), w.ravel())
    j = {n: i for i, n in enumerate(names)}
    limbs = {}
    for side, s in (("L", "L"), ("R", "R")):
        limbs[f"upper_arm.{side}"] = (j[f"{s}_Shoulder"], j[f"{s}_Elbow"])
        limbs[f"forearm.{side}"] = (j[f"{s}_Elbow"], j[f"{s}_Wrist"])
        limbs[f"thigh.{side}"] = (j[f"{s}_Hip"], j[f"{s}_Knee"])
        limbs[f"shin.{side}"] = (j[f"{s}_Knee"], j[f"{s}_Ankle"])
    z_of = {n: joints[i, 2] for n, i in j.items()}
    heights = {"hip": z_of["L_Hip"], "waist": 0.5 * (z_of["Torso"] + z_of["Spine"]), "chest": z_of["Chest"],
               "armpit": z_of["L_Shoulder"] - 0.07, "neck": z_of["Neck"], "knee": z_of["L_Knee"]}
    return Figure("Wooden", v, faces, names, joints, parents, weights, limbs, heights)


def stick_figure() -> Figure:
    """A stockier adult (1.75 m) in an A-pose: Rigify-style bone names, radii for the Skin modifier."""
    spec = [
        # name, parent, position (x, y, z), Skin-modifier radii (across, front-back) before subdivision
        ("hips", None, (0.0, 0.0, 0.98), (0.25, 0.17)),
        ("spine", "hips", (0.0, 0.0, 1.12), (0.22, 0.16)),
        ("chest", "spine", (0.0, 0.0, 1.30), (0.25, 0.17)),
        ("neck", "chest", (0.0, 0.0, 1.50), (0.05, 0.05)),
        ("head", "neck", (0.0, -0.01, 1.61), (0.12, 0.13)),
        ("head_top", "head", (0.0, -0.01, 1.75), (0.06, 0.06)),
    ]
    for side, sx in (("L", 1.0), ("R", -1.0)):
        spec += [
            (f"shoulder.{side}", "chest", (sx * 0.12, 0.0, 1.44), (0.10, 0.10)),
            (f"upper_arm.{side}", f"shoulder.{side}", (sx * 0.23, 0.0, 1.41), (0.085, 0.085)),
            (f"forearm.{side}", f"upper_arm.{side}", (sx * 0.39, 0.02, 1.19), (0.07, 0.07)),
            (f"hand.{side}", f"forearm.{side}", (sx * 0.52, 0.03, 1.00), (0.05, 0.05)),
            (f"hand_tip.{side}", f"hand.{side}", (sx * 0.58, 0.03, 0.90), (0.035, 0.035)),
            (f"thigh.{side}", "hips", (sx * 0.10, 0.0, 0.90), (0.13, 0.13)),
            (f"shin.{side}", f"thigh.{side}", (sx * 0.11, 0.0, 0.50), (0.085, 0.085)),
            (f"foot.{side}", f"shin.{side}", (sx * 0.12, 0.01, 0.08), (0.06, 0.06)),
            (f"toe.{side}", f"foot.{side}", (sx * 0.13, -0.15, 0.03), (0.05, 0.04)),
        ]
    names = [s[0] for s in spec]
    parents = np.array([names.index(s[1]) if s[1] else -1 for s in spec])
    joints = np.array([s[2] for s in spec], dtype=np.float64)
    radii = np.array([s[3] for s in spec], dtype=np.float64)
    j = {n: i for i, n in enumerate(names)}
    limbs = {}
    for side in ("L", "R"):
        limbs[f"upper_arm.{side}"] = (j[f"upper_arm.{side}"], j[f"forearm.{side}"])
        limbs[f"forearm.{side}"] = (j[f"forearm.{side}"], j[f"hand.{side}"])
        limbs[f"thigh.{side}"] = (j[f"thigh.{side}"], j[f"shin.{side}"])
        limbs[f"shin.{side}"] = (j[f"shin.{side}"], j[f"foot.{side}"])
    heights = {"hip": 0.90, "waist": 1.04, "chest": 1.28, "armpit": 1.33, "neck": 1.50, "knee": 0.50}
    return Figure("Stocky", np.zeros((0, 3)), np.zeros((0, 3), np.int64), names, joints, parents, None, limbs,
                  heights, radii)


def limb_position(points: np.ndarray, figure: Figure, role: str) -> np.ndarray:
    """Where along a limb bone each point lies: 0 at its head joint, 1 at its tail joint."""
    h, t = figure.limbs[role]
    a, b = figure.joints[h], figure.joints[t]
    ab = b - a
    return (points - a) @ ab / (ab @ ab)


def bone_weights(points: np.ndarray, figure: Figure, power: float = 4.0, keep: int = 4) -> np.ndarray:
    """Skin weights for a mesh around a stick skeleton: inverse distance to each bone segment
    to the ``power``, the ``keep`` largest per point, rows normalised."""
    heads, tails = figure.joints, figure.bone_tails()
    ab = tails - heads
    t = np.clip(np.einsum("njk,jk->nj", points[:, None] - heads[None], ab) / np.maximum((ab * ab).sum(1), 1e-12),
                0, 1)
    closest = heads[None] + t[..., None] * ab[None]
    d = np.linalg.norm(points[:, None] - closest, axis=2)
    w = 1.0 / np.maximum(d, 1e-4) ** power
    if keep < w.shape[1]:
        cut = np.partition(w, -keep, axis=1)[:, -keep][:, None]
        w = np.where(w >= cut, w, 0.0)
    return w / w.sum(1, keepdims=True)

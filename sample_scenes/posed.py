"""MakeHuman's outfit on its own skeleton, posed the way MPFB2 poses it: the default skeleton's
skin weights (the garments' interpolated from the body's through their .mhclo binding) and linear
blend skinning, as Blender's Armature modifier deforms a mesh. Still poses and two 24-frame ramps
(assets/makehuman/rig_female.npz, CC0). numpy only: core benchmarks and tests use it, and the
rigged Blender scene builds its armature from the same matrices."""

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

RIG = Path(__file__).parent / "assets" / "makehuman" / "rig_female.npz"
OUTFIT = ("female_sportsuit01", "female_casualsuit01")  # inner to outer
POSES = ("rest", "tpose", "run01", "gym01")
ANIMATIONS = ("ramp_run01", "ramp_gym01")


@dataclass
class SkinnedMesh:
    rest: np.ndarray  # (n, 3) float64
    faces: np.ndarray  # (m, 3) int64
    weights: sp.csr_matrix  # (n, bones), rows summing to 1

    def posed(self, matrices: np.ndarray) -> np.ndarray:
        """Vertices under the bones' skinning matrices (bones, 4, 4): sum_b w_b M_b [v, 1]."""
        h = np.c_[self.rest, np.ones(len(self.rest))]
        w = self.weights.tocoo()
        moved = np.einsum("kij,kj->ki", matrices[w.col, :3, :], h[w.row])  # each weight's bone image
        out = np.zeros((len(self.rest), 3))
        np.add.at(out, w.row, w.data[:, None] * moved)
        return out


class Rig:
    """The body and the outfit with their weights, and the poses' and animations' bone matrices."""

    def __init__(self, path=RIG, garments=OUTFIT):
        z = np.load(path)
        self.bones = [str(b) for b in z["bones"]]
        self.body = self._mesh(z, "body")
        self.garments = [self._mesh(z, g) for g in garments]
        self.poses = {p: z[f"pose_{p}"].astype(np.float64) for p in POSES}
        self.animations = {a: z[f"anim_{a}"].astype(np.float64) for a in ANIMATIONS}

    def _mesh(self, z, key):
        rest = z[f"{key}_rest"].astype(np.float64)
        w = sp.csr_matrix((z[f"{key}_W_data"].astype(np.float64), z[f"{key}_W_indices"].astype(np.int64),
                           z[f"{key}_W_indptr"]), shape=(len(rest), len(self.bones)))
        total = np.asarray(w.sum(1)).ravel()
        w = sp.diags(1.0 / np.where(total > 0, total, 1.0)) @ w
        return SkinnedMesh(rest, z[f"{key}_faces"].astype(np.int64), w.tocsr())

    def frame(self, matrices):
        """(body vertices, [garment vertices]) under one pose's bone matrices, rounded through
        float32 as Blender hands evaluated meshes over."""
        f32 = lambda v: v.astype(np.float32).astype(np.float64)  # noqa: E731
        return f32(self.body.posed(matrices)), [f32(g.posed(matrices)) for g in self.garments]

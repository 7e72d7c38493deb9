"""Motion beyond the rig's two ramps, for measuring what animators' characters meet: a walk, a jog,
the walk carried forward and turning as a captured one is, and 24-frame ramps from rest into
harder poses (sitting on the floor, on a chair, deep, cross-legged, squatting, hugging the knees, a
fighting stance, a lunge, kneeling, the splits, arms overhead, flying, bending and twisting),
posed by forward kinematics on MakeHuman's skeleton.

The rig file holds each bone's skinning matrix per pose, not the skeleton, so the skeleton is read
back from those matrices: a bone's head moves with its parent's bone (the joint stays attached), so
in every given pose M_b h = M_p h; over all the poses and ramp frames, the head is the least-squares
solution of (R_b - R_p) h = t_p - t_b, and the parent the earlier bone that leaves no residual.
Where several earlier bones move alike in all the given poses (the pelvis and the root, never
turned apart), the trunk's and the limbs' parents are MakeHuman's default skeleton's. numpy and
scipy only."""

import numpy as np
from scipy.spatial.transform import Rotation

from .posed import Rig

# MakeHuman's default skeleton, where the given poses do not tell the parent apart
KNOWN_PARENTS = {
    "pelvis.L": "root", "pelvis.R": "root", "spine05": "root", "upperleg01.L": "pelvis.L",
    "upperleg01.R": "pelvis.R", "spine04": "spine05", "spine03": "spine04", "spine02": "spine03",
    "spine01": "spine02", "breast.L": "spine02", "breast.R": "spine02", "clavicle.L": "spine01",
    "clavicle.R": "spine01", "neck01": "spine01", "lowerarm02.L": "lowerarm01.L",
    "lowerarm02.R": "lowerarm01.R", "wrist.L": "lowerarm02.L", "wrist.R": "lowerarm02.R",
    "lowerleg02.L": "lowerleg01.L", "lowerleg02.R": "lowerleg01.R", "foot.L": "lowerleg02.L",
    "foot.R": "lowerleg02.R",
}


def _x(deg):
    return Rotation.from_euler("x", deg, degrees=True).as_matrix()


def _y(deg):
    return Rotation.from_euler("y", deg, degrees=True).as_matrix()


def _z(deg):
    return Rotation.from_euler("z", deg, degrees=True).as_matrix()


class Skeleton:
    """Parents and joint heads (rest, Blender coordinates: the figure faces -Y, Z up, its left at +X)
    read back from a Rig's matrices; ``pose`` turns chosen bones about their heads."""

    def __init__(self, rig: Rig):
        self.bones = rig.bones
        seen = np.concatenate([np.stack(list(rig.poses.values()))] + list(rig.animations.values()))
        self.parent = np.full(len(self.bones), -1)
        self.head = np.zeros((len(self.bones), 3))
        for b in range(1, len(self.bones)):
            self.parent[b], self.head[b] = self._attached(seen, b)
        index = {n: i for i, n in enumerate(self.bones)}
        for bone, parent in KNOWN_PARENTS.items():
            self.parent[index[bone]] = index[parent]
        self.index = index

    @staticmethod
    def _attached(seen, b):
        """(parent, head) of bone b: the earlier bone it stays attached to in every seen pose."""
        best = None
        for p in range(b):
            a = (seen[:, b, :3, :3] - seen[:, p, :3, :3]).reshape(-1, 3)
            y = (seen[:, p, :3, 3] - seen[:, b, :3, 3]).reshape(-1)
            h = np.linalg.lstsq(a, y, rcond=None)[0]
            key = (round(float(np.linalg.norm(a @ h - y)), 5), b - p)
            if best is None or key < best[0]:
                best = (key, p, h)
        return best[1], best[2]

    def pose(self, turns: dict) -> np.ndarray:
        """Skinning matrices (bones, 4, 4) with each named bone turned by its 3x3 rotation (given in
        the rest frame) about its head, children following their parents."""
        out = np.zeros((len(self.bones), 4, 4))
        for b, name in enumerate(self.bones):  # parents come before their children
            local = np.eye(4)
            if name in turns:
                r = turns[name]
                local[:3, :3], local[:3, 3] = r, self.head[b] - r @ self.head[b]
            out[b] = local if self.parent[b] < 0 else out[self.parent[b]] @ local
        return out


def _mirrored(turns: dict) -> dict:
    """The left side's turns, and the same on the right (mirrored in x) unless given."""
    flip = np.diag([-1.0, 1.0, 1.0])
    out = dict(turns)
    for name, r in turns.items():
        if name.endswith(".L"):
            out.setdefault(name[:-2] + ".R", flip @ r @ flip)
    return out


# Still poses past the rig's own: hips bend forward with a negative turn about x, knees back with a
# positive one; an arm rises sideways with a negative turn about y on the left.
HARD_POSES = {
    "sit_floor": {"upperleg01.L": _x(-95), "upperleg01.R": _x(-95), "spine04": _x(10),
                  "upperarm01.L": _y(-10) @ _x(25), "upperarm01.R": _y(10) @ _x(25)},
    "sit_chair": _mirrored({"upperleg01.L": _x(-90), "lowerleg01.L": _x(90)}),
    "squat": _mirrored({"upperleg01.L": _z(-15) @ _x(-120), "lowerleg01.L": _x(130), "foot.L": _x(-20),
                        "upperarm01.L": _x(-70)}) | {"spine03": _x(-20)},
    "fight": {"upperleg01.L": _y(-20) @ _x(-25), "lowerleg01.L": _x(40), "upperleg01.R": _y(20) @ _x(20),
              "spine03": _z(25), "spine01": _x(-10), "upperarm01.L": _x(-80) @ _y(20),
              "lowerarm01.L": _x(-110), "upperarm01.R": _x(-60) @ _y(-30), "lowerarm01.R": _x(-120)},
    "kneel": _mirrored({"upperleg01.L": _x(-10), "lowerleg01.L": _x(100)}) | {"spine04": _x(-10)},
    "arms_up": _mirrored({"upperarm01.L": _y(-150), "clavicle.L": _y(-15)}),
    # deeper still (past 120 degrees the knee's skin folds through itself under linear blend
    # skinning, and cloth is trapped between thigh and calf or belly), and poses turning one side
    "deep_seat": _mirrored({"upperleg01.L": _x(-115), "lowerleg01.L": _x(120)}) | {"spine03": _x(-15)},
    "hug_knees": _mirrored({"upperleg01.L": _x(-135), "lowerleg01.L": _x(145), "upperarm01.L": _x(-60)})
    | {"spine03": _x(-25), "spine04": _x(-15)},
    "lunge": {"upperleg01.L": _x(-100), "lowerleg01.L": _x(100), "upperleg01.R": _x(35), "lowerleg01.R": _x(40),
              "spine03": _x(-10)},
    "flying": _mirrored({"upperarm01.L": _y(-10) @ _x(-165), "upperleg01.L": _x(15)}) | {"spine03": _x(15)},
    "side_bend": {"spine03": _z(30), "spine04": _z(15), "upperarm01.L": _y(-160), "upperarm01.R": _y(20)},
    "split": {"upperleg01.L": _x(-80), "upperleg01.R": _x(70), "lowerleg01.R": _x(10)},
    "cross_legs": _mirrored({"upperleg01.L": _z(-30) @ _x(-90), "lowerleg01.L": _x(120)}),
    "twist": {"spine03": _y(35), "spine05": _y(20), "upperarm01.L": _x(-90), "lowerarm01.L": _x(-90)},
}


def ramp(turns: dict, frames: int = 24) -> list:
    """From rest into ``turns`` over ``frames`` frames, each bone's turn by the same share a frame."""
    vectors = {name: Rotation.from_matrix(r).as_rotvec() for name, r in turns.items()}
    return [{name: Rotation.from_rotvec(k / (frames - 1) * v).as_matrix() for name, v in vectors.items()}
            for k in range(frames)]


def gait(frames: int, period: float, stride: float = 1.0) -> list:
    """A walk (period 30 frames at 24 fps: 0.8 cycles a second) or a jog (18 frames, stride 1.3):
    thighs swing +-28 degrees, the knee bends in the swing, arms swing against the legs, the chest
    twists a little."""
    out = []
    for k in range(frames):
        phase = 2 * np.pi * k / period
        swing = np.sin(phase) * stride
        knee_l = 60 * max(0.0, np.sin(phase + 1.2)) * stride + 5
        knee_r = 60 * max(0.0, np.sin(phase + 1.2 + np.pi)) * stride + 5
        out.append({"upperleg01.L": _x(-28 * swing), "upperleg01.R": _x(28 * swing),
                    "lowerleg01.L": _x(knee_l), "lowerleg01.R": _x(knee_r),
                    "foot.L": _x(-0.3 * knee_l), "foot.R": _x(-0.3 * knee_r),
                    "upperarm01.L": _x(22 * swing) @ _y(-8), "upperarm01.R": _x(-22 * swing) @ _y(8),
                    "lowerarm01.L": _x(-15 - 10 * max(0.0, -swing)), "lowerarm01.R": _x(-15 - 10 * max(0.0, swing)),
                    "spine03": _z(6 * swing), "spine05": _x(-4)})
    return out


def travelling(frames: np.ndarray, speed: float = 1.4, turn: float = 1.5, bob: float = 0.02,
               period: float = 30.0) -> np.ndarray:
    """Skinning matrices ``frames`` (frames, bones, 4, 4) of motion in place carried through the
    world as a captured walk is: forward (-Y) at ``speed`` metres a second at 24 fps, turning by
    ``turn`` degrees a frame about the vertical, bobbing ``bob`` metres twice a step cycle."""
    out = np.empty_like(frames)
    for k, m in enumerate(frames):
        world = np.eye(4)
        world[:3, :3] = _z(turn * k)
        world[:3, 3] = [0.0, -speed / 24.0 * k, bob * np.sin(4.0 * np.pi * k / period)]
        out[k] = world @ m
    return out


def motions(skeleton: Skeleton) -> dict:
    """Name -> frames of skinning matrices: a walk (48 frames) in place and travelling, a jog (36),
    and ramps into the hard poses."""
    turns = {"walk": gait(48, 30.0), "jog": gait(36, 18.0, 1.3)}
    turns |= {f"rest to {name}": ramp(pose) for name, pose in HARD_POSES.items()}
    out = {name: np.stack([skeleton.pose(t) for t in frames]) for name, frames in turns.items()}
    walk = out.pop("walk")
    return {"walk": walk, "walk, travelling and turning": travelling(walk), **out}

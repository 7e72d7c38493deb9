"""Frame to frame (playback, frame bakes): what a frame resolved after the last one keeps of it, so
nothing a viewer sees changes faster than the figure itself moves.

Each frame resolved on its own is right, but its discrete choices (which body point a garment
point takes, whether the body guard takes a push back, which edges the stretch relaxation draws
in) flip from one frame to the next, and the correction d = resolved - posed jumps: on MakeHuman's
ramps 25-52 mm of second difference in a frame at a few vertices, where the cloth itself
accelerates 2.5 mm (p99). Three rules keep it as smooth as the cloth:

- **Hidden faces held**: a face hidden because it crossed stays hidden HIDE_HOLD frames after it
  last crossed, so a face crossing every other frame does not blink; a face shown again stays
  shown two frames at least.
- **The correction's acceleration bounded**: from the last two frames' corrections, each turned
  with the body under the point (the least rotation taking the body's normal there then to its
  normal now, at the point's body point now), the next is
  predicted (constant velocity); the new one may differ from the prediction by JERK offsets plus
  MOTION_SHARE of how much the cloth itself accelerated at that vertex relative to its body point
  (``_cloth_acceleration``). A flip between two valid corrections is spread over frames; a fast
  move (a kick, a jump cut in a capture) still gets the correction it needs, because the bound
  grows with the cloth's own acceleration. Measured: with no share of the cloth's acceleration,
  ramps played three times faster show 2.3% poke-through (the correction lags behind what the
  motion needs); a share of 0.15 keeps them at 0.00%. JERK was 0.5 offsets until stop 66: with the
  relative acceleration, 0.25 brings the corrections' second difference p99 from 0.90-1.27 mm to
  0.47-0.75 mm on the casual suit's ramps, walks and squats (docs/REPORT.md).
  The corrections are turned because a lift or push is along the cloth's global normal:
  kept fixed in world space while a limb turns, the last correction pointed ever further from
  this frame's, the bounded step toward it went sideways, and the length never came down (a
  T-pose to gym blend: a 56 mm lift held for 8 frames where the frame's own fell to 26 mm). Turned
  as the body turned at the point's body point now (its vertex normals, blended there, then and
  now), which moves smoothly however the point's body point changes, and only as far as a body
  turns in a frame (``followed``); not with the posed cloth's own normals (they swing by tens of
  degrees a frame in folds: jitter max 3 -> 25 mm on the rest-to-run ramp), nor with its global
  normals (they jump where the body point goes to another part: 4 -> 41 mm), nor with the face
  normal of the body triangle under it (a skinned triangle folding at a joint flips: 10 -> 96 mm).
- **Corrections held** (issue 57's hysteresis): a correction changes only where the frame's
  bounded one departs from the last (turned with the body) by more than HOLD offsets, and then by
  what goes past that band, so it never jumps; the band narrows as the cloth accelerates relative
  to its body point (HOLD offsets over 1 + that acceleration in offsets), and the bound above
  grows by the band, so a correction that must move moves as fast as before, one band behind.
  Frame by frame the correction wanders by hundredths to tenths of a millimetre where nothing asks
  it to; where it hovered about a millimetre it switched on and off. Held, vertices switching
  within three frames 0.4-5.8 -> 0.1-0.9 a frame on the ramps, the walk and the jog; crossing
  edges on the walk and the jog 3 -> 0 and 19 -> 4, the jog's poke-through 0.24 -> 0.05%; the
  second difference as before. A band held without growing the bound froze corrections: the
  bounded step (JERK offsets from the prediction) never left a band wider than it, and a
  correction from rest never started (docs/REPORT.md, stop 68).
- **The correction's acceleration capped in the world**: whatever the rules above let through, a
  correction's second difference in the world (what a viewer sees jolt) is at most ACCEL_CAP
  offsets. The turn followed is the body's turn under the point, and skin folding in a crease (the
  crotch on a walk) turns up to 10-20 degrees a frame and back: a 20-30 mm lift turned with it
  jolted 6-11 mm in the world on a walk and a jog, and 19 mm on the gym ramp played three times as
  fast. Capped at 2 offsets (about 4 mm on a person): 4.2 / 4.3 / 4.3 mm; the jog's poke-through
  0.05 -> 0.13% and its crossing edges 4 -> 7 (a lift a frame or two late), the walk's and the
  harder poses' unchanged (docs/REPORT.md, stop 70).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.vectors import cross, norms

HIDE_HOLD = 3
JERK = 0.25  # offsets d per frame per frame (about 0.5 mm on a person)
MOTION_SHARE = 0.15
# offsets d: how far a correction may stay from where the frame's bounded one goes (0.5 mm on a person)
HOLD = 0.25
# offsets d per frame per frame, in the world (issue 57 allows 5 mm on any frame; an offset is about 2 mm)
ACCEL_CAP = 2.0


class History:
    """What the next frame needs of this one and the one before: per garment the correction and the
    posed vertices it was made for, and the body's vertices and vertex normals (arrays only: no
    chain of earlier results)."""

    def __init__(self, moved, posed, body_normals, earlier=None, body_vertices=None):
        self.moved, self.posed, self.body_normals = moved, posed, body_normals
        self.body_vertices = body_vertices
        self.moved_before = earlier.moved if earlier is not None else None
        self.posed_before = earlier.posed if earlier is not None else None
        self.body_normals_before = earlier.body_normals if earlier is not None else None
        self.body_vertices_before = earlier.body_vertices if earlier is not None else None


def turned(d, a, b):
    """Vectors ``d`` turned by the least rotation taking unit normals ``a`` to ``b`` (per row);
    left as they are where either normal is zero or they point opposite ways (no one rotation)."""
    axis = cross(a, b)
    c = np.einsum("ij,ij->i", a, b)
    ok = (c > -0.9) & (norms(a) > 0) & (norms(b) > 0)
    k, cc = axis[ok], c[ok]
    v = d[ok]
    # Rodrigues with the unnormalised axis k = a x b (|k| = sin): v c + k x v + k (k . v) / (1 + c)
    out = d.copy()
    out[ok] = v * cc[:, None] + cross(k, v) + k * (np.einsum("ij,ij->i", k, v) / (1.0 + cc))[:, None]
    return out


# How far the body under a point may turn in one frame and the last corrections turn with it:
# wholly up to TURN_FULL, fading out by TURN_NONE. Skinned skin folding at a joint (linear blend
# skinning in extreme poses) flips its normals by 90-130 degrees in a frame; that is no turn of the
# cloth, and corrections turned with it jumped 50-96 mm.
TURN_FULL, TURN_NONE = 10.0, 20.0  # degrees a frame


def followed(d, a, b, frames=1):
    """``d`` turned as the body under it turned from normal ``a`` to ``b`` (``turned``) over
    ``frames`` frames, wholly where it turned by at most TURN_FULL degrees a frame, not at all
    beyond TURN_NONE, in between in part."""
    share = turn_share(a, b, frames)
    return d + share[:, None] * (turned(d, a, b) - d)


def turn_share(a, b, frames=1):
    """How much of a turn from unit normals ``a`` to ``b`` over ``frames`` frames is followed (1 up to
    TURN_FULL degrees a frame, 0 beyond TURN_NONE)."""
    c = np.einsum("ij,ij->i", a, b)
    full, none = np.cos(np.radians(np.minimum(frames * np.array([TURN_FULL, TURN_NONE]), 180.0)))
    return np.clip((c - none) / (full - none), 0.0, 1.0)


def held_hidden(crossing, previous_removed, previous_clear, previous_shown, simulated=None):
    """Hidden faces with the hold over the last frame's; per face how many frames it has not
    crossed and how many it has been shown (both capped). ``previous_*`` None on a first frame.

    Neither state lasts a single frame: a face stays hidden HIDE_HOLD frames after it last
    crossed, and a face shown again after being hidden stays shown one more frame even if it
    crosses then (hidden, shown, hidden is a blink too; the hold hides it the frame after).
    Not on a ``simulated`` garment (per garment; None: none is): a cloth solver's contacts come
    and go every frame, and the faces kept shown crossing were up to 81 crossing edges a frame on
    four falling sheets, against none hidden. A face shown for one frame there lies behind the
    layer it crossed (it crosses neither frame before nor after), where it is rarely seen."""
    if previous_clear is None:
        shown = [np.where(c, 0, 2).astype(np.int8) for c in crossing]  # shown on a first frame: not just now
        return crossing, [np.where(c, 0, HIDE_HOLD + 1).astype(np.int8) for c in crossing], shown
    removed, clear, shown = [], [], []
    olds = previous_shown if previous_shown is not None else [None] * len(crossing)
    solver = simulated if simulated is not None else [False] * len(crossing)
    for now, was, before, run, sim in zip(crossing, previous_removed, previous_clear, olds, solver, strict=True):
        since = np.where(now, 0, np.minimum(before.astype(np.int16) + 1, HIDE_HOLD + 1)).astype(np.int8)
        hide = now | (was & (since <= HIDE_HOLD))
        if run is not None and not sim:
            hide &= ~(~was & (run == 1))  # shown since the last frame only: shown once more
        removed.append(hide)
        clear.append(since)
        shown.append(np.where(hide, 0, np.minimum(run + 1 if run is not None else 2, 2)).astype(np.int8))
    return removed, clear, shown


@dataclass(frozen=True)
class BodyNow:
    """The body under a layer this frame: the layer's BodyCorrespondence (``binding``), and the
    body's vertex normals, faces and vertices."""

    binding: object
    normals: np.ndarray
    faces: np.ndarray
    vertices: np.ndarray


def _cloth_acceleration(world, history: History, body: BodyNow, followed_share):
    """How fast the cloth's own motion asks the correction to change, per vertex: its acceleration
    relative to its body point (``world`` less the body point's) where the correction turns with
    the body (``followed_share`` 1), in the world where the body turned too fast to be followed
    (0), blended between. Cloth skinned to the limb under it keeps its place on the body however
    fast the limb swings, and needs no new correction for it: the world's acceleration let a walking
    leg's correction wander by 15% of the leg's swing (jitter max 7.7 mm on a walk's crotch). Where
    the body turns more than a frame's turn, the last corrections are not turned with it and the
    correction must keep up with the cloth in the world (three times the given ramps' speed:
    8.6% poke-through on the relative measure alone, 0.05% blended)."""
    if followed_share is None or history.body_vertices is None or len(history.body_vertices) != len(body.vertices):
        return world
    binding, faces = body.binding, body.faces
    before = history.body_vertices_before  # None on the first frame eased: then as the last one
    if before is not None and len(before) != len(body.vertices):
        return world  # the body two frames back was another mesh
    b1 = binding.points(history.body_vertices, faces)
    b2 = binding.points(before, faces) if before is not None else b1
    relative = world - (binding.points(body.vertices, faces) - 2.0 * b1 + b2)
    return followed_share[:, None] * relative + (1.0 - followed_share[:, None]) * world


def eased(vertices, posed, k, history: History, offset: float, body: BodyNow):
    """Layer k's resolved ``vertices`` (posed at ``posed``) with the correction's change from the
    constant-velocity prediction bounded (module docstring), and how many vertices were bounded;
    (None, 0) where none is."""
    binding, body_normals, body_faces = body.binding, body.normals, body.faces

    def normal_at(normals):  # the body's normal at each point's body point, in those normals
        return binding.normals(normals, body_faces)

    now = normal_at(body_normals)
    same = len(history.body_normals) == len(body_normals)  # else another mesh: nothing carried over
    then = normal_at(history.body_normals) if same else None

    def turned_since(d, normals, frames):  # normals of another mesh than this frame's: kept as it was
        return followed(d, normal_at(normals), now, frames) if len(normals) == len(body_normals) else d

    d1, x1 = (followed(history.moved[k], then, now) if same else history.moved[k]), history.posed[k]
    if history.moved_before is not None:
        d2, x2 = turned_since(history.moved_before[k], history.body_normals_before, 2), history.posed_before[k]
    else:
        d2, x2 = d1, x1
    predicted = 2.0 * d1 - d2
    change = vertices - posed - predicted
    size = norms(change)
    motion = _cloth_acceleration(posed - 2.0 * x1 + x2, history, body, turn_share(then, now) if same else None)
    band = HOLD * offset / (1.0 + norms(motion) / offset)
    # the band is added to the bound: what the hold then takes back, it may first go further
    bound = JERK * offset + MOTION_SHARE * norms(motion) + band
    over = size > bound
    own = vertices - posed
    d = own.copy()
    if over.any():
        bounded = predicted[over] + change[over] * (bound[over] / size[over])[:, None]
        # a trend carried on must not overshoot: never further than this frame's own correction or the
        # last one (the prediction runs on past a correction that has stopped growing)
        most = np.maximum(norms(d[over]), norms(d1[over]))
        bounded *= np.minimum(1.0, most / np.maximum(norms(bounded), 1e-30))[:, None]
        d[over] = bounded
    kept = _held(d, d1, band)
    if history.moved_before is not None:
        kept = _capped(kept, 2.0 * history.moved[k] - history.moved_before[k], ACCEL_CAP * offset)
    other = (kept != own).any(axis=1)
    out = vertices.copy()
    out[other] = posed[other] + kept[other]
    changed = (out != vertices).any(axis=1)  # not those only rounded back onto where they were
    return (out, int(changed.sum())) if changed.any() else (None, 0)


def _capped(d, trend, most):
    """Corrections ``d`` no farther than ``most`` from the world's constant-velocity ``trend`` (not
    turned with the body: the second difference a viewer sees)."""
    gap = d - trend
    size = norms(gap)
    far = size > most
    if not far.any():
        return d
    out = d.copy()
    out[far] = trend[far] + gap[far] * (most / size[far])[:, None]
    return out


def _held(d, last, band):
    """Corrections ``d`` kept at the ``last`` ones (turned with the body) where they differ by at most
    ``band`` per vertex, and moved by what goes past the band where they differ more (a backlash:
    no jump as the band is left)."""
    gap = d - last
    size = norms(gap)
    share = np.maximum(size - band, 0.0) / np.maximum(size, 1e-30)
    return last + gap * share[:, None]

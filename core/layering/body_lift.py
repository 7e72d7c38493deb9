"""Lifting cloth off the body: garments fitted one at a time to a body often lie on its skin or
inside it (a tight top, leggings under jeans). There the skin shows through, and a lower layer
has no room to go behind a higher one. Each layer is first lifted along its global normals to its
floor (LayerStack.floor: the lowest layer nearest the body), so the stages that follow find room."""

from __future__ import annotations

import numpy as np

from ..geometry.normals import vertex_normals

# A garment with thickness (two shells, as Solidify makes) has about half of its surface facing the
# body; one cloth surface has a few folds and collars that do. Above this share it is shelled.
_SHELLED = 0.3
_FADE = 0.25
RATE = 0.5


def inner_shell(stack, k):
    """Layer k's vertices facing the body, if it has thickness (two shells, _SHELLED); else None."""
    facing_in = np.einsum("ij,ij->i", vertex_normals(stack.verts[k], stack.faces[k]), stack.normals[k]) < 0
    return facing_in if facing_in.mean() > _SHELLED else None


def lift_off_body(stack, k, distance, held=None) -> np.ndarray:
    """Lift layer k of the LayerStack where it lies under its floor or inside the body; ``distance``:
    each vertex's distance from its nearest body point (the way out, when inside). Left as they are:
    vertices farther from their body point than their probe reaches (cloth that has slid away from
    where the body point was found: no distance to trust), and the inner shell of a garment with
    thickness (facing the body, behind its outer one). ``held``: the last frame's lift per vertex
    (playback): the lift then changes by at most RATE gaps a frame, up or down. The depth of cloth
    sunk in the body jumps where two body parts meet (its nearest point goes from one to the
    other) and cloth found inside at once was inside unseen the frames before: a lift dropped or
    taken at once is seen as a jolt; one eased in over a few frames is not, and the stages that
    follow push a lift held a little long back behind the layers above. Returns the lift per vertex."""
    floor = stack.floor(k)
    clearance = stack.clearance[k]
    inside = np.isinf(clearance)
    lift = np.where(inside, distance + floor, np.maximum(floor - clearance, 0.0))
    # faded out over the last quarter of the reach, not cut at it: a vertex whose distance crosses
    # the reach as the figure moves would be lifted by the whole depth one frame and not the next
    reach = stack.probe_len[k]
    lift *= np.clip((reach - distance) / (_FADE * np.maximum(reach, 1e-30)), 0.0, 1.0)
    facing_in = inner_shell(stack, k)
    if facing_in is not None:
        lift[facing_in] = 0.0
    needed = lift
    if held is not None and len(held) == len(lift):
        step = RATE * stack.gap
        lift = np.clip(needed, held - step, held + step).clip(0.0)
    lifted = lift > 0
    if not lifted.any():
        return lift
    out = stack.verts[k].copy()
    out[lifted] += stack.normals[k][lifted] * lift[lifted, None]
    # at the floor when lifted as far as needed; short of it (no room to push in) or beyond it
    clearance[lifted] = np.where(needed > 0, floor, clearance)[lifted] + (lift - needed)[lifted]
    stack.moved(k, out)  # resolve makes where the lift leaves it the body guard's rest
    stack.moved_by["lift"] += int(lifted.sum())
    return lift

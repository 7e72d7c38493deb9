"""Relaxing edges the lift pulled apart: where two vertices a millimetre apart take body points
on opposite sides of something thin (a shoe's welt, a collar's fold), the lift moves them
along opposite global normals and the edge between them grows several times over. Seen as a
tear; nothing about the layers' order needs it."""

from __future__ import annotations

import numpy as np

# An edge longer than this many times its fitted length after the lift has its ends' moves drawn
# together (resolve._relax).
MAX_STRETCH = 2.5
_ROUNDS = 40


def relax_stretch(fitted, moved_to, edges):
    """``moved_to`` (n, 3) with every edge (m, 2) over MAX_STRETCH times its length in ``fitted``
    brought back under it: each round the two ends' moves are drawn to their mean (both ends
    move, so the edge keeps its place between them), a vertex of several such edges taking the
    mean of their pulls (a smoothing of the moves over the torn edges alone, so it converges).
    Returns (vertices, how many vertices were drawn)."""
    if not len(edges):
        return moved_to, 0
    a, b = edges[:, 0], edges[:, 1]
    rest = np.linalg.norm(fitted[a] - fitted[b], axis=1)
    over = np.linalg.norm(moved_to[a] - moved_to[b], axis=1) > MAX_STRETCH * rest
    if not over.any():
        return moved_to, 0
    # only edges at a torn one's ends or at a drawn vertex can tear as ends are drawn: each round
    # looks at those
    near = np.zeros(len(fitted), dtype=bool)
    near[edges[over].ravel()] = True
    move = moved_to - fitted
    drawn = np.zeros(len(fitted), dtype=bool)
    for _ in range(_ROUNDS):
        ask = np.flatnonzero(near[a] | near[b])
        now = np.linalg.norm(fitted[a[ask]] + move[a[ask]] - fitted[b[ask]] - move[b[ask]], axis=1)
        over = ask[now > MAX_STRETCH * rest[ask]]
        if not len(over):
            break
        near[a[over]] = near[b[over]] = True
        ea, eb = a[over], b[over]
        half = 0.5 * (move[eb] - move[ea])
        pull = np.zeros_like(move)
        count = np.zeros(len(move))
        np.add.at(pull, ea, half)
        np.add.at(pull, eb, -half)
        np.add.at(count, ea, 1)
        np.add.at(count, eb, 1)
        touched = count > 0
        move[touched] += pull[touched] / count[touched, None]
        drawn[touched] = True
    return fitted + move, int(drawn.sum())

"""Relaxing edges the lift pulled apart: where two vertices a millimetre apart take body points
on opposite sides of something thin (a shoe's welt, a collar's fold), the lift moves them
along opposite global normals and the edge between them grows several times over. Seen as a
tear; nothing about the layers' order needs it."""

from __future__ import annotations

import numpy as np

# An edge longer than this many times its fitted length after the lift has its ends' moves drawn
# together (resolve._relax).
MAX_STRETCH = 2.5
# After every stage, an edge longer than this is shortened (shorten_torn): the push and tuck move
# each end along its own global normal, and where those diverge (a fold between two body parts)
# they tear it: 3.03x on the t-shirt under the suit running. Drawing the moves to their mean
# there instead drew pushed cloth back out (Fig 4.12's poke-through 0.01% -> 0.07-0.13%);
# shortening along the edge moves it 0.023% -> 0.038% (16 views of 128 px).
MAX_TORN = 2.9
_ROUNDS = 40


def _mean_pulls(n, ea, eb, half):
    """Each edge (ea, eb) pulls its first end by ``half`` and its second by ``-half``; per vertex of
    ``n``, the mean of its pulls and whether it was pulled."""
    pull = np.zeros((n, 3))
    count = np.zeros(n)
    np.add.at(pull, ea, half)
    np.add.at(pull, eb, -half)
    np.add.at(count, ea, 1)
    np.add.at(count, eb, 1)
    touched = count > 0
    pull[touched] /= count[touched, None]
    return pull, touched


def relax_stretch(fitted, moved_to, edges):
    """``moved_to`` (n, 3) with every edge (m, 2) over MAX_STRETCH times its length in ``fitted``
    brought back to it: each round the two ends' moves are drawn towards their mean until the edge
    is at the limit (both ends move, so the edge keeps its place between them), a vertex of
    several such edges taking the mean of their pulls (a smoothing of the moves over the torn
    edges alone, so it converges).
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
        diff = move[eb] - move[ea]
        # the ends' moves drawn together just so far that the edge is back at the limit (the share
        # t of their difference kept solves |f + t diff| = MAX_STRETCH x its fitted length, t in
        # (0, 1)): an edge a little over it is moved a little. Drawing them to their mean pulled an
        # edge just past the limit all the way in, and one just under it not at all: on a ramp
        # that jumped 4-5 mm in a frame where an edge crossed the limit (jitter max 6.5 -> 4.3 mm)
        f = fitted[eb] - fitted[ea]
        dd = np.einsum("ij,ij->i", diff, diff)
        fd = np.einsum("ij,ij->i", f, diff)
        short = np.einsum("ij,ij->i", f, f) - (MAX_STRETCH * rest[over]) ** 2  # < 0: under the limit
        t = (-fd + np.sqrt(np.maximum(fd * fd - dd * short, 0.0))) / np.maximum(dd, 1e-300)
        pull, touched = _mean_pulls(len(move), ea, eb, 0.5 * (1.0 - np.clip(t, 0.0, 1.0))[:, None] * diff)
        move[touched] += pull[touched]
        drawn |= touched
    return fitted + move, int(drawn.sum())


def shorten_torn(fitted, moved_to, edges, limit):
    """``moved_to`` with every edge over ``limit`` times its fitted length shortened to it, both
    ends drawn towards each other along the edge (a vertex of several such edges taking the mean
    of its pulls). Unlike drawing the ends' moves to their mean, no end goes back the way it was
    pushed: where the two ends were pushed along opposite global normals (a fold between two body
    parts), their mean move is no push at all. Returns (vertices, how many vertices were drawn)."""
    if not len(edges):
        return moved_to, 0
    a, b = edges[:, 0], edges[:, 1]
    rest = np.linalg.norm(fitted[a] - fitted[b], axis=1)
    out = moved_to.copy()
    drawn = np.zeros(len(fitted), dtype=bool)
    ask = np.arange(len(edges))
    for _ in range(_ROUNDS):
        vec = out[b[ask]] - out[a[ask]]
        now = np.linalg.norm(vec, axis=1)
        over = now > limit * rest[ask]
        if not over.any():
            break
        sel = ask[over]
        half = (0.5 * (now[over] - limit * rest[sel]) / now[over])[:, None] * vec[over]
        pull, touched = _mean_pulls(len(out), a[sel], b[sel], half)
        out[touched] += pull[touched]
        drawn |= touched
        ask = np.flatnonzero(touched[a] | touched[b])  # only edges at a drawn vertex can change
    return out, int(drawn.sum())

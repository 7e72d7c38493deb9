"""Where layer probes start and which of their hits are ties: a probe exactly through a vertex or
along a triangle's plane meets it or not by float32 round-off, so it is moved off the line or the
hit is decided by the geometry alone, the same way however the scene is turned."""

from __future__ import annotations

import numpy as np

from ..geometry.normals import face_normals
from ..geometry.vectors import norms

_GRAZING_COS = 0.05  # about 87 degrees from the triangle's normal


def grazing(vertices, faces, directions):
    """Per ray (unit ``directions``), whether it runs within _GRAZING_COS of its triangle's plane
    (a degenerate triangle has none)."""
    n = face_normals(vertices, faces)
    return (np.abs(np.einsum("ij,ij->i", n, directions)) < _GRAZING_COS) & (norms(n) > 0)


def on_edges(vertices, faces, edges, points, tolerance):
    """Per hit (its triangle's corners ``faces``, where it hit ``points``): within ``tolerance``
    of one of the triangle's corners or edges that lies on ``edges`` (sorted vertex pairs)."""
    out = np.zeros(len(points), dtype=bool)
    if not len(edges):
        return out
    n_vertices = len(vertices)
    on = np.zeros(n_vertices, dtype=bool)
    on[edges.ravel()] = True
    for a in range(3):
        near = np.flatnonzero(on[faces[:, a]])
        out[near] |= norms(points[near] - vertices[faces[near, a]]) <= tolerance[near]
    keys = np.sort(edges[:, 0] * np.int64(n_vertices) + edges[:, 1])
    for a, b in ((0, 1), (1, 2), (2, 0)):
        lo, hi = np.minimum(faces[:, a], faces[:, b]), np.maximum(faces[:, a], faces[:, b])
        k = lo * np.int64(n_vertices) + hi
        near = np.flatnonzero(keys[np.minimum(np.searchsorted(keys, k), len(keys) - 1)] == k)
        if not len(near):
            continue
        start, edge = vertices[lo[near]], vertices[hi[near]] - vertices[lo[near]]
        s = np.clip(np.einsum("ij,ij->i", points[near] - start, edge) / np.maximum(
            np.einsum("ij,ij->i", edge, edge), 1e-300), 0.0, 1.0)
        out[near] |= norms(points[near] - start - edge * s[:, None]) <= tolerance[near]
    return out


def off_the_lines(vertices, topology, step, directions, which=None):
    """Probe origins at ``vertices`` (those of ``which``, indices, if given), each moved ``step``
    sideways to its probe's direction (``directions``, unit, one per origin), toward the centre of
    the first triangle it is a corner of: the distance a probe meets something at is then still
    measured from the vertex.

    Why: artists' garments are often bound vertex by vertex to the same body points, so a probe
    along a lower garment vertex's normal runs exactly through a higher garment's vertex (its
    hem's, or any). Embree's float32 test then meets one of the triangles round that vertex or
    none, by round-off, and which one changed with the scene's orientation (up to 2.4 mm on
    MakeHuman's outfits). A step of a ten-thousandth of an edge takes the probe off the vertex
    into a triangle, by the geometry alone: turned with the scene, it is turned the same way."""
    ids = np.arange(len(vertices)) if which is None else np.asarray(which)
    out = np.array(vertices[ids], dtype=np.float64, copy=True)
    first = topology.first_face[ids]
    has = np.flatnonzero(first < len(topology.faces))
    if not len(has) or step == 0:
        return out
    toward = vertices[topology.faces[first[has]]].mean(axis=1) - out[has]
    d = directions[has]
    toward -= d * np.einsum("ij,ij->i", toward, d)[:, None]
    length = norms(toward)
    ok = length > 0  # (a negative step goes the other way)
    out[has[ok]] += toward[ok] * (step / length[ok])[:, None]
    return out


__all__ = ["grazing", "off_the_lines", "on_edges"]

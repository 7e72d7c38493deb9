"""Meshes made fit for tracing: what a cloth solver that blew up leaves at NaN or infinite
positions is left out, as Cycles renders such a mesh."""

from dataclasses import replace

import numpy as np


def finite_part(a):
    """(``a`` without the triangles that have a corner at no finite position, how many went): a
    cloth solver that blew up or a driver dividing by zero leaves NaN or infinite vertices, and
    Cycles renders the rest of such a mesh. The lost vertices, which no triangle then uses, take
    a finite vertex's place so that boxes and searches over the mesh stay finite; corner
    normals Blender blended from a lost neighbour take their triangle's own normal."""
    lost = ~np.isfinite(a.vertices).all(axis=1)
    if not lost.any():
        return a, 0
    keep = ~lost[a.triangles].any(axis=1)
    vertices = a.vertices.copy()
    vertices[lost] = vertices[~lost][0] if (~lost).any() else 0.0
    tris = a.triangles[keep]
    normals = None
    if a.triangle_normals is not None:
        normals = a.triangle_normals[keep].copy()
        odd = ~np.isfinite(normals).all(axis=2)
        if odd.any():
            c = vertices[tris]
            flat = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
            flat /= np.maximum(np.linalg.norm(flat, axis=1, keepdims=True), 1e-300)
            normals[odd] = np.broadcast_to(flat[:, None], normals.shape)[odd]
    pick = lambda x: None if x is None else x[keep]  # noqa: E731
    return replace(a, vertices=vertices, triangles=tris, triangle_polygon=a.triangle_polygon[keep],
                   triangle_material=pick(a.triangle_material), triangle_uv=pick(a.triangle_uv),
                   triangle_normals=normals), int((~keep).sum())

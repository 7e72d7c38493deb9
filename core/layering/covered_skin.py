"""Skin under cloth: the body's faces that garments cover all over. MakeHuman hides such faces with
a garment's delete group so skin never pokes through a tight garment; here they are found from
the garments as worn, for a non-destructive mask."""

from __future__ import annotations

import numpy as np

from ..geometry.normals import vertex_normals
from ..geometry.topology import path_distance, topology_of
from ..geometry.vectors import cross, norms, rows, unit
from ..rays.scene import FEW_RAYS, RayScene


def covered_faces(body_vertices, body_faces, garments, reach_out, reach_in, margin=0.0, normals=None) -> np.ndarray:
    """Per body face, whether cloth lies over every point of it: along the body's normal from each
    corner and from its centre, a garment triangle (either side facing) within ``reach_out``
    outward or ``reach_in`` inward (cloth a little inside the skin). ``garments``: (vertices,
    faces) pairs. A face at a hem, under a neckline or a sleeve's opening has a point with no
    cloth over it and is kept, and so is every face within ``margin`` of one over the body's
    surface: looking into a sleeve, the skin just inside its opening shows. ``normals``: the body's
    vertex normals when the caller has them (the resolve found them: a frame's 3 ms)."""
    body_vertices = np.asarray(body_vertices, dtype=np.float64)
    body_faces = np.asarray(body_faces, dtype=np.int64)
    out = np.zeros(len(body_faces), dtype=bool)
    garments = [(np.asarray(v, float), np.asarray(f, np.int64)) for v, f in garments if len(f)]
    if not len(body_faces) or not garments:
        return out
    offsets = np.cumsum([0] + [len(v) for v, _ in garments])
    # built every frame in playback and traced by about one ray per body vertex: a quick build pays
    cloth = RayScene(np.vstack([v for v, _ in garments]),
                     np.vstack([f + o for (_, f), o in zip(garments, offsets[:-1], strict=True)]), quality=FEW_RAYS)
    # from a little inside the skin outward: cloth inside it by up to reach_in counts too
    span = float(reach_out) + reach_in

    def clothed(points, normals):
        ok = norms(normals) > 0
        over = np.zeros(len(points), dtype=bool)
        over[ok] = cloth.occluded(points[ok] - normals[ok] * reach_in, normals[ok], max_dist=span)
        return over

    normals = vertex_normals(body_vertices, body_faces) if normals is None else normals
    # corner by corner: all/any over the rows of an (m, 3) gather is several times slower
    corner = [body_faces[:, k] for k in range(3)]
    under = clothed(body_vertices, normals)
    covered = under[corner[0]] & under[corner[1]] & under[corner[2]]
    # a face's centre is asked only when its corners are all under cloth (else it is kept anyway)
    ask = np.flatnonzero(covered)
    a, b, c = (rows(body_vertices, corner[k][ask]) for k in range(3))
    covered[ask] = clothed((a + b + c) / 3.0, unit(cross(b - a, c - a)))
    n_v = len(body_vertices)
    if margin > 0 and not covered.all():
        topo = topology_of(body_faces, n_v)
        e = topo.edges
        lengths = norms(rows(body_vertices, e[:, 0]) - rows(body_vertices, e[:, 1]))[topo.adjacency_edge]
        open_skin = np.zeros(n_v, dtype=bool)  # a mask, not np.unique: no sort of every corner
        open_skin[body_faces[~covered]] = True
        near = path_distance(topo.adjacency, lengths, np.flatnonzero(open_skin), margin) <= margin
        covered &= ~(near[corner[0]] | near[corner[1]] | near[corner[2]])
    return covered


__all__ = ["covered_faces"]

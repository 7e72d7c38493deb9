"""Garments cut from a figure's envelope, as plain numpy (no bpy).

A garment is the part of the body's envelope (a closed surface around the body, from
Blender's voxel remesh) that it covers, cut along hems, cuffs and necklines, pushed out by
its ease; skirts and dresses are tubes around the convex hull of the hips and legs. Each
garment is fitted to the body alone, as an artist would receive it: together they cross.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull, cKDTree

from ..core.geometry.normals import vertex_normals
from ..core.geometry.topology import vertex_adjacency
from ..core.layering.correspondence import nearest_on_surface
from ..core.layering.metrics import self_crossing_edges, unique_edges
from ..core.layering.segmentation import S13, segments_from_groups
from .figures import Figure, limb_position

_ARM_PARTS = {"upper_arm": ("right_upper_arm", "left_upper_arm"), "forearm": ("right_forearm", "left_forearm")}
_LEG_PARTS = {"thigh": ("right_thigh", "left_thigh"), "shin": ("right_shin", "left_shin")}


@dataclass(frozen=True)
class Cut:
    """Which part of the envelope a garment covers.

    torso: (from, to) heights as (landmark, offset_m) pairs, or None for no torso; a
    missing end is open (the neck, the crotch). Limbs: how far down each limb bone the
    garment reaches, 0 none to 1 the whole bone.
    """

    torso: tuple | None
    upper_arm: float = 0.0
    forearm: float = 0.0
    thigh: float = 0.0
    shin: float = 0.0


@dataclass(frozen=True)
class Tube:
    """A skirt or dress: a tube around the hips and legs from ``top`` down to ``bottom``
    (landmark, offset_m), flaring by ``flare`` (m) at the hem."""

    top: tuple
    bottom: tuple
    flare: float = 0.05


CUTS = {
    "shirt": Cut((("hip", 0.02), ("neck", -0.03)), upper_arm=1.0, forearm=0.9),
    "tshirt": Cut((("hip", 0.06), ("neck", -0.03)), upper_arm=0.55),
    "jacket": Cut((("hip", -0.01), ("neck", -0.01)), upper_arm=1.0, forearm=0.95),
    "pants": Cut((None, ("waist", 0.0)), thigh=1.0, shin=0.9),
    "shorts": Cut((None, ("waist", -0.02)), thigh=0.55),
    "jumpsuit": Cut((None, ("neck", -0.05)), upper_arm=1.0, forearm=0.7, thigh=1.0, shin=0.92),
    "dress": Tube(("armpit", -0.02), ("knee", 0.0), flare=0.06),
    "skirt": Tube(("waist", 0.0), ("knee", 0.06), flare=0.05),
}


def _height(fig: Figure, spec):
    return None if spec is None else fig.heights[spec[0]] + spec[1]


def body_parts(fig: Figure) -> np.ndarray:
    """S13 part id per body vertex, from the figure's skin weights."""
    return segments_from_groups(fig.weights, fig.joint_names, S13, vertices=fig.vertices)


def cover_mask(points: np.ndarray, part: np.ndarray, fig: Figure, cut: Cut) -> np.ndarray:
    """Bool per envelope point: does the garment cover it."""
    keep = np.zeros(len(points), dtype=bool)
    if cut.torso is not None:
        lo, hi = (_height(fig, s) for s in cut.torso)
        torso = part == S13.torso
        z = points[:, 2]
        keep |= torso & (z >= (lo if lo is not None else -np.inf)) & (z <= (hi if hi is not None else np.inf))
    for kind, names, reach in (("upper_arm", _ARM_PARTS["upper_arm"], cut.upper_arm),
                               ("forearm", _ARM_PARTS["forearm"], cut.forearm),
                               ("thigh", _LEG_PARTS["thigh"], cut.thigh),
                               ("shin", _LEG_PARTS["shin"], cut.shin)):
        if reach <= 0:
            continue
        for side, name in zip("RL", names, strict=True):
            on = part == S13.parts.index(name)
            if on.any():
                t = limb_position(points[on], fig, f"{kind}.{side}")
                # a whole bone (reach 1) includes its part's overlap past the joint
                keep[np.flatnonzero(on)[(t <= reach) | (reach >= 1.0)]] = True
    return keep


def keep_faces(faces: np.ndarray, keep_vertex: np.ndarray, min_share: float = 0.02):
    """Faces whose corners are all covered, without scraps under ``min_share`` of them;
    returns (vertex ids used, faces renumbered to them)."""
    f = faces[keep_vertex[faces].all(1)]
    if not len(f):
        return np.zeros(0, np.int64), np.zeros((0, 3), np.int64)
    used = np.unique(f)
    remap = np.full(len(keep_vertex), -1)
    remap[used] = np.arange(len(used))
    f = remap[f]
    _, label = connected_components(vertex_adjacency(f, len(used)), directed=False)
    face_label = label[f[:, 0]]
    sizes = np.bincount(face_label)
    f = f[sizes[face_label] >= min_share * len(f)]
    used2 = np.unique(f)
    remap2 = np.full(len(used), -1)
    remap2[used2] = np.arange(len(used2))
    return used[used2], remap2[f]


def offset(vertices, faces, ease: float) -> np.ndarray:
    """Push a surface out along its own normals by ``ease`` (metres)."""
    return vertices + vertex_normals(vertices, faces) * ease


def clear_of_body(points, body_vertices, body_faces, gap: float) -> np.ndarray:
    """Move points that are inside the body or closer than ``gap`` to it out to ``gap``
    along the body's normal at their nearest surface point."""
    corr = nearest_on_surface(points, body_vertices, body_faces)
    q = corr.points(body_vertices, body_faces)
    n = corr.normals(vertex_normals(body_vertices, body_faces), body_faces)
    signed = np.einsum("ij,ij->i", points - q, n)
    low = signed < gap
    out = points.copy()
    out[low] = q[low] + n[low] * gap
    return out


def folded_faces(vertices, faces) -> np.ndarray:
    """Bool per face: it faces against its corners' normals (a pleat folded flat over onto itself
    shows its back, dark, even where no edge passes through the cloth)."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    corner_normals = vertex_normals(vertices, faces)[faces].sum(axis=1)
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), corner_normals) < 0


def untangle(vertices, faces, rounds: int = 40, rings: int = 2, weight: float = 0.5):
    """``vertices`` with the places where the garment passes through itself or folds over onto
    itself smoothed out: the cloth solve drapes without self-collision (which would take several
    times as long), and such folds show as pinholes and slits of the cloth's dark back in a
    render. Each round moves the ends of every self-crossing edge and the corners of every
    folded face, with ``rings`` rings of neighbours round them, half way (``weight``) to their
    neighbours' mean; the rest of the garment stays as it is. Returns (vertices, self-crossing
    edges and folded faces left)."""
    v = np.array(vertices, dtype=np.float64, copy=True)
    adjacency = vertex_adjacency(faces, len(v)).astype(np.float64)
    degree = np.maximum(np.asarray(adjacency.sum(axis=1)).ravel(), 1.0)
    edges = unique_edges(faces)

    def bad_vertices():
        crossing, folded = self_crossing_edges(v, faces, edges=edges), folded_faces(v, faces)
        mark = np.zeros(len(v), dtype=bool)
        mark[edges[crossing].ravel()] = True
        mark[faces[folded].ravel()] = True
        return mark, int(crossing.sum() + folded.sum())

    for _ in range(rounds):
        mark, count = bad_vertices()
        if not count:
            return v, 0
        for _ in range(rings):
            mark |= (adjacency @ mark.astype(np.float64)) > 0
        mean = (adjacency @ v) / degree[:, None]
        v[mark] += weight * (mean[mark] - v[mark])
    return v, bad_vertices()[1]


def tube_garment(fig: Figure, part: np.ndarray, tube: Tube, ease: float, edge: float, n_around: int | None = None):
    """A skirt or dress: at each height, the convex hull of the body's torso and leg
    points (arms left out) sampled round its centre, plus ease, plus the flare."""
    top, bottom = _height(fig, tube.top), _height(fig, tube.bottom)
    if not top > bottom:
        raise ValueError(f"tube garment top {top:.3f} m must be above its bottom {bottom:.3f} m")
    legs_torso = np.isin(part, [S13.torso] + [S13.parts.index(n) for pair in _LEG_PARTS.values() for n in pair])
    pts = fig.vertices[legs_torso]
    rows = max(3, int(np.ceil((top - bottom) / edge)) + 1)
    z = np.linspace(top, bottom, rows)
    slab = max(edge, 0.02)
    centre = pts[(pts[:, 2] < top) & (pts[:, 2] > bottom), :2].mean(0)
    hulls = []
    for zi in z:
        sec = pts[np.abs(pts[:, 2] - zi) < slab, :2] - centre
        hulls.append(sec[ConvexHull(sec).vertices] if len(sec) >= 3 else None)
    if n_around is None:
        # the widest section's perimeter (with ease and flare) in edges of about ``edge``
        widest = max(np.linalg.norm(h - np.roll(h, -1, 0), axis=1).sum() for h in hulls if h is not None)
        n_around = int(np.ceil((widest + 2 * np.pi * (ease + tube.flare)) / edge))
    theta = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    radius = np.zeros((rows, n_around))
    for i, hull in enumerate(hulls):
        if hull is not None:
            radius[i] = _polygon_radius(hull, theta)
    # a tube hangs: never narrower than any section above it minus a little taper
    for i in range(1, rows):
        radius[i] = np.maximum(radius[i], radius[i - 1] - 0.25 * (z[i - 1] - z[i]))
    flare = tube.flare * ((top - z) / (top - bottom))[:, None]
    r = radius + ease + flare
    x = centre[0] + r * np.cos(theta)
    y = centre[1] + r * np.sin(theta)
    v = np.column_stack([x.ravel(), y.ravel(), np.repeat(z, n_around)])
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(n_around), indexing="ij")
    a = i * n_around + j
    b = i * n_around + (j + 1) % n_around
    c, d = a + n_around, b + n_around
    # wound so normals point outward (rows run top to bottom)
    f = np.concatenate([np.stack([a, d, b], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return v, f


def _polygon_radius(poly: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Distance from the origin to a convex polygon's boundary along each direction."""
    d = np.column_stack([np.cos(theta), np.sin(theta)])
    a, b = poly, np.roll(poly, -1, axis=0)
    e = b - a
    # ray s*d meets edge a + u e: solve [d, -e] [s, u] = a
    det = d[:, None, 0] * (-e[None, :, 1]) - d[:, None, 1] * (-e[None, :, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (a[None, :, 0] * (-e[None, :, 1]) - a[None, :, 1] * (-e[None, :, 0])) / det
        u = (d[:, None, 0] * a[None, :, 1] - d[:, None, 1] * a[None, :, 0]) / det
    ok = (u >= -1e-9) & (u <= 1 + 1e-9) & (s > 0)
    return np.where(ok, s, np.inf).min(1)


def transfer_parts(points: np.ndarray, fig: Figure, part: np.ndarray) -> np.ndarray:
    """Part of each point: that of its nearest body vertex."""
    return part[cKDTree(fig.vertices).query(points, workers=-1)[1]]

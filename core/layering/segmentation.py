"""Body-part segmentation and the tracing hierarchy (thesis 4.4 pre-processing 2, Fig. 4.7).

A scheme names the segment ids: the thesis' static S=5 (torso, right arm, left arm, right
leg, left leg, then the skirt) and a 13-part one for posed figures. Probe rays of a
segment only meet triangles of the segments it is linked to: itself, and for the skirt
the torso and both legs (a skirt or dress spans both legs, so its triangles cannot be
split between them).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.spatial import ConvexHull, QhullError, cKDTree

from ..geometry.keys import digest
from ..geometry.parallel import map_chunks
from ..geometry.topology import topology_of
from ..geometry.vectors import norms, rows
from .correspondence import closest_on_table, triangle_table


@dataclass(frozen=True)
class Scheme:
    name: str
    parts: tuple  # segment id -> part name; the last is always "skirt"
    # the parts a skirt spans besides the torso (it is traced against these and the torso)
    skirt_spans: tuple

    @property
    def skirt(self) -> int:
        return len(self.parts) - 1

    @property
    def torso(self) -> int:
        return self.parts.index("torso")

    def side(self, side: str) -> tuple:
        return tuple(i for i, p in enumerate(self.parts) if p.startswith(side + "_"))

    def leg_parts(self, side: str) -> tuple:
        return tuple(i for i in self.side(side) if i in self.skirt_spans)

    def links(self) -> np.ndarray:
        """Which segments' triangles a probe ray of each segment meets (symmetric bool matrix)."""
        n = len(self.parts)
        m = np.eye(n, dtype=bool)
        for p in (self.torso, *self.skirt_spans):
            m[self.skirt, p] = m[p, self.skirt] = True
        return m


S5 = Scheme("S5", ("torso", "right_arm", "left_arm", "right_leg", "left_leg", "skirt"), skirt_spans=(3, 4))
# The thesis names S=13 for dynamic poses without listing the parts; ours splits each limb
# at the elbow/knee and wrist/ankle, where posed figures bend (the head stays with the torso).
S13 = Scheme("S13", ("torso", "right_upper_arm", "left_upper_arm", "right_forearm", "left_forearm", "right_hand",
                     "left_hand", "right_thigh", "left_thigh", "right_shin", "left_shin", "right_foot", "left_foot",
                     "skirt"), skirt_spans=(7, 8, 9, 10))
SCHEMES = {"S5": S5, "S13": S13}


def get_scheme(scheme) -> Scheme:
    if isinstance(scheme, Scheme):
        return scheme
    if scheme in SCHEMES:
        return SCHEMES[scheme]
    raise ValueError(f"unknown segmentation scheme {scheme!r}; use one of {sorted(SCHEMES)}")


# Keyword -> limb, first match wins (so "forearm" is tested before "arm", "upleg" before "leg").
_LIMBS = (
    ("hand", ("hand", "finger", "thumb", "index", "middle", "ring", "pinky", "wrist", "palm")),
    ("forearm", ("forearm", "lowerarm", "lower_arm", "elbow")),
    ("upper_arm", ("upperarm", "upper_arm", "humerus", "arm")),
    ("foot", ("foot", "toe", "ankle", "heel", "ball")),
    ("thigh", ("thigh", "upleg", "upperleg", "upper_leg", "hip", "femur")),
    ("shin", ("shin", "calf", "knee", "lowerleg", "lower_leg", "leg")),
)
_S5_LIMB = {"hand": "arm", "forearm": "arm", "upper_arm": "arm", "foot": "leg", "thigh": "leg", "shin": "leg"}


def _side(name: str) -> str | None:
    low = name.lower()
    if "left" in low or re.search(r"(^|[^a-z])l([^a-z]|$)", low):
        return "left"
    if "right" in low or re.search(r"(^|[^a-z])r([^a-z]|$)", low):
        return "right"
    return None


def smpl_naming(group_names) -> bool:
    """SMPL-family rigs call the clavicle "Collar" or "Thorax" and the upper-arm joint
    "Shoulder"; Rigify and Mixamo call the clavicle "shoulder"."""
    return any(k in g.lower() for g in group_names for k in ("collar", "thorax"))


def part_of_group(name: str, scheme="S5", smpl: bool = False) -> int:
    """Segment id for a vertex-group or bone name (Rigify ``thigh.L``, Mixamo ``LeftUpLeg``,
    SMPL ``L_Knee``, or the scheme's own part names). Names without a side, and clavicles,
    spine, neck and head, belong to the torso. With ``smpl``, "Shoulder" is the upper arm."""
    scheme = get_scheme(scheme)
    low = name.lower()
    if low in scheme.parts:
        return scheme.parts.index(low)
    side = _side(name)
    if smpl and side is not None and "shoulder" in low:
        low = "upper_arm"
    if side is None or any(k in low for k in ("shoulder", "clavicle", "collar", "scapula", "thorax")):
        return scheme.torso
    for limb, keys in _LIMBS:
        if any(k in low for k in keys):
            part = f"{side}_{limb if scheme is not S5 else _S5_LIMB[limb]}"
            if part in scheme.parts:
                return scheme.parts.index(part)
            # a scheme without this limb split: the coarsest part of that side and limb
            coarse = f"{side}_{_S5_LIMB[limb]}"
            return scheme.parts.index(coarse) if coarse in scheme.parts else scheme.torso
    return scheme.torso


def segments_from_groups(weights, group_names, scheme="S5", vertices=None) -> np.ndarray:
    """One segment id per vertex from skin weights or vertex groups.

    weights: (n_vertices, n_groups) weights, 0 where a vertex is not in a group.
    Each vertex takes the part with the largest summed weight; a vertex in no group takes
    the part of the nearest vertex that has one (with ``vertices``), else the torso.
    """
    scheme = get_scheme(scheme)
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 2 or w.shape[1] != len(group_names):
        raise ValueError(f"weights must be (n_vertices, {len(group_names)}), one column per group; got {w.shape}")
    if not np.isfinite(w).all():
        raise ValueError("weights contain NaN or infinite values")
    smpl = smpl_naming(group_names)
    part = np.array([part_of_group(g, scheme, smpl) for g in group_names], dtype=np.int64)
    per_part = np.zeros((len(w), len(scheme.parts)))
    for p in np.unique(part):
        per_part[:, p] = w[:, part == p].sum(1)
    seg = np.argmax(per_part, axis=1)
    none = per_part.max(1) <= 0
    seg[none] = scheme.torso
    if vertices is not None and none.any() and (~none).any():
        v = np.asarray(vertices, dtype=np.float64)
        _, j = cKDTree(v[~none]).query(v[none])
        seg[none] = seg[~none][j]
    return seg


def boundary_loops(faces: np.ndarray, n_vertices: int) -> list:
    """Vertex ids of each connected set of boundary edges (a hem, cuff or neckline)."""
    return topology_of(faces, n_vertices).hem_loops


def is_skirt(faces, vertex_segment, scheme="S5", min_share=0.1, vertices=None, body=None) -> bool:
    """A garment is a skirt (or dress) when one of its hems goes round both legs: most of
    that hem's points lie on the legs, at least ``min_share`` on each, and (given the
    garment's ``vertices`` and the ``body`` as (its vertices, its part per vertex)) the legs are
    apart at the hem's height, so the hem is not just a shirt's hem sagging onto the tops of the
    thighs. Trouser hems go round one leg each; a waistband lies mostly on the torso. Heights
    are along z."""
    scheme = get_scheme(scheme)
    seg = np.asarray(vertex_segment, dtype=np.int64)
    loops = boundary_loops(np.asarray(faces), len(seg))
    if not loops or not len(seg):
        return False
    # every loop's shares at once: a garment of separate pieces has dozens of loops, asked every frame
    left, right = list(scheme.leg_parts("left")), list(scheme.leg_parts("right"))
    n = max(int(seg.max(initial=0)), *left, *right, 0) + 1
    on_left, on_right = np.zeros(n + 1), np.zeros(n + 1)
    on_left[left], on_right[right] = 1.0, 1.0
    which = np.repeat(np.arange(len(loops)), [len(loop) for loop in loops])
    at = seg[np.concatenate(loops)]
    at = np.where(at >= 0, at, n)  # no part: on neither leg
    count = np.bincount(which, minlength=len(loops))
    left_share = np.bincount(which, on_left[at], minlength=len(loops)) / count
    right_share = np.bincount(which, on_right[at], minlength=len(loops)) / count
    both = (left_share >= min_share) & (right_share >= min_share) & (left_share + right_share >= 0.5)
    for k in np.flatnonzero(both):
        if vertices is None or body is None:
            return True
        z = float(np.asarray(vertices)[loops[k], 2].mean())
        if legs_apart(z, *body, scheme):
            return True
    return False


def legs_apart(z, body_vertices, body_segments, scheme="S5", slab=0.015, cell=0.01) -> bool:
    """Whether the body's left and right legs are separate shapes at height ``z``: their
    points in a thin slab fall in different blobs of a 2-D occupancy grid. Works for figures
    made of overlapping parts, where the surface's own connectivity says nothing. ``slab``
    and ``cell`` (metres) grow to the body's vertex spacing there, so outlines stay closed."""
    from scipy import ndimage

    scheme = get_scheme(scheme)
    body_vertices = np.asarray(body_vertices, dtype=np.float64)
    band = np.abs(body_vertices[:, 2] - z) < max(slab, 0.1)
    if band.sum() >= 2:
        nn, _ = cKDTree(body_vertices[band]).query(body_vertices[band], k=2)
        spacing = 2.0 * float(np.median(nn[:, 1]))
        slab, cell = max(slab, spacing), max(cell, spacing)
    near = np.abs(body_vertices[:, 2] - z) < slab
    pts, seg = body_vertices[near, :2], np.asarray(body_segments)[near]
    left, right = np.isin(seg, scheme.leg_parts("left")), np.isin(seg, scheme.leg_parts("right"))
    if not left.any() or not right.any():
        return False
    ij = np.floor((pts - pts.min(0)) / cell).astype(np.int64) + 1
    grid = np.zeros(ij.max(0) + 2, dtype=bool)
    grid[ij[:, 0], ij[:, 1]] = True
    # 8-connected: a leg's outline is a ring of cells its vertices fall in, about one cell apart;
    # filled, so parts modelled inside others (thigh tops inside the pelvis) join them
    labels, _ = ndimage.label(ndimage.binary_fill_holes(grid), structure=np.ones((3, 3), dtype=bool))
    blob = labels[ij[:, 0], ij[:, 1]]
    return not set(blob[left]) & set(blob[right])


def skirt_segments(vertex_segment, scheme="S5") -> np.ndarray:
    """A skirt's segment ids: its points on the legs form the skirt segment, the rest stay."""
    scheme = get_scheme(scheme)
    seg = np.asarray(vertex_segment, dtype=np.int64).copy()
    seg[np.isin(seg, scheme.skirt_spans)] = scheme.skirt
    return seg


class _Hull(NamedTuple):
    """A convex hull as what _nearest_on_convex asks of it, worked out once."""

    tri: np.ndarray  # (m, 3, 3) facets, wound outward
    normal: np.ndarray  # (m, 3) unit outward normals
    offset: np.ndarray  # (m,) plane offsets
    table: np.ndarray  # correspondence.triangle_table of the facets
    normal32: np.ndarray
    offset32: np.ndarray
    centre32: np.ndarray  # facet centres
    centre_sq: np.ndarray  # their squared lengths
    reach32: np.ndarray  # facet bounding-sphere radii
    slack: float
    size: float  # the hull's diagonal


def _prepared_hull(hv, hf) -> _Hull:
    tri = hv[hf]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    offset = np.einsum("ij,ij->i", normal, tri[:, 0])
    centre = tri.mean(1)
    reach32 = np.linalg.norm(tri - centre[:, None], axis=2).max(1).astype(np.float32)
    centre_sq = np.einsum("ij,ij->i", centre, centre).astype(np.float32)
    return _Hull(tri, normal, offset, triangle_table(tri[:, 0], tri[:, 1], tri[:, 2]), normal.astype(np.float32),
                 offset.astype(np.float32), centre.astype(np.float32), centre_sq, reach32,
                 1e-5 * float(np.ptp(hv, axis=0).max()), float(np.linalg.norm(np.ptp(hv, axis=0))))


def _nearest_on_convex(points, hull: _Hull, chunk=1024):
    """Per point, the unit normal of the hull facet holding its nearest hull point and the
    vector from that point to it (outward hull, wound outward).

    Exact. The hull lies behind every facet's plane, so an outside point is at least its
    height above any plane away from the hull: where its nearest point on the facet of the
    highest plane is that far, nothing is nearer (most points, the ones over a facet's
    interior). The others (over an edge or corner) try every facet whose plane they are
    above by at most that distance and whose bounding sphere is that close. An inside
    point's nearest facet is the one whose plane is closest.
    """
    tri, normal, offset = hull.tri, hull.normal, hull.offset
    normal32, offset32, centre32, centre_sq, reach32 = hull.normal32, hull.offset32, hull.centre32, hull.centre_sq, \
        hull.reach32
    slack = hull.slack
    best = np.zeros(len(points), dtype=np.int64)
    away = np.zeros_like(points)

    def nearest_on(p, facets):
        return np.einsum("ij,ijk->ik", closest_on_table(p, rows(hull.table, facets))[1], rows(tri, facets))

    def run(sl):
        p = points[sl]
        # float32 only picks the plane and the candidates; distances are float64
        height = p.astype(np.float32) @ normal32.T
        height -= offset32
        pick = np.argmax(height, axis=1)
        plane = np.einsum("ij,ij->i", p, normal[pick]) - offset[pick]
        vec = -plane[:, None] * normal[pick]
        out = np.flatnonzero(height[np.arange(len(pick)), pick] > 0)
        if len(out):
            po = p[out]
            vec[out] = po - nearest_on(po, pick[out])
            dist = norms(vec[out])
            more = dist > plane[out] + 1e-3 * slack
            out, po, ub = out[more], po[more], (dist[more] + slack).astype(np.float32)[:, None]
        if len(out):
            hb = height[out]
            near = po.astype(np.float32) @ centre32.T
            near *= -2
            near += np.einsum("ij,ij->i", po, po).astype(np.float32)[:, None] + centre_sq
            near -= np.square(ub + reach32)
            row, col = np.nonzero((hb > 0) & (hb <= ub) & (near <= 0))
            q = nearest_on(po[row], col)
            dist = norms(po[row] - q)
            # the pair with the smallest distance per point, the first of a tie (np.nonzero gives
            # the pairs point by point): a minimum per run of pairs, no sort
            first = row
            if len(row):
                start = np.flatnonzero(np.r_[True, row[1:] != row[:-1]])
                low = np.minimum.reduceat(dist, start)
                at = np.flatnonzero(dist == np.repeat(low, np.diff(np.r_[start, len(row)])))
                first = at[np.r_[True, row[at][1:] != row[at][:-1]]]
            pick[out[row[first]]] = col[first]
            vec[out[row[first]]] = po[row[first]] - q[first]
        best[sl] = pick
        away[sl] = vec

    map_chunks(run, len(points), chunk)
    return normal[best], away


def _hull_mesh(points, hull):
    """A scipy ConvexHull of ``points`` as a triangle mesh of its own vertices, wound outward."""
    used = np.unique(hull.simplices)
    remap = np.full(len(points), -1)
    remap[used] = np.arange(len(used))
    hv, hf = points[used], remap[hull.simplices]
    # qhull's simplices are not consistently wound: orient each outward from the centroid
    tri = hv[hf]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = np.einsum("ij,ij->i", n, tri.mean(1) - hv.mean(0)) < 0
    hf[flip] = hf[flip][:, ::-1]
    return hv, hf


def hull_normals(body_vertices, body_segments, parts, points) -> np.ndarray:
    """Outward normals for skirt points: from the convex hull of the body parts it spans.

    Body normals between the legs point sideways at the other leg; the hull bridges the
    gap, so its normals point out of the skirt as a whole (the thesis' "manual intervention"
    for skirts, done automatically).
    """
    hull = _skirt_hull(np.asarray(body_vertices, dtype=np.float64)[np.isin(body_segments, parts)], parts)
    # Outside the hull the direction from its nearest point is the outward normal, and it
    # turns smoothly round the hull's edges; a facet's own normal would jump between facets
    # (a flared hem beside the legs' hull edge would point backwards). On or inside the hull
    # the facet normal: the hull's few large facets would blend a bottom cap's -z into every
    # vertex normal of the flat bridge between the legs.
    pts = np.asarray(points, dtype=np.float64)
    facet, away = _nearest_on_convex(pts, hull)
    outside = np.einsum("ij,ij->i", away, facet) > 1e-6 * hull.size
    n = facet.copy()
    # a short bridge of the facet normal keeps points just off the hull from taking a
    # direction out of round-off
    n[outside] = away[outside] + facet[outside] * (1e-3 * hull.size)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


_hulls: dict = {}  # the last few skirt hulls, by the content of the body points they wrap


def _skirt_hull(v, parts) -> _Hull:
    """The convex hull of body points ``v`` (of ``parts``), reduced and prepared; kept, as every
    skirt on a body and every frame of a still body asks for the same one."""
    key = digest(v)
    if key in _hulls:
        return _hulls[key]
    try:
        hull = ConvexHull(v)
        # A smooth body's hull has a facet per few vertices on every curve; the normals need
        # its shape, not its detail: one hull vertex per cell of 2% of the size, the
        # outermost, keeps the hull within that of the true one with a fraction of the facets.
        hv = v[hull.vertices]
        cell = 0.02 * float(np.linalg.norm(np.ptp(hv, axis=0)))
        if cell > 0 and len(hv) > 64:
            cells = np.unique(np.floor((hv - hv.min(0)) / cell).astype(np.int64), axis=0, return_inverse=True)[1]
            order = np.lexsort((-np.linalg.norm(hv - hv.mean(0), axis=1), cells.ravel()))
            keep = order[np.r_[True, cells.ravel()[order][1:] != cells.ravel()[order][:-1]]]
            if len(keep) >= 4:
                v = hv[keep]
                hull = ConvexHull(v)
    except (QhullError, ValueError) as err:
        raise ValueError(f"the body parts {list(parts)} have no 3-D extent for a skirt hull: {err}") from None
    if len(_hulls) >= 4:
        _hulls.pop(next(iter(_hulls)), None)
    _hulls[key] = _prepared_hull(*_hull_mesh(v, hull))
    return _hulls[key]


__all__ = ["S5", "S13", "SCHEMES", "Scheme", "boundary_loops", "get_scheme", "hull_normals", "is_skirt",
           "legs_apart", "part_of_group", "segments_from_groups", "skirt_segments", "smpl_naming"]

"""How wrong a set of garment layers looks: one metrics module for tests, benchmarks and the UI."""

from __future__ import annotations

import numpy as np

from ..geometry.topology import edges_with_counts
from ..geometry.vectors import box, norms, rows
from ..rays.scene import RayScene, step_past_hit


def unique_edges(faces) -> np.ndarray:
    return edges_with_counts(faces)[0]


def crossing_edges(vertices_a, faces_a, scene_b: RayScene, edges=None) -> np.ndarray:
    """Bool mask over ``edges`` (default ``unique_edges(faces_a)``): True where the edge
    passes through a triangle of B.

    Exact segment-triangle tests: a ray from each edge's start, limited to the edge's length.
    """
    v = np.asarray(vertices_a, dtype=np.float64)
    e = unique_edges(faces_a) if edges is None else edges
    if not len(e):
        return np.zeros(0, dtype=bool)
    start = rows(v, e[:, 0])
    vec = rows(v, e[:, 1]) - start
    length = norms(vec)
    ok = length > 0
    if ok.all():  # as a rule: masked copies of every edge's rows cost more than the test of a few
        return scene_b.occluded(start, vec, max_dist=length)
    out = np.zeros(len(e), dtype=bool)
    out[ok] = scene_b.occluded(start[ok], vec[ok], max_dist=length[ok])
    return out


def self_crossing_edges(vertices, faces, scene: RayScene | None = None, edges=None) -> np.ndarray:
    """Bool mask over ``edges`` (default ``unique_edges(faces)``): True where the edge passes
    through a triangle of its own mesh that shares no vertex with it (cloth folded through
    itself). Each edge is traced on past the triangles beside it, a few at a time."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    e = unique_edges(f) if edges is None else edges
    out = np.zeros(len(e), dtype=bool)
    if not len(e) or not len(f):
        return out
    scene = RayScene(v, f) if scene is None else scene
    start = rows(v, e[:, 0])
    vec = rows(v, e[:, 1]) - start
    length = norms(vec)
    live = np.flatnonzero(length > 0)
    # along the edge in units of its length, from just past its start (where its neighbours meet
    # it) to just short of its end; each search on starts past the last hit by float32's round-off
    lo, hi = box(v)
    step = np.full(len(e), np.inf)
    step[live] = step_past_hit(length[live], lo, hi) / length[live]
    t_min = step.copy()
    for _ in range(32):  # triangles beside an edge along it: its two own, and a fan's at each end
        if not len(live):
            break
        live = live[t_min[live] < 1.0 - step[live]]
        hits = scene.intersect(start[live], vec[live], max_dist=1.0 - step[live], min_dist=t_min[live], scaled=True)
        live, t, face = live[hits.hit], hits.t[hits.hit], hits.face[hits.hit]
        corners = f[face]
        beside = ((corners == e[live, :1]) | (corners == e[live, 1:])).any(axis=1)
        # a triangle in the edge's own plane (a flat stretch of cloth) is touched, not crossed:
        # Embree reports such rays' grazing contacts at t = 0
        normal = hits.normal[hits.hit]
        along = np.abs(np.einsum("ij,ij->i", normal, vec[live])) <= 1e-9 * norms(vec[live])
        beside |= along
        out[live[~beside]] = True
        t_min[live[beside]] = t[beside] + step[live[beside]]
        live = live[beside]
    return out


def crossings(vertices_a, faces_a, vertices_b, faces_b) -> int:
    """Edges of either mesh that pass through a triangle of the other (counted once per edge)."""
    scene_a = RayScene(vertices_a, faces_a)
    scene_b = RayScene(vertices_b, faces_b)
    return int(crossing_edges(vertices_a, faces_a, scene_b).sum() + crossing_edges(vertices_b, faces_b, scene_a).sum())


def layer_crossings(layers) -> np.ndarray:
    """Pairwise crossings between a list of (vertices, faces) layers: symmetric (k, k) int matrix."""
    scenes = [RayScene(v, f) for v, f in layers]
    k = len(layers)
    out = np.zeros((k, k), dtype=np.int64)
    for i in range(k):
        for j in range(i + 1, k):
            n = crossing_edges(*layers[i], scenes[j]).sum() + crossing_edges(*layers[j], scenes[i]).sum()
            out[i, j] = out[j, i] = n
    return out


def camera_ring(center, radius, views=8, elevations_deg=(0.0, 35.0), resolution=128, up_axis=2):
    """Pinhole cameras on a ring around ``center``, each framing a sphere of ``radius``.

    Returns a list of (origins, directions) ray arrays, one per view (resolution^2 rays).
    """
    center = np.asarray(center, dtype=np.float64)
    dist = 3.0 * radius
    half = np.arcsin(radius / dist) * 1.05  # the sphere's angular radius (its tangent rays), 5% of margin
    s = np.tan(half) * np.linspace(-1, 1, resolution)
    sx, sy = np.meshgrid(s, -s)
    out = []
    axes = [a for a in range(3) if a != up_axis]
    for el in np.radians(elevations_deg):
        for az in np.linspace(0, 2 * np.pi, views, endpoint=False):
            eye_dir = np.zeros(3)
            eye_dir[axes[0]] = np.cos(az) * np.cos(el)
            eye_dir[axes[1]] = np.sin(az) * np.cos(el)
            eye_dir[up_axis] = np.sin(el)
            forward = -eye_dir
            up = np.zeros(3)
            up[up_axis] = 1.0
            right = np.cross(forward, up)
            right /= np.linalg.norm(right)
            cam_up = np.cross(right, forward)
            d = forward + sx.reshape(-1, 1) * right + sy.reshape(-1, 1) * cam_up
            o = np.broadcast_to(center + eye_dir * dist, d.shape).copy()
            out.append((o, d))
    return out


def _stack_layers(layers):
    verts, faces, layer_of_face, offset = [], [], [], 0
    for k, (v, f) in enumerate(layers):
        v = np.asarray(v, dtype=np.float64)
        f = np.asarray(f, dtype=np.int64).reshape(-1, 3)
        verts.append(v)
        faces.append(f + offset)
        layer_of_face.append(np.full(len(f), k))
        offset += len(v)
    return np.concatenate(verts), np.concatenate(faces), np.concatenate(layer_of_face)


def layer_bounds(layers):
    pts = np.concatenate([np.asarray(v, dtype=np.float64).reshape(-1, 3) for v, _ in layers])
    lo, hi = pts.min(0), pts.max(0)
    return 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))


def poke_through(layers, normals=None, depth=None, cameras=None):
    """Share of covered pixels where a lower layer shows through a higher one.

    A pixel pokes through when its first hit is on layer k and, within ``depth`` behind
    that point along the ray, the ray meets a front face (normal toward the camera) of a
    layer j > k. ``layers`` are (vertices, faces) inner to outer; ``normals`` optional
    outward vertex normals per layer (default: each triangle's winding). ``depth``
    defaults to 2% of the scene's bounding radius. Returns (share, poked, covered).
    """
    center, radius = layer_bounds(layers)
    depth = 0.02 * radius if depth is None else float(depth)
    cameras = cameras if cameras is not None else camera_ring(center, radius)
    v_all, f_all, lay = _stack_layers(layers)
    scene = RayScene(v_all, f_all)
    top = len(layers) - 1
    stacked_above = [_stack_layers(layers[k + 1:]) for k in range(top)]
    above = [RayScene(v, f) for v, f, _ in stacked_above]
    above_faces = [f for _, f, _ in stacked_above]
    n_all = None if normals is None else np.concatenate([np.asarray(n, dtype=np.float64) for n in normals])
    offsets = np.cumsum([0] + [len(v) for v, _ in layers])
    poked = covered = 0
    for o, d in cameras:
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        first = scene.intersect(o, d)
        covered += int(first.hit.sum())
        k_hit = np.where(first.hit, lay[np.maximum(first.face, 0)], -1)
        p = first.points(o, d)
        for k in range(top):
            idx = np.flatnonzero(k_hit == k)
            if not len(idx):
                continue
            behind = above[k].intersect(p[idx], d[idx], max_dist=depth, min_dist=1e-9 * radius)
            h = behind.hit
            if not h.any():
                continue
            if n_all is None:
                facing = behind.normal[h]
            else:
                # interpolate the given vertex normals of the hit triangle
                tri = above_faces[k][behind.face[h]] + offsets[k + 1]
                u, w = behind.bary[h, 0], behind.bary[h, 1]
                facing = (1 - u - w)[:, None] * n_all[tri[:, 0]] + u[:, None] * n_all[tri[:, 1]] + \
                    w[:, None] * n_all[tri[:, 2]]
            front = np.einsum("ij,ij->i", facing, d[idx][h]) < 0
            poked += int(front.sum())
    return (poked / covered if covered else 0.0), poked, covered


def first_layer(layers, cameras):
    """Per camera, the layer index each pixel shows first (-1 for background)."""
    v, f, lay = _stack_layers(layers)
    scene = RayScene(v, f)
    out = []
    for o, d in cameras:
        if not len(f):
            out.append(np.full(len(o), -1))
            continue
        hits = scene.intersect(o, d)
        out.append(np.where(hits.hit, lay[np.maximum(hits.face, 0)], -1))
    return out


def new_holes(layers_before, layers_after, cameras=None):
    """Share of pixels covered before that now show a lower layer or the background.

    Removing hidden faces may only reveal higher layers; anything else is a hole. Compare
    the corrected layers with and without face removal to isolate what removal opened.
    """
    if cameras is None:
        cameras = camera_ring(*layer_bounds(layers_before))
    before = first_layer(layers_before, cameras)
    after = first_layer(layers_after, cameras)
    dropped = sum(int(((a < b) & (b >= 0)).sum()) for b, a in zip(before, after, strict=True))
    total = sum(int((b >= 0).sum()) for b in before)
    return dropped / total if total else 0.0


def distortion(vertices_before, vertices_after, faces):
    """Displacement (mean, max, max relative to the garment's size) and edge stretch (new/old):
    the largest and the 99th percentile (one badly stretched edge in a seam against the whole)."""
    v0 = np.asarray(vertices_before, dtype=np.float64)
    v1 = np.asarray(vertices_after, dtype=np.float64)
    if not len(v0):
        return {"mean_move": 0.0, "max_move": 0.0, "max_move_rel": 0.0, "max_stretch": 1.0, "p99_stretch": 1.0}
    move = np.linalg.norm(v1 - v0, axis=1)
    size = float(np.linalg.norm(np.ptp(v0, axis=0))) or 1.0
    e = unique_edges(faces)
    stretch = p99 = 1.0
    if len(e):
        l0 = np.linalg.norm(v0[e[:, 0]] - v0[e[:, 1]], axis=1)
        l1 = np.linalg.norm(v1[e[:, 0]] - v1[e[:, 1]], axis=1)
        ok = l0 > 0
        ratio = l1[ok] / l0[ok]
        stretch = float(ratio.max(initial=1.0))
        p99 = float(np.percentile(ratio, 99)) if len(ratio) else 1.0
    return {"mean_move": float(move.mean()), "max_move": float(move.max()), "max_move_rel": float(move.max() / size),
            "max_stretch": stretch, "p99_stretch": p99}


def removed_area_share(vertices, faces, removed) -> float:
    f = np.asarray(faces, dtype=np.int64)
    if not len(f):
        return 0.0
    tri = np.asarray(vertices, dtype=np.float64)[f]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    total = area.sum()
    return float(area[np.asarray(removed)].sum() / total) if total > 0 else 0.0

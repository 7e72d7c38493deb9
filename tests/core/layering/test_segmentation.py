"""Segmentation schemes, part names, skirt detection and the skirt's tracing hierarchy (Fig. 4.7)."""

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull

from core.layering import resolve_layers
from core.layering.correspondence import closest_point_on_triangles
from core.layering.segmentation import (
    S5,
    S13,
    _hull_mesh,
    _nearest_on_convex,
    _prepared_hull,
    boundary_loops,
    hull_normals,
    is_skirt,
    legs_apart,
    part_of_group,
    segments_from_groups,
    skirt_segments,
)
from sample_scenes.shapes import Folds, tube
from tests.core.brute import brute_crossings
from tests.core.layered_cases import lower_body, mesh


@pytest.mark.parametrize("name, s5, s13", [
    ("upper_arm.L", "left_arm", "left_upper_arm"),
    ("DEF-forearm.R", "right_arm", "right_forearm"),
    ("hand.L", "left_arm", "left_hand"),
    ("f_index.01.R", "right_arm", "right_hand"),
    ("thigh.R", "right_leg", "right_thigh"),
    ("shin.L", "left_leg", "left_shin"),
    ("foot.L", "left_leg", "left_foot"),
    ("mixamorig:LeftUpLeg", "left_leg", "left_thigh"),
    ("mixamorig:RightLeg", "right_leg", "right_shin"),
    ("mixamorig:LeftForeArm", "left_arm", "left_forearm"),
    ("mixamorig:RightShoulder", "torso", "torso"),
    ("mixamorig:Hips", "torso", "torso"),
    ("L_Knee", "left_leg", "left_shin"),
    ("R_Elbow", "right_arm", "right_forearm"),
    ("spine.003", "torso", "torso"),
    ("head", "torso", "torso"),
    ("left_leg", "left_leg", "left_shin"),
])
def test_group_names_map_to_parts(name, s5, s13):
    assert S5.parts[part_of_group(name, "S5")] == s5
    assert S13.parts[part_of_group(name, "S13")] == s13


def test_smpl_shoulders_are_upper_arms():
    assert S13.parts[part_of_group("L_Shoulder", "S13", smpl=True)] == "left_upper_arm"
    assert S13.parts[part_of_group("L_Thorax", "S13", smpl=True)] == "torso"
    seg = segments_from_groups(np.eye(2), ["R_Shoulder", "R_Collar"], "S5")
    assert [S5.parts[s] for s in seg] == ["right_arm", "torso"]


def test_segments_from_weights_match_a_per_vertex_loop():
    rng = np.random.default_rng(3)
    names = ["thigh.L", "shin.L", "upper_arm.R", "spine", "hand.R"]
    w = rng.random((200, len(names))) * (rng.random((200, len(names))) < 0.4)
    seg = segments_from_groups(w, names, "S5")
    part = [part_of_group(n, "S5") for n in names]
    for i in range(len(w)):
        total = {}
        for g, p in enumerate(part):
            total[p] = total.get(p, 0.0) + w[i, g]
        want = max(total, key=lambda p: (total[p], -p)) if max(total.values()) > 0 else S5.torso
        assert seg[i] == want


def test_unweighted_vertices_take_the_nearest_weighted_part():
    v = np.array([[0, 0, 0], [1, 0, 0], [0.1, 0, 0], [0.9, 0, 0]], float)
    w = np.array([[1, 0], [0, 1], [0, 0], [0, 0]], float)
    seg = segments_from_groups(w, ["thigh.L", "thigh.R"], "S5", vertices=v)
    assert seg.tolist() == [4, 3, 4, 3]
    with pytest.raises(ValueError, match="one column per group"):
        segments_from_groups(w, ["thigh.L"], "S5")
    with pytest.raises(ValueError, match="unknown segmentation scheme"):
        segments_from_groups(w, ["a", "b"], "S7")


def test_boundary_loops_of_an_open_tube():
    v, f = tube(1.0, 0.0, 1.0, grid=(12, 5))
    loops = boundary_loops(f, len(v))
    assert sorted(len(x) for x in loops) == [12, 12]
    assert sorted(float(v[x, 2].mean()) for x in loops) == [0.0, 1.0]
    v, f = tube(1.0, 0.0, 1.0, grid=(12, 5), capped=True)
    assert boundary_loops(f, len(v)) == []


def _skirt(radius=0.18, z0=0.2, z1=0.62, n=64):
    return mesh(*tube(radius, z0, z1, grid=(n, 24)))


def _segments_by_nearest(body, ids, g):
    from scipy.spatial import cKDTree
    return ids[cKDTree(body.vertices).query(g.vertices)[1]]


def test_a_hem_counts_as_round_both_legs_by_its_own_points_shares_among_many_loops():
    """Many hems at once (the rings of separate pieces), against each hem's shares counted alone:
    a hem whose points lie at least 10% on each leg and half on the legs makes a skirt, and only
    such a hem; points with no part lie on neither leg."""
    left, right = S5.leg_parts("left")[0], S5.leg_parts("right")[0]
    rng = np.random.default_rng(3)
    rings, n = [], 0
    for size in rng.integers(3, 12, 40):  # forty separate fans, each rim one loop
        rings.append(np.array([[n + i, n + (i + 1) % size, n + size] for i in range(size)]))
        n += size + 1
    faces = np.vstack(rings)
    loops = [np.unique(r[:, :2]) for r in rings]
    for trial in range(60):
        seg = rng.choice([0, 1, left, right, -1], n, p=[0.5, 0.1, 0.15, 0.15, 0.1]) if trial % 2 else \
            rng.choice([0, left, right], n, p=[0.8, 0.1, 0.1])
        want = False
        for loop in loops:
            on_l, on_r = np.mean(seg[loop] == left), np.mean(seg[loop] == right)
            want |= bool(on_l >= 0.1 and on_r >= 0.1 and on_l + on_r >= 0.5)
        assert is_skirt(faces, seg, "S5") == want


def test_a_skirt_hem_goes_round_both_legs_and_trouser_hems_do_not():
    body, ids = lower_body()
    skirt = _skirt()
    assert is_skirt(skirt.faces, _segments_by_nearest(body, ids, skirt), "S5")
    for x in (-0.09, 0.09):  # one trouser leg each
        leg = mesh(*tube(0.085, 0.05, 0.49, grid=(32, 12)))
        leg.apply_translation([x, 0, 0])
        assert not is_skirt(leg.faces, _segments_by_nearest(body, ids, leg), "S5")
    # a waistband round the hips touches both legs' tops but lies mostly on the torso
    seg = np.array([0] * 6 + [3, 4])
    ring = np.array([[i, (i + 1) % 8, 8] for i in range(8)])  # a fan: its rim is one loop of 8
    assert not is_skirt(ring, np.r_[seg, 0], "S5")
    assert is_skirt(ring, np.r_[np.array([0, 0, 3, 3, 3, 4, 4, 4]), 0], "S5")
    shirt = mesh(*tube(0.17, 0.6, 0.95, grid=(48, 12)))
    assert not is_skirt(shirt.faces, _segments_by_nearest(body, ids, shirt), "S5")
    seg = skirt_segments(np.array([0, 3, 4, 1]), "S5")
    assert seg.tolist() == [0, 5, 5, 1]
    links = S5.links()
    assert links[5, [0, 3, 4, 5]].all() and not links[5, [1, 2]].any() and not links[3, 4]
    assert S13.links()[S13.skirt, [0, 7, 8, 9, 10]].all()


def test_skirt_normals_come_from_the_hull_of_both_legs():
    body, ids = lower_body()
    # In front of the gap between the legs the hull is the plane through the torso's rim
    # (y 0.15, z 0.5) and the legs' front (y 0.07): it faces +y, tilted down by 0.08/0.5,
    # where the nearer leg's own normal would lean sideways. At the side it is vertical.
    pts = np.array([[0.0, 0.12, 0.3], [0.0, -0.12, 0.3], [0.2, 0.0, 0.3]])
    n = hull_normals(body.vertices, ids, (0, 3, 4), pts)
    front = np.array([0.0, 1.0, -0.08 / 0.5]) / np.hypot(1.0, 0.08 / 0.5)
    np.testing.assert_allclose(n[0], front, atol=0.03)
    np.testing.assert_allclose(n[1], front * [1, -1, 1], atol=0.03)
    np.testing.assert_allclose(n[2], [1, 0, 0], atol=np.sin(np.pi / 48) + 1e-3)  # a facet of the 48-gon leg
    with pytest.raises(ValueError, match="no 3-D extent"):
        hull_normals(np.zeros((4, 3)), np.zeros(4, int), (0,), pts)


def test_legs_are_apart_below_the_crotch_and_not_above_it():
    body, ids = lower_body()
    assert legs_apart(0.3, body.vertices, ids, "S5")
    # a body whose thighs merge into the hips (overlapping blobs) at the hem's height
    fat = body.vertices.copy()
    legs = ids > 0
    fat[legs, 0] -= np.sign(fat[legs, 0]) * 0.03  # leg axes 6 cm out, radius 7 cm: they overlap
    assert not legs_apart(0.3, fat, ids, "S5")
    assert not legs_apart(0.8, body.vertices, ids, "S5")  # no legs at that height


def test_jacket_over_a_skirt_pushes_the_skirt_behind_it():
    body, ids = lower_body()
    skirt = _skirt()
    jacket = mesh(*tube(0.17, 0.45, 0.95, grid=(64, 24)))  # inside the skirt on z 0.45-0.62
    res = resolve_layers(body, [skirt, jacket], body_segments=ids, scheme="S5")
    # the jacket's hem (z 0.45) is just below the torso, mostly on it: not a skirt
    assert res.stats["skirts"] == [0]
    assert (res.segments[0] == S5.skirt).sum() > 0.5 * len(skirt.vertices)
    s, j = res.garments
    assert brute_crossings(s.vertices, s.faces, j.vertices, j.faces) == 0
    # where the jacket covers it, the skirt now lies inside the jacket's inscribed radius
    covered = (skirt.vertices[:, 2] > 0.46) & (skirt.vertices[:, 2] < 0.6)
    inner = 0.17 * np.cos(np.pi / 64)
    assert (np.linalg.norm(s.vertices[covered, :2], axis=1) < inner).all()
    assert not res.moved[1].any()


def test_a_long_probe_does_not_pull_a_skirt_towards_its_far_side():
    # Probes longer than the skirt is wide cross the gap between the legs and meet the far
    # side of the skirt above, which faces the other way: not a layer in front.
    body, ids = lower_body()
    rng = np.random.default_rng(3)
    skirts = [mesh(*tube(r, 0.2, 0.62 - 0.003 * k, grid=(64, 24), folds=Folds(0.008, rng)))
              for k, r in enumerate((0.18, 0.184))]
    res = resolve_layers(body, skirts, body_segments=ids, scheme="S5", probe_distance=0.6)
    assert res.stats["skirts"] == [0, 1]
    a, b = res.garments
    assert brute_crossings(a.vertices, a.faces, b.vertices, b.faces) == 0
    # the inner skirt only moves where the outer one dips into it: by the bumps, not across the gap
    r_in = np.linalg.norm(skirts[0].vertices[:, :2], axis=1)
    r_out_min = np.linalg.norm(skirts[1].vertices[:, :2], axis=1).min()
    assert np.linalg.norm(res.moved[0], axis=1).max() < r_in.max() - r_out_min + 0.01


def test_hull_normals_point_away_from_the_nearest_hull_point():
    # A box's hull: the nearest point of an outside point is the point clamped to the box,
    # so round its edges and corners the normal turns with the point, not facet by facet.
    rng = np.random.default_rng(0)
    lo, hi = np.array([-0.2, -0.1, 0.0]), np.array([0.2, 0.1, 1.0])
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    body = np.vstack([corners, lo + rng.random((200, 3)) * (hi - lo)])
    pts = lo - 0.3 + rng.random((500, 3)) * (hi - lo + 0.6)
    n = hull_normals(body, np.zeros(len(body), int), (0,), pts)
    near = np.clip(pts, lo, hi)
    out = np.linalg.norm(pts - near, axis=1) > 0.01
    expect = (pts - near)[out] / np.linalg.norm(pts - near, axis=1, keepdims=True)[out]
    # the normal differs by the small facet bridge only (1e-3 of the hull's size over >= 1 cm)
    np.testing.assert_allclose(n[out], expect, atol=0.12)
    assert np.einsum("ij,ij->i", n[out], expect).min() > 0.995
    # inside, the normal of the nearest face
    inner = ((pts > lo) & (pts < hi)).all(1)
    gap = np.column_stack([pts - lo, hi - pts])[inner]
    face = np.argmin(gap, axis=1)
    expect_in = np.zeros((inner.sum(), 3))
    expect_in[np.arange(len(face)), face % 3] = np.where(face < 3, -1.0, 1.0)
    np.testing.assert_allclose(n[inner], expect_in, atol=1e-9)


@pytest.mark.parametrize("seed", [0, 1])
def test_nearest_on_convex_hull_matches_every_facet_tried(seed):
    # A hull of an elongated point cloud (small facets and long slivers, like a body's), points
    # inside, outside, over its edges and corners; the reference tries every facet.
    rng = np.random.default_rng(seed)
    cloud = rng.normal(size=(300, 3)) * [0.3, 0.15, 0.8]
    hv, hf = _hull_mesh(cloud, ConvexHull(cloud))
    tri = hv[hf]
    # wound outward: every vertex lies behind every facet's plane
    unit = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    assert (hv @ unit.T - np.einsum("ij,ij->i", unit, tri[:, 0]) < 1e-12).all()
    pts = np.vstack([rng.normal(size=(3000, 3)) * [0.4, 0.25, 1.0],
                     hv[rng.integers(len(hv), size=200)] * 1.2,  # beyond the corners
                     tri[:, :2].mean(1)[:200] * 1.1])  # beyond the edges
    facet, away = _nearest_on_convex(pts, _prepared_hull(hv, hf))
    # every facet of every point, by brute force
    p = np.repeat(pts, len(hf), axis=0)
    t = np.tile(tri, (len(pts), 1, 1))
    q = np.einsum("ij,ijk->ik", closest_point_on_triangles(p, t[:, 0], t[:, 1], t[:, 2]), t)
    dist = np.linalg.norm(p - q, axis=1).reshape(len(pts), len(hf))
    height = pts @ unit.T - np.einsum("ij,ij->i", unit, tri[:, 0])
    outside = height.max(1) > 0
    assert 0.2 < outside.mean() < 0.9
    np.testing.assert_allclose(np.linalg.norm(away, axis=1)[outside], dist.min(1)[outside], rtol=0, atol=1e-12)
    # inside: the depth below the closest plane, along its normal
    np.testing.assert_allclose(np.einsum("ij,ij->i", away, facet)[~outside], -height.max(1)[~outside], atol=1e-12)
    # the facet returned holds a nearest point (ties between facets sharing it are either)
    chosen = np.argmax(facet @ unit.T, axis=1)
    np.testing.assert_allclose(dist[np.arange(len(pts)), chosen][outside], dist.min(1)[outside], atol=1e-12)


def test_scheme_needs_body_segments_in_range():
    body, ids = lower_body(n=16)
    skirt = _skirt(n=16)
    with pytest.raises(ValueError, match="pass body_segments"):
        resolve_layers(body, [skirt], scheme="S5")
    with pytest.raises(ValueError, match="ids 0..4"):
        resolve_layers(body, [skirt], body_segments=np.where(ids == 4, 5, ids), scheme="S5")
    with pytest.raises(ValueError, match="segment_links must be"):
        resolve_layers(body, [skirt], body_segments=ids, segment_links=np.eye(2, dtype=bool))


def test_reused_correspondence_gives_the_same_result():
    body, ids = lower_body(n=24)
    skirt, jacket = _skirt(n=32), mesh(*tube(0.17, 0.45, 0.95, grid=(32, 12)))
    first = resolve_layers(body, [skirt, jacket], body_segments=ids, scheme="S5")
    again = resolve_layers(body, [skirt, jacket], body_segments=ids, scheme="S5", correspondence=first.correspondence)
    for a, b in zip(first.garments, again.garments, strict=True):  # (a distance recomputed: round-off)
        np.testing.assert_allclose(a.vertices, b.vertices, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="for another mesh"):
        resolve_layers(body, [jacket, skirt], body_segments=ids, correspondence=first.correspondence)


def test_skirt_points_on_the_legs_meet_a_higher_layer_of_the_torso():
    # The jacket is all torso (a user's override); the skirt's points below the hips are on
    # the legs. Only the skirt segment, linked to the torso (Fig. 4.7), lets their rays meet it.
    body, ids = lower_body()
    skirt = _skirt()
    jacket = mesh(*tube(0.17, 0.3, 0.95, grid=(64, 24)))
    covered = (skirt.vertices[:, 2] > 0.31) & (skirt.vertices[:, 2] < 0.6)
    inner = 0.17 * np.cos(np.pi / 64)
    segs = [None, np.zeros(len(jacket.vertices), int)]
    plain = resolve_layers(body, [skirt, jacket], body_segments=ids, garment_segments=segs, remove_hidden=False,
                           segment_margin=0.0)
    on_legs = covered & np.isin(plain.segments[0], (3, 4))
    assert on_legs.sum() > 100
    assert (np.linalg.norm(plain.garments[0].vertices[on_legs, :2], axis=1) > inner).all()
    res = resolve_layers(body, [skirt, jacket], body_segments=ids, garment_segments=segs, scheme="S5",
                         remove_hidden=False, segment_margin=0.0)
    assert (np.linalg.norm(res.garments[0].vertices[covered, :2], axis=1) < inner).all()


def test_given_skirt_segments_get_the_skirt_treatment():
    # segments passed back in (painted DRT_ groups) give what the skirt detection gave
    body, ids = lower_body()
    skirt, jacket = _skirt(), mesh(*tube(0.17, 0.45, 0.95, grid=(64, 24)))
    found = resolve_layers(body, [skirt, jacket], body_segments=ids, scheme="S5", segment_margin=0.0)
    again = resolve_layers(body, [skirt, jacket], body_segments=ids, scheme="S5", segment_margin=0.0,
                           garment_segments=found.segments)
    assert again.stats["skirts"] == found.stats["skirts"] == [0]
    np.testing.assert_allclose(again.global_normals[0], found.global_normals[0])
    np.testing.assert_allclose(again.moved[0], found.moved[0])


def test_one_part_probe_distance_overrides_only_that_part():
    body, ids = lower_body()
    rng = np.random.default_rng(4)
    skirts = [mesh(*tube(r, 0.2, 0.62 - 0.003 * k, grid=(32, 12), folds=Folds(0.004, rng)))
              for k, r in enumerate((0.18, 0.184))]
    default = resolve_layers(body, skirts, body_segments=ids, scheme="S5").stats["probe_distance"]
    given = np.full(len(default), np.nan)
    given[3] = 0.123
    mixed = resolve_layers(body, skirts, body_segments=ids, scheme="S5", probe_distance=given).stats["probe_distance"]
    want = np.array(default)
    want[3] = 0.123
    np.testing.assert_allclose(mixed, want)
    with pytest.raises(ValueError, match="probe_distance"):
        resolve_layers(body, skirts, body_segments=ids, scheme="S5", probe_distance=np.inf)


def test_each_body_gets_its_own_skirt_hull():
    """The hull is kept per set of body points: a second body with the same part ids gets its own.
    Over a ball the hull's outward direction is the radial one from that ball's centre."""
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.3)
    point = np.array([[0.5, 0.0, 2.0]])
    for centre in ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)):
        v = np.asarray(ball.vertices) + centre
        n = hull_normals(v, np.zeros(len(v), dtype=np.int64), (0,), point)
        want = (point - centre) / np.linalg.norm(point - centre)
        assert float(n[0] @ want[0]) > 0.999


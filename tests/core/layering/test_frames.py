"""Frame to frame (Resolve on Frame Change, frame bakes): body points carried through the body's
motion and searched again where the cloth has left them, and hidden faces that never blink."""

import numpy as np
import pytest
import trimesh

from core.layering import frame_coherence, resolve_layers
from core.layering.body_facts import body_facts
from core.layering.correspondence import BodyCorrespondence
from core.layering.frame_coherence import HIDE_HOLD
from core.layering.garment_prep import DRIFT, SWITCH, carried
from sample_scenes.shapes import Folds, tube
from tests.core.layered_cases import body_tube, lower_body, mesh


def _trouser_legs(x, seed=0):
    """Two noisy layers round a 7 cm leg at x (they cross), 30 cm long."""
    rng = np.random.default_rng(seed)
    out = []
    for r in (0.078, 0.081):
        v, f = tube(r, 0.1, 0.4, grid=(40, 16), folds=Folds(0.006, rng, floor=0.074))
        out.append(mesh(v + [x, 0, 0], f))
    return out


def test_cloth_the_body_moved_away_from_is_bound_to_the_body_it_is_on_now():
    """The inner-thigh case: garment points bound on frame 1 to one leg, the leg swung away and the
    cloth now on the other. Carried blindly, the old body points are 18 cm off and the cloth is
    pushed along the wrong leg's normals; searched again where they drifted, the frame resolves
    exactly as a fresh search resolves it."""
    body, parts = lower_body()
    first = resolve_layers(body, _trouser_legs(0.09), body_segments=parts)
    kept = first.found()[1]
    moved_on = _trouser_legs(-0.09)
    fresh = resolve_layers(body, moved_on, body_segments=parts)
    again = resolve_layers(body, moved_on, body_segments=parts, correspondence=kept)
    for a, b in zip(again.moved, fresh.moved, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-9)
    assert max(np.linalg.norm(m, axis=1).max() for m in again.moved) < 0.02


def test_a_carried_point_is_searched_again_only_where_it_drifted_and_then_is_the_nearest():
    body, _ = lower_body()
    facts = body_facts(np.asarray(body.vertices, float), np.asarray(body.faces))
    rng = np.random.default_rng(3)
    # points 5-15 mm off the left leg (x = +9 cm), bound there
    ang, z = rng.uniform(0, 2 * np.pi, 300), rng.uniform(0.1, 0.4, 300)
    r = 0.07 + rng.uniform(0.005, 0.015, 300)
    p = np.column_stack([0.09 + r * np.cos(ang), r * np.sin(ang), z])
    closest, dist, tri = trimesh.proximity.closest_point(body, p)  # the independent reference
    bary = trimesh.triangles.points_to_barycentric(body.triangles[tri], closest)
    bound = BodyCorrespondence(tri.astype(np.int64), bary, dist)
    # the first half of the points leaves the left leg for the right one; the rest stays
    q = p.copy()
    q[:150, 0] -= 0.18
    c = carried(bound, q, facts, gap=0.002)
    _, near, _ = trimesh.proximity.closest_point(body, q)
    np.testing.assert_allclose(c.distance[:150], near[:150], atol=1e-9)
    np.testing.assert_array_equal(c.triangle[150:], tri[150:])  # not searched: the same body points
    np.testing.assert_allclose(c.distance[150:], dist[150:], atol=1e-12)
    assert (c.checked[:150] == c.distance[:150]).all()
    # a point that drifted but whose nearest is hardly nearer keeps its binding (no switching back
    # and forth between two parts at about the same distance)
    lifted = p[150:151] + [0.0, 0.0, 0.0]
    lifted[0, :2] += (lifted[0, :2] - [0.09, 0]) / np.linalg.norm(lifted[0, :2] - [0.09, 0]) * 0.02
    c2 = carried(BodyCorrespondence(tri[150:151].astype(np.int64), bary[150:151], dist[150:151]), lifted, facts,
                 gap=0.001)
    assert c2.distance[0] > DRIFT * dist[150]
    assert c2.triangle[0] == tri[150] or c2.distance[0] < SWITCH * np.linalg.norm(lifted[0] - closest[150])


def _dented(dent: bool):
    """A lower sleeve over a tube body and a higher one that, when ``dent``, dips to 1.5 mm off the
    body over a patch: there the lower layer has no room behind it and shows through, so its
    faces are hidden; without the dent nothing is hidden."""
    v, f = tube(0.17, 0.05, 0.55, grid=(64, 32))
    if dent:
        ang = np.arctan2(v[:, 1], v[:, 0])
        patch = (np.abs(ang) < 0.35) & (np.abs(v[:, 2] - 0.3) < 0.06)
        v[patch, :2] *= 0.1515 / 0.17
    low = tube(0.16, 0.08, 0.52, grid=(48, 24))
    return [mesh(*low), mesh(v, f)]


def _pops(masks):
    m = np.array(masks)
    return int(((m[1:-1] != m[:-2]) & (m[1:-1] != m[2:])).sum())


@pytest.mark.parametrize("outer_room", [False, True])
def test_a_face_that_crosses_every_other_frame_never_blinks(outer_room):
    """Hidden in a frame: what crossed in it or in the HIDE_HOLD frames before. With the outer room
    stage the higher layer's dent goes out by a gap where it still crosses, and easing holds that
    from frame to frame, so which faces cross differs from the frames resolved alone: there only
    no face may blink."""
    body = body_tube()
    frames = [_dented(k % 2 == 0) for k in range(7)]
    first = resolve_layers(body, frames[0], outer_room=outer_room)
    kept = first.found()[1]
    alone = [resolve_layers(body, g, correspondence=kept, outer_room=outer_room).removed_faces[0] for g in frames]
    assert any(m.any() for m in alone) and _pops(alone) > 0  # each frame by itself blinks
    chain, last = [], None
    for g in frames:
        last = resolve_layers(body, g, correspondence=kept, previous=last, outer_room=outer_room)
        chain.append(last.removed_faces[0])
    assert _pops(chain) == 0
    if not outer_room:
        for t, m in enumerate(chain):  # hidden: what crossed in this frame or the HIDE_HOLD before it
            np.testing.assert_array_equal(m, np.any(alone[max(0, t - HIDE_HOLD):t + 1], axis=0))


@pytest.mark.parametrize("bad", ["count", "faces"])
def test_a_previous_result_for_other_meshes_is_not_used(bad):
    body = body_tube()
    frame = _dented(True)
    other = [mesh(*tube(0.16, 0.08, 0.52, grid=(40 if bad == "count" else 48, 24))), frame[1]]
    if bad == "faces":
        other[0] = mesh(other[0].vertices, other[0].faces[:-2])
    prev = resolve_layers(body, other)
    res = resolve_layers(body, frame, previous=prev)
    np.testing.assert_array_equal(res.removed_faces[0], resolve_layers(body, frame).removed_faces[0])


@pytest.mark.parametrize("kind", ["legs", "box"])
def test_the_nearest_within_a_bound_is_the_nearest_point_of_the_surface(kind):
    """Against brute force over every triangle, on fine legs and on a box of twelve large triangles (whose
    nearest triangle may have no corner near the point); the bound is the distance to any point of
    the surface, as a carried body point gives it."""
    from core.geometry.topology import topology_of
    from core.layering.correspondence import nearest_within

    body = lower_body()[0] if kind == "legs" else trimesh.creation.box(extents=(1.0, 0.6, 0.3))
    rng = np.random.default_rng(7)
    p = body.bounds[0] - 0.05 + rng.random((200, 3)) * (np.ptp(body.bounds, axis=0) + 0.1)
    somewhere = body.sample(200, seed=3) if hasattr(body, "sample") else None
    bound = np.linalg.norm(p - somewhere, axis=1)
    faces = np.asarray(body.faces, dtype=np.int64)
    found = nearest_within(p, bound, body.vertices, faces, topology_of(faces, len(body.vertices)).vertex_faces)
    # brute force: every triangle's closest point (trimesh's per-triangle solution) for every point
    tri = body.triangles
    dist = np.array([np.linalg.norm(trimesh.triangles.closest_point(tri, np.repeat(q[None], len(tri), 0)) - q,
                                    axis=1).min() for q in p])
    np.testing.assert_allclose(found.distance, dist, atol=1e-9)
    on = np.einsum("ij,ijk->ik", found.bary, body.vertices[faces[found.triangle]])
    np.testing.assert_allclose(np.linalg.norm(p - on, axis=1), dist, atol=1e-9)


def test_cloth_falling_far_above_the_body_is_bound_again_exactly_by_the_search_structure(monkeypatch):
    """Points 25-45 cm over the legs (cloth falling onto a stage, blown sideways), carried from body
    points they have drifted 40 cm away from: their bounds take in every body vertex, more than
    WITHIN_PAIRS pairs, so the bounded search declines (None) and the search structure binds them,
    exactly (against trimesh's closest points); near the body the bounded search still answers."""
    import core.layering.garment_prep as garment_prep
    from core.geometry.topology import topology_of
    from core.layering.correspondence import nearest_within

    body, _ = lower_body()
    faces = np.asarray(body.faces, dtype=np.int64)
    facts = body_facts(np.asarray(body.vertices, float), faces)
    rng = np.random.default_rng(5)
    top = body.bounds[1][2]
    p = np.column_stack([rng.uniform(-0.15, 0.15, 120), rng.uniform(-0.1, 0.1, 120),
                         top + rng.uniform(0.25, 0.45, 120)])
    closest, dist, tri = trimesh.proximity.closest_point(body, p)
    bary = trimesh.triangles.points_to_barycentric(body.triangles[tri], closest)
    was = BodyCorrespondence(tri.astype(np.int64), bary, dist)
    q = p + [0.4, 0.0, -0.05]
    vertex_faces = topology_of(faces, len(body.vertices)).vertex_faces
    bound = np.linalg.norm(q - closest, axis=1)  # the carried body points' distance now
    assert nearest_within(q, bound, body.vertices, faces, vertex_faces, budget=garment_prep.WITHIN_PAIRS) is None
    asked = []
    real = garment_prep.nearest_on_surface
    monkeypatch.setattr(garment_prep, "nearest_on_surface",
                        lambda pts, *a, **k: asked.append(len(pts)) or real(pts, *a, **k))
    c = garment_prep.carried(was, q, facts, gap=0.002)
    _, near, _ = trimesh.proximity.closest_point(body, q)
    assert asked and sum(asked) <= len(q)
    moved = c.distance < bound - 1e-9
    assert moved.any()
    np.testing.assert_allclose(c.distance[moved], near[moved], atol=1e-6)
    # on a finely meshed body (1 cm edges, as a figure's skin), points a centimetre off it: the
    # bounded search answers by itself, exactly
    ball = trimesh.creation.icosphere(subdivisions=4, radius=0.1)
    ball_faces = np.asarray(ball.faces, dtype=np.int64)
    close = ball.sample(40, seed=2) * 1.1
    _, d_close, _ = trimesh.proximity.closest_point(ball, close)
    found = nearest_within(close, d_close * 1.5, ball.vertices, ball_faces,
                           topology_of(ball_faces, len(ball.vertices)).vertex_faces, budget=garment_prep.WITHIN_PAIRS)
    assert found is not None
    np.testing.assert_allclose(found.distance, d_close, atol=1e-9)


def test_cloth_that_slid_beside_its_body_point_is_bound_again_before_it_reads_as_inside():
    """Cloth 10 mm over a flat body slides 8 mm along it and sinks to 6 mm: as far from its old body
    point as before, but beside it; ever further along, "behind the point's normal" would read as
    inside the body and lift it by the whole distance. It is bound to the point under it."""
    from tests.core.layered_cases import slab_body

    body = slab_body(size=1.0, thickness=0.2, subdivisions=4)
    facts = body_facts(np.asarray(body.vertices, float), np.asarray(body.faces))
    p = np.array([[0.01, 0.02, 0.010], [-0.1, 0.05, 0.010]])
    closest, dist, tri = trimesh.proximity.closest_point(body, p)
    bary = trimesh.triangles.points_to_barycentric(body.triangles[tri], closest)
    bound = BodyCorrespondence(tri.astype(np.int64), bary, dist)
    q = p + [[0.008, 0.0, -0.004], [0.0, 0.0, 0.0]]  # the first slid and sank; the second stayed
    c = carried(bound, q, facts, gap=0.001)
    np.testing.assert_allclose(c.distance, [0.006, 0.010], atol=1e-9)
    under = np.einsum("ij,ijk->ik", c.bary, body.vertices[body.faces[c.triangle]])
    np.testing.assert_allclose(under[0], [0.018, 0.02, 0.0], atol=1e-9)
    assert c.triangle[1] == tri[1]


def test_a_lift_off_the_body_eases_out_at_its_rate_in_playback():
    """A sleeve sunk 2 cm into a tube body is lifted by its depth and the floor; on the next frame
    it lies clear of the body: resolved alone it needs no lift, after the sunk frame the lift falls
    by RATE gaps."""
    from core.layering.body_lift import RATE

    body = body_tube(n=48)
    outer = mesh(*tube(0.175, 0.1, 0.5, grid=(48, 24)))
    sunk = [mesh(*tube(0.13, 0.12, 0.48, grid=(48, 24))), outer]
    clear = [mesh(*tube(0.16, 0.12, 0.48, grid=(48, 24))), outer]
    first = resolve_layers(body, sunk)
    depth = 0.15 * np.cos(np.pi / 48) - 0.13  # to the 48-gon's flat sides, at most
    assert first.lifts[0].min() > depth
    alone = resolve_layers(body, clear)
    assert not alone.lifts[0].any()
    after = resolve_layers(body, clear, correspondence=first.found()[1], previous=first)
    np.testing.assert_allclose(after.lifts[0], first.lifts[0] - RATE * after.stats["gap"], rtol=1e-9)



def _second_differences(chain, frames, k):
    d = np.array([r.moved[k] for r in chain])
    x = np.array([g[k].vertices for g in frames])
    return (np.linalg.norm(d[2:] - 2 * d[1:-1] + d[:-2], axis=2),
            np.linalg.norm(x[2:] - 2 * x[1:-1] + x[:-2], axis=2))


def test_a_correction_that_flips_every_frame_changes_no_faster_than_its_bound():
    """The higher sleeve dents in and out every other frame: resolved alone, the lower one is pushed
    in and let out by several millimetres a frame (its correction's second difference is the
    jolt one sees). In playback its correction departs from the last two frames' trend by at
    most JERK offsets plus MOTION_SHARE of the cloth's own acceleration, vertex by vertex."""
    from core.layering.frame_coherence import JERK, MOTION_SHARE

    body = body_tube()
    frames = [_dented(k % 2 == 0) for k in range(8)]
    kept = resolve_layers(body, frames[0]).found()[1]
    alone = [resolve_layers(body, g, correspondence=kept) for g in frames]
    chain, last = [], None
    for g in frames:
        last = resolve_layers(body, g, correspondence=kept, previous=last)
        chain.append(last)
    offset = chain[0].stats["offset"]
    jolt, _ = _second_differences(alone, frames, 0)
    assert jolt.max() > 4 * JERK * offset  # the flip, frame by frame
    for k in range(2):
        jerk, motion = _second_differences(chain, frames, k)
        assert (jerk <= JERK * offset + MOTION_SHARE * motion + 1e-9).all()
        # the design's numbers (docs/REPORT.md): a quarter offset (0.5 mm on a person, half the 1 mm
        # p99 issue 57 allows) and 15% of the cloth's acceleration (what ramps three times as fast need)
        assert (jerk <= 0.25 * offset + 0.15 * motion + 1e-9).all()
    assert sum(r.stats["vertices_eased"] for r in chain) > 0


def test_a_frame_reports_how_far_easing_left_its_cloth_from_where_the_frame_alone_put_it(monkeypatch):
    """The flipping dent in playback: each frame's stats say the farthest a vertex was left from
    where that frame's own stages put it (what ``eased`` was given) and how many were left farther
    than the gap between layers, measured here from what ``eased`` was given and gave back."""
    import core.layering.resolve as resolve_module

    seen = []
    real = resolve_module.eased

    def spy(vertices, *args):
        out, n = real(vertices, *args)
        seen[-1].append(np.linalg.norm((out if n else vertices) - vertices, axis=1))
        return out, n

    monkeypatch.setattr(resolve_module, "eased", spy)
    body = body_tube()
    last, rows = None, []
    for k in range(8):
        seen.append([])
        last = resolve_layers(body, _dented(k % 2 == 0), previous=last)
        rows.append(last.stats)
    assert rows[0]["eased_most"] == 0.0 and rows[0]["eased_past_gap"] == 0 and not seen[0]
    for stats, lefts in zip(rows[1:], seen[1:], strict=True):
        left = np.concatenate(lefts)
        assert stats["eased_most"] == left.max()
        assert stats["eased_past_gap"] == int((left > stats["gap"]).sum())
        assert stats["vertices_eased"] == int((left > 0).sum())
    assert max(r["eased_most"] for r in rows) > 0.5 * rows[0]["offset"]  # the flip was eased


def test_a_correction_carried_by_a_fast_limb_changes_no_faster_than_jerk(monkeypatch):
    """The flipping dent of the test above on a body and sleeves that all move together, ever
    faster (20 mm a frame more each frame, a fast limb): the cloth keeps its place on the body,
    so its correction may depart from the trend by JERK offsets only. The old bound grew with the
    cloth's acceleration in the world (15% of 20 mm: the flip went through by 3 mm a frame)."""
    monkeypatch.setattr(frame_coherence, "HOLD", 0.0)  # the bound alone: no band held
    from core.layering.frame_coherence import JERK

    def moved(meshes, t):
        shift = np.array([0.5 * 0.02 * t * t, 0.0, 0.0])
        return [mesh(m.vertices + shift, m.faces) for m in meshes]

    frames = [moved(_dented(k % 2 == 0), k) for k in range(8)]
    bodies = [moved([body_tube()], k)[0] for k in range(8)]
    chain, last = [], None
    for body, g in zip(bodies, frames, strict=True):
        last = resolve_layers(body, g, previous=last)
        chain.append(last)
    offset = chain[0].stats["offset"]
    jerk, motion = _second_differences(chain, frames, 0)
    assert motion.min() > 0.019  # the cloth accelerates 20 mm a frame in the world
    assert jerk.max() <= JERK * offset + 1e-6  # float32 rounding of the moved meshes aside
    assert jerk.max() <= 0.25 * offset + 1e-6  # the design's quarter offset: 0.5 mm on a person
    assert jerk.max() > 0.5 * JERK * offset  # the flip is there, bounded
    assert sum(r.stats["vertices_eased"] for r in chain) > 0


def test_cloth_sliding_over_a_still_body_lets_its_correction_change_by_a_share_of_its_acceleration():
    """The flipping dent on sleeves that slide along a still tube body, ever faster (4 mm a frame
    more each frame): relative to its body points the cloth accelerates as much as in the world,
    and the correction may depart from its trend by a quarter offset plus 15% of that (the design's
    numbers, docs/REPORT.md), no more; the flip needs the share (it goes past the quarter offset)."""
    def slid(meshes, t):
        shift = np.array([0.0, 0.0, 0.5 * 0.004 * t * t])
        return [mesh(m.vertices + shift, m.faces) for m in meshes]

    body = body_tube(height=0.8)
    frames = [slid(_dented(k % 2 == 0), k) for k in range(8)]
    chain, last = [], None
    for g in frames:
        last = resolve_layers(body, g, previous=last)
        chain.append(last)
    offset = chain[0].stats["offset"]
    jerk, motion = _second_differences(chain, frames, 0)
    assert motion.min() > 0.0039
    assert (jerk <= 0.25 * offset + 0.15 * motion + 1e-6).all()
    assert jerk.max() > 0.25 * offset + 0.05 * motion.min()  # bounded by the share, not by JERK alone
    assert sum(r.stats["vertices_eased"] for r in chain) > 0


def _turning_patch(degrees_a_frame, frames=3, radius=0.1):
    """A small patch 0.1 m from the x axis, turning about it, its cloth lying on it (each cloth point
    on its own body vertex): per frame (posed patch, its vertex normals)."""
    from scipy.spatial.transform import Rotation

    from core.geometry.normals import vertex_normals

    ring = np.array([[np.cos(t), np.sin(t), 0.0] for t in np.linspace(0, 2 * np.pi, 8, endpoint=False)]) * 0.01
    rest = np.vstack([[0.0, 0.0, 0.0], ring]) + [0.0, 0.0, radius]
    faces = np.array([[0, 1 + i, 1 + (i + 1) % 8] for i in range(8)])
    out = []
    for frame in range(frames):
        posed = Rotation.from_euler("x", degrees_a_frame * frame, degrees=True).apply(rest)
        out.append((posed, vertex_normals(posed, faces)))
    return out, faces


@pytest.mark.parametrize("degrees", [8.0, 30.0])
def test_a_limb_turning_faster_than_followed_lets_the_correction_keep_up_with_the_cloth(degrees, monkeypatch):
    """No correction for two frames, then 2 mm along the normal (a change from the trend of 2 mm).
    Turning 8 degrees a frame (followed), the cloth keeps its place on its body point: eased to JERK
    offsets. Turning 30 degrees a frame (past TURN_NONE, the last corrections are not turned), the
    bound is the world's: the cloth's centripetal acceleration, 2 r (1 - cos 30 deg) = 26.8 mm, of
    which MOTION_SHARE (4.0 mm) is more than the change, so it is taken whole."""
    monkeypatch.setattr(frame_coherence, "HOLD", 0.0)  # the bound alone: no band held
    from core.layering.frame_coherence import JERK, MOTION_SHARE, TURN_FULL, TURN_NONE, BodyNow, History, eased

    assert degrees <= TURN_FULL or degrees > TURN_NONE
    patch, faces = _turning_patch(degrees)
    offset = 0.002
    on = BodyCorrespondence(np.array([0] + [i for i in range(8)]), np.vstack([[1.0, 0, 0]] + [[0, 1.0, 0]] * 8),
                            np.zeros(9))
    history = None
    for frame, (posed, normals) in enumerate(patch):
        resolved = posed + (0.002 * normals if frame == 2 else 0.0)
        if history is not None:
            out, count = eased(resolved, posed, 0, history, offset, BodyNow(on, normals, faces, posed))
            resolved = out if count else resolved
        history = History([resolved - posed], [posed], normals, history, posed)
    d = np.linalg.norm(resolved[0] - patch[2][0][0])
    world = 2 * 0.1 * (1 - np.cos(np.radians(degrees)))
    if degrees < TURN_NONE:
        np.testing.assert_allclose(d, JERK * offset, rtol=1e-9)
    else:
        assert MOTION_SHARE * world > 0.002
        np.testing.assert_allclose(d, 0.002, rtol=1e-12)


def test_a_correction_turned_with_a_body_that_starts_turning_jolts_no_more_than_its_cap(monkeypatch):
    """A 40 mm lift along the normal of a patch that stands still for two frames, then turns 10
    degrees a frame (followed): the lift turned with the body would swing 7 mm off its world trend in
    the first turning frame (2 sin 5 deg of 40 mm), a jolt a viewer sees. Its second difference in
    the world stays within ACCEL_CAP offsets every frame, and it catches up with the turning lift
    (whose steady turn needs 40 mm x (10 deg)^2 = 1.2 mm a frame per frame)."""
    monkeypatch.setattr(frame_coherence, "HOLD", 0.0)  # the bound and the cap alone
    from core.layering.frame_coherence import ACCEL_CAP, BodyNow, History, eased

    still, faces = _turning_patch(0.0, frames=2)
    turning, _ = _turning_patch(10.0, frames=14)
    patch = still + turning[1:]
    offset, lift = 0.002, 0.04
    on = BodyCorrespondence(np.array([0] + [i for i in range(8)]), np.vstack([[1.0, 0, 0]] + [[0, 1.0, 0]] * 8),
                            np.zeros(9))
    history, corrections, own = None, [], []
    for posed, normals in patch:
        resolved = posed + lift * normals
        own.append(resolved - posed)
        if history is not None:
            out, count = eased(resolved, posed, 0, history, offset, BodyNow(on, normals, faces, posed))
            resolved = out if count else resolved
        corrections.append(resolved - posed)
        history = History([resolved - posed], [posed], normals, history, posed)
    d, alone = np.array(corrections), np.array(own)
    second = lambda c: np.linalg.norm(c[2:] - 2 * c[1:-1] + c[:-2], axis=2)  # noqa: E731
    assert second(alone).max() > 0.005  # the jolt the turn alone makes, past the 5 mm issue 57 allows
    assert second(d).max() <= min(ACCEL_CAP * offset, 0.005) + 1e-9
    assert second(d).max() > 0.9 * ACCEL_CAP * offset  # capped, not eased away by the other rules
    np.testing.assert_allclose(d[-1], alone[-1], atol=0.1 * offset)  # caught up with the turning lift


def _runs_of_one(masks):
    m = np.array(masks)
    return int(((m[1:-1] != m[:-2]) & (m[1:-1] != m[2:])).sum())


def test_no_face_is_hidden_or_shown_for_a_single_frame():
    """Random crossings of 400 faces over 60 frames through the hold: no state lasts one frame (a
    face crossing again one frame after its hold ran out used to show for that frame only), and
    against the rule written out face by face: hidden when it crossed within HIDE_HOLD frames,
    except the frame after it was shown for one frame only."""
    from core.layering.frame_coherence import held_hidden

    rng = np.random.default_rng(7)
    crossing = rng.random((60, 400)) < rng.uniform(0.02, 0.5, 400)
    out, state = [], (None, None, None)
    for now in crossing:
        state = held_hidden([now], *state)
        out.append(state[0][0])
    assert _runs_of_one(out) == 0 and _runs_of_one(crossing) > 0
    # the same rule by hand, face by face
    for face in range(400):
        last_cross, hidden_before, shown_run = -10, None, 0
        for t in range(60):
            if crossing[t, face]:
                last_cross = t
            hide = t - last_cross <= HIDE_HOLD and (crossing[t, face] or bool(hidden_before))
            if hidden_before is False and shown_run == 1:
                hide = False
            assert out[t][face] == hide, (face, t)
            shown_run = 0 if hide else (min(shown_run + 1, 2) if t else 2)  # shown from the start: not "just"
            hidden_before = hide


def test_a_simulated_garments_crossing_faces_are_hidden_every_frame_they_cross():
    """The random crossings above on two garments at once, one skinned and one simulated (a cloth
    solver's): the skinned one's faces never change state for one frame only, the simulated one's
    are hidden on every frame they cross (against the rule written out: hidden when it crossed
    within HIDE_HOLD frames, no exception), while the skinned one still shows some crossing faces
    for a frame (the rule that keeps it free of one-frame states)."""
    from core.layering.frame_coherence import held_hidden

    rng = np.random.default_rng(7)
    crossing = rng.random((60, 400)) < rng.uniform(0.02, 0.5, 400)
    out, state = [], (None, None, None)
    for now in crossing:
        state = held_hidden([now, now], *state, simulated=[False, True])
        out.append(state[0])
    skinned, solved = np.array([o[0] for o in out]), np.array([o[1] for o in out])
    assert _runs_of_one(skinned) == 0
    assert (skinned < crossing).any()  # shown while crossing: the skinned garment's trade
    assert not (solved < crossing).any()
    for face in range(400):
        last_cross = -10
        for t in range(60):
            if crossing[t, face]:
                last_cross = t
            hide = t - last_cross <= HIDE_HOLD and (crossing[t, face] or bool(solved[t - 1, face] if t else False))
            assert solved[t, face] == hide, (face, t)


def test_a_vector_is_turned_by_the_least_rotation_between_two_normals():
    """Against scipy's rotation about a x b by the angle between them; opposite or zero normals
    leave the vector as it is."""
    from scipy.spatial.transform import Rotation

    from core.layering.frame_coherence import turned

    rng = np.random.default_rng(3)
    a = rng.normal(size=(200, 3))
    b = a + rng.normal(scale=0.6, size=(200, 3))
    a /= np.linalg.norm(a, axis=1)[:, None]
    b /= np.linalg.norm(b, axis=1)[:, None]
    d = rng.normal(size=(200, 3))
    axis = np.cross(a, b)
    angle = np.arctan2(np.linalg.norm(axis, axis=1), np.einsum("ij,ij->i", a, b))
    keep = np.einsum("ij,ij->i", a, b) > -0.9
    rotvec = axis / np.linalg.norm(axis, axis=1)[:, None] * angle[:, None]
    want = Rotation.from_rotvec(rotvec[keep]).apply(d[keep])
    np.testing.assert_allclose(turned(d, a, b)[keep], want, atol=1e-12)
    assert keep.sum() > 150
    flat = np.zeros((2, 3))
    np.testing.assert_array_equal(turned(d[:2], np.stack([a[0], a[1]]), np.stack([-a[0], flat[1]])), d[:2])


def _lifted_on_a_still_patch(lifts, offset=0.002, slide=None):
    """A cloth point on each vertex of a still body patch, lifted along its normal by ``lifts`` in
    turn (what each frame resolves), played through ``eased``: per frame the lift kept. ``slide``:
    per frame how far the cloth has slid along x over the patch (its body points kept)."""
    from core.geometry.normals import vertex_normals
    from core.layering.frame_coherence import BodyNow, History, eased

    patch, faces = _turning_patch(0.0)
    posed = patch[0][0]
    normals = vertex_normals(posed, faces)
    on = BodyCorrespondence(np.array([0] + list(range(8))), np.vstack([[1.0, 0, 0]] + [[0, 1.0, 0]] * 8), np.zeros(9))
    body = posed
    history, kept = None, []
    for lift, x in zip(lifts, np.zeros(len(lifts)) if slide is None else slide, strict=True):
        cloth = body + [x, 0.0, 0.0]
        resolved = cloth + lift * normals
        if history is not None:
            out, count = eased(resolved, cloth, 0, history, offset, BodyNow(on, normals, faces, body))
            resolved = out if count else resolved
        history = History([resolved - cloth], [cloth], normals, history, body)
        kept.append(float(np.dot(resolved[0] - cloth[0], normals[0])))
    return np.array(kept)


def _switches_within(values, threshold, frames=3):
    on = np.asarray(values) > threshold
    at = np.flatnonzero(on[1:] != on[:-1])
    return int((np.diff(at) <= frames).sum())


def test_a_correction_the_frames_wander_about_is_held_and_switches_neither_on_nor_off():
    """Frame by frame a still figure's correction wanders by tenths of a millimetre (the stages'
    discrete choices); about the 1 mm at which issue 57 counts a correction as on, it switched on
    and off. Within HOLD offsets of the last correction it is kept as it was: constant here."""
    from core.layering.frame_coherence import HOLD

    offset = 0.002
    wander = 0.001 + np.array([0.0, 0.2, -0.2, 0.3, -0.1, 0.2, -0.3, 0.1]) * 1e-3
    assert np.abs(wander - wander[0]).max() < HOLD * offset  # within the band, everywhere
    kept = _lifted_on_a_still_patch(wander, offset)
    assert _switches_within(wander * 1000, 1.0) >= 3  # each frame alone switches
    np.testing.assert_allclose(kept, wander[0], rtol=0, atol=1e-15)
    assert _switches_within(kept * 1000, 1.0) == 0


def test_a_correction_that_must_grow_follows_one_band_behind_and_never_freezes():
    """A lift the frames want 0.4 mm larger each frame, on a still figure (no share of the cloth's
    motion widens the bound): the kept lift starts once the frame's is a band (HOLD offsets) away and
    settles one band behind what the frame asks, growing as fast. Held without the band added to
    the bound, the bounded step (JERK offsets from the trend) never left the band and the lift
    never started."""
    from core.layering.frame_coherence import HOLD, JERK

    offset = 0.002
    wanted = 0.004 + 0.0004 * np.arange(16)
    kept = _lifted_on_a_still_patch(wanted, offset)
    assert kept[1] == kept[0] and kept[2] > kept[1]  # it starts once the frame's is past the band
    assert (np.diff(kept) >= -1e-15).all() and (kept <= wanted + 1e-15).all()
    np.testing.assert_allclose(wanted[-4:] - kept[-4:], HOLD * offset, rtol=1e-6)
    np.testing.assert_allclose(np.diff(kept[-4:]), 0.0004, rtol=1e-6)
    second = np.abs(np.diff(kept, 2))
    assert second.max() <= (JERK + HOLD) * offset + 1e-12


def test_the_band_narrows_as_the_cloth_accelerates_over_its_body_points():
    """A lift the third frame wants 0.35 mm larger: on a still figure it is held (the band is HOLD
    offsets, 0.5 mm); with the cloth sliding over its body points, accelerating one offset a frame
    a frame, the band is HOLD offsets over 1 + 1 (0.25 mm), and the lift grows by what goes past it."""
    from core.layering.frame_coherence import HOLD

    offset = 0.002
    lifts = np.array([1.0, 1.0, 1.35]) * 1e-3
    still = _lifted_on_a_still_patch(lifts, offset)
    sliding = _lifted_on_a_still_patch(lifts, offset, slide=np.array([0.0, 0.0, offset]))
    np.testing.assert_allclose(still, 0.001, rtol=0, atol=1e-15)
    np.testing.assert_allclose(sliding[2], 0.00135 - HOLD * offset / 2.0, rtol=1e-9)


def test_a_lift_that_turns_with_the_cloth_eases_along_the_cloth_not_across_it(monkeypatch):
    """A cloth point on the axis a body patch turns about (it does not move; the patch's normal
    turns 8 degrees a frame, as a limb swung fast) lifted 10 mm along that normal for two frames,
    5 mm the third: turned with the body, the constant-velocity prediction is 10 mm along this
    frame's normal, so the eased correction is along this normal, JERK offsets shorter than 10 mm.
    Kept in world space, the last corrections point 8 and 16 degrees away and the bounded step
    toward this frame's goes sideways (a lift that never came down in a turning limb)."""
    monkeypatch.setattr(frame_coherence, "HOLD", 0.0)  # the bound alone: no band held
    from scipy.spatial.transform import Rotation

    from core.geometry.normals import vertex_normals
    from core.layering.frame_coherence import JERK, BodyNow, History, eased

    ring = np.array([[np.cos(t), np.sin(t), 0.0] for t in np.linspace(0, 2 * np.pi, 8, endpoint=False)]) * 0.02
    rest = np.vstack([[0.0, 0.0, 0.0], ring])
    faces = np.array([[0, 1 + i, 1 + (i + 1) % 8] for i in range(8)])
    offset = 0.002
    on = BodyCorrespondence(np.full(len(rest), 3), np.full((len(rest), 3), 1 / 3), np.zeros(len(rest)))
    history = None
    for frame, lift in enumerate((0.010, 0.010, 0.005)):
        posed = Rotation.from_euler("x", 8 * frame, degrees=True).apply(rest)
        body_normals = vertex_normals(posed, faces)  # the cloth lies on this patch of body
        resolved = posed + lift * body_normals[0]
        if history is not None:
            out, count = eased(resolved, posed, 0, history, offset, BodyNow(on, body_normals, faces, posed))
            resolved = out if count else resolved
        history = History([resolved - posed], [posed], body_normals, history)
    d = resolved[0] - posed[0]
    np.testing.assert_allclose(d, (0.010 - JERK * offset) * body_normals[0], atol=1e-12)


def test_a_body_that_flips_in_a_frame_does_not_turn_the_correction():
    """Skin folding through itself at a joint flips its normal; that is no turn of the cloth. Up to
    TURN_FULL degrees a frame a correction turns wholly, beyond TURN_NONE not at all, in between in
    part; over two frames, twice that."""
    from scipy.spatial.transform import Rotation

    from core.layering.frame_coherence import TURN_FULL, TURN_NONE, followed, turned

    angles = [0.5 * TURN_FULL, 0.5 * (TURN_FULL + TURN_NONE), 1.5 * TURN_NONE, 130.0]
    d = np.array([[0.0, 0.0, 0.01]] * 4)
    a = np.array([[0.0, 0.0, 1.0]] * 4)
    b = np.array([Rotation.from_euler("x", t, degrees=True).apply([0.0, 0.0, 1.0]) for t in angles])
    out = followed(d, a, b)
    np.testing.assert_allclose(out[0], turned(d, a, b)[0], atol=1e-15)
    np.testing.assert_array_equal(out[2:], d[2:])
    cos = np.cos(np.radians([angles[1], TURN_FULL, TURN_NONE]))
    share = (cos[0] - cos[2]) / (cos[1] - cos[2])
    np.testing.assert_allclose(out[1], d[1] + share * (turned(d, a, b)[1] - d[1]), atol=1e-15)
    assert 0 < share < 1
    two = followed(d, a, b, frames=2)
    np.testing.assert_allclose(two[:2], turned(d, a, b)[:2], atol=1e-15)  # within twice the full turn
    assert 0 < np.linalg.norm(two[2] - d[2]) < np.linalg.norm(turned(d, a, b)[2] - d[2])
    np.testing.assert_array_equal(two[3], d[3])


def test_the_nearest_within_a_tight_bound_is_found_for_a_point_alone():
    """One point at a time, its bound barely more than its true nearest distance (a body point
    carried from the last frame that is still the nearest): only the body near that point is
    searched, and what is found is still brute force's nearest."""
    from core.geometry.topology import topology_of
    from core.layering.correspondence import nearest_within

    body = lower_body()[0]
    faces = np.asarray(body.faces, dtype=np.int64)
    vertex_faces = topology_of(faces, len(body.vertices)).vertex_faces
    rng = np.random.default_rng(11)
    p = body.bounds[0] - 0.05 + rng.random((40, 3)) * (np.ptp(body.bounds, axis=0) + 0.1)
    tri = body.triangles
    for q in p:
        dist = np.linalg.norm(trimesh.triangles.closest_point(tri, np.repeat(q[None], len(tri), 0)) - q, axis=1).min()
        found = nearest_within(q[None], [dist * 1.001 + 1e-9], body.vertices, faces, vertex_faces)
        np.testing.assert_allclose(found.distance, [dist], atol=1e-9)


def test_a_body_of_other_vertices_two_frames_back_is_not_read(monkeypatch):
    """The body two frames back had other vertices (a modifier switched on, say) while the garments
    stayed: its normals and vertices are not read with this body's indices (an index past its end
    failed the frame); the bound is then the world's, worked by hand for the patch's centre: JERK
    offsets plus MOTION_SHARE of its centripetal acceleration 2 r (1 - cos 8 deg)."""
    monkeypatch.setattr(frame_coherence, "HOLD", 0.0)  # the bound alone: no band held
    from core.layering.frame_coherence import JERK, MOTION_SHARE, BodyNow, History, eased

    patch, faces = _turning_patch(8.0)
    on = BodyCorrespondence(np.array([0] + list(range(8))), np.vstack([[1.0, 0, 0]] + [[0, 1.0, 0]] * 8), np.zeros(9))
    tiny = np.zeros((3, 3))  # the other body: three vertices
    first = History([np.zeros((9, 3))], [patch[0][0]], tiny, None, tiny)
    second = History([np.zeros((9, 3))], [patch[1][0]], patch[1][1], first, patch[1][0])
    posed, normals = patch[2]
    out, count = eased(posed + 0.002 * normals, posed, 0, second, 0.002, BodyNow(on, normals, faces, posed))
    assert count > 0
    bound = JERK * 0.002 + MOTION_SHARE * 2 * 0.1 * (1 - np.cos(np.radians(8.0)))
    np.testing.assert_allclose(out[0] - posed[0], bound * normals[0], atol=1e-12)

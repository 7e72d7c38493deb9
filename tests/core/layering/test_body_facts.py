"""Body facts kept across calls: the same answers as computing afresh, never stale."""

import numpy as np
import trimesh

from core.geometry.normals import vertex_normals
from core.layering import body_facts as bf_module
from core.layering import resolve_layers
from core.layering.body_facts import body_facts, part_junctions
from core.layering.correspondence import local_radius
from tests.core.layered_cases import body_tube, noisy_sleeves


def test_the_same_body_gives_the_same_facts_and_a_changed_one_new_facts():
    body = body_tube()
    v, f = np.asarray(body.vertices), np.asarray(body.faces)
    facts = body_facts(v, f)
    assert body_facts(v.copy(), f.copy()) is facts  # by content, not identity
    np.testing.assert_array_equal(facts.normals, vertex_normals(v, f))
    np.testing.assert_array_equal(facts.radius, local_radius(v, f))
    moved = v.copy()
    moved[0, 0] += 1e-9
    assert body_facts(moved, f) is not facts
    flipped = f[:, ::-1]  # the same points wound the other way: the faces are in the key
    other = body_facts(v, flipped)
    assert other is not facts
    np.testing.assert_array_equal(other.normals, vertex_normals(v, flipped))
    assert body_facts(v, f.astype(np.int32)) is facts  # Blender's int32 faces: the same body


def test_pieces_are_the_connected_parts_of_the_body_mesh():
    """Three balls, one of them with a vertex no face uses, against trimesh's own labelling."""
    balls = [trimesh.creation.icosphere(subdivisions=2, radius=r).apply_translation((3 * i, 0, 0))
             for i, r in enumerate((1.0, 0.5, 2.0))]
    body = trimesh.util.concatenate(balls)
    v = np.vstack([body.vertices, [[9.0, 9.0, 9.0]]])
    f = np.asarray(body.faces)
    pieces = body_facts(v, f).pieces
    want = trimesh.graph.connected_component_labels(trimesh.Trimesh(v, f, process=False).face_adjacency, len(f))
    on_faces = pieces[f[:, 0]]
    pairs = np.unique(np.column_stack([on_faces, want]), axis=0)
    assert len(pairs) == len(np.unique(want)) == len(np.unique(on_faces)) == 3  # the same partition
    assert len(np.unique(pieces)) == 4 and pieces[-1] not in pieces[f].ravel()
    assert not pieces.flags.writeable


def test_junctions_follow_the_segmentation_they_are_asked_for():
    body = body_tube()
    v, f = np.asarray(body.vertices), np.asarray(body.faces)
    facts = body_facts(v, f)
    halves = (v[:, 2] > np.median(v[:, 2])).astype(np.int64)
    thirds = np.digitize(v[:, 2], np.quantile(v[:, 2], [1 / 3, 2 / 3])).astype(np.int64)
    for seg in (halves, thirds, halves):
        got = facts.junctions(seg)
        want = part_junctions(v, f, seg)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)


def test_junction_distance_is_each_vertex_s_nearest_junction_of_its_own_part_by_brute_force():
    body = body_tube()
    v, f = np.asarray(body.vertices), np.asarray(body.faces)
    facts = body_facts(v, f)
    # three parts by height, and one part (3) with no junction at all: a lone band of ids
    seg = np.digitize(v[:, 2], np.quantile(v[:, 2], [1 / 3, 2 / 3])).astype(np.int64)
    rng = np.random.default_rng(2)
    for s in (seg, np.where(seg == 2, 3, seg)):
        # asked a few vertices first (with repeats), then all: the kept ones agree with the fresh ones
        some = rng.integers(0, len(v), 50)
        first = facts.junction_distance(s, some)
        got = facts.junction_distance(s, np.arange(len(v)))
        np.testing.assert_array_equal(first, got[some])
        pos, own, _ = facts.junctions(s)
        want = np.full(len(v), np.inf)
        for i in range(len(v)):
            mine = pos[own == s[i]]
            if len(mine):
                want[i] = np.linalg.norm(mine - v[i], axis=1).min()
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)


def test_border_parts_are_the_same_with_the_lower_bound_that_skips_far_points():
    """border_segment with a lower bound on each point's junction distance (here the exact one,
    the tightest, so points at the reach's edge are skipped or asked by a hair) against without."""
    from core.layering.garment_prep import border_segment

    rng = np.random.default_rng(3)
    pos = rng.uniform(-1, 1, (60, 3))
    own, other = rng.integers(0, 3, 60), rng.integers(3, 5, 60)
    points = rng.uniform(-1.2, 1.2, (4000, 3))
    primary, distance = rng.integers(0, 4, 4000), rng.uniform(0, 0.2, 4000)  # part 3 has no junction
    exact = np.array([np.linalg.norm(pos[own == p] - x, axis=1).min() if (own == p).any() else np.inf
                      for x, p in zip(points, primary, strict=True)])
    plain = border_segment(points, distance, primary, (pos, own, other), 0.05)
    bounded = border_segment(points, distance, primary, (pos, own, other), 0.05, lower=exact)
    np.testing.assert_array_equal(bounded, plain)
    assert (plain >= 0).sum() > 100 and (plain < 0).sum() > 100  # both kinds of answer are there
    # a bound that is not one (too large) would drop answers: the test can tell
    assert (border_segment(points, distance, primary, (pos, own, other), 0.05, lower=exact + 0.1) != plain).any()


def test_a_resolve_with_kept_facts_equals_one_from_scratch():
    body = body_tube()
    garments = list(noisy_sleeves(n=30))
    first = resolve_layers(body, garments)
    bf_module.BODIES.clear()
    again = resolve_layers(body, garments)
    for a, b in zip(first.garments, again.garments, strict=True):
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)


def test_part_radius_is_each_parts_radius_and_nan_for_a_part_without_vertices():
    """Two balls of 10 cm and 4 cm as parts 0 and 1: half the chord through a ball's centre is
    its radius; part 2 has no vertex of its own."""
    big = trimesh.creation.icosphere(subdivisions=4, radius=0.1)
    small = trimesh.creation.icosphere(subdivisions=4, radius=0.04)
    v = np.vstack([big.vertices, small.vertices + [0.5, 0.0, 0.0]])
    f = np.vstack([big.faces, small.faces + len(big.vertices)])
    parts = np.repeat([0, 1], [len(big.vertices), len(small.vertices)])
    got = body_facts(v, f).part_radius(parts, 3)
    np.testing.assert_allclose(got[:2], [0.1, 0.04], rtol=0.01)
    assert np.isnan(got[2])


def test_probe_lengths_give_a_part_without_vertices_its_linked_parts_farthest_reach():
    """The balls of 10 cm and 4 cm as parts 0 and 1; part 2 (a skirt) is linked to both,
    part 3 to neither: it takes the median over the body, halfway between the two radii
    (both balls have as many vertices). Overrides replace defaults, NaN keeps them."""
    big = trimesh.creation.icosphere(subdivisions=4, radius=0.1)
    small = trimesh.creation.icosphere(subdivisions=4, radius=0.04)
    v = np.vstack([big.vertices, small.vertices + [0.5, 0.0, 0.0]])
    f = np.vstack([big.faces, small.faces + len(big.vertices)])
    parts = np.repeat([0, 1], [len(big.vertices), len(small.vertices)])
    links = np.eye(4, dtype=bool)
    links[2, :2] = links[:2, 2] = True
    facts = body_facts(v, f)
    np.testing.assert_allclose(facts.probe_lengths(parts, 4, links), [0.1, 0.04, 0.1, 0.07], rtol=0.01)
    got = facts.probe_lengths(parts, 4, links, given=np.array([np.nan, 0.02, 0.03, np.nan]))
    np.testing.assert_allclose(got, [0.1, 0.02, 0.03, 0.07], rtol=0.01)


def test_junctions_of_parts_modelled_apart_are_the_vertices_near_the_other_parts_surface():
    """Three balls overlapping a little, each its own part and its own mesh: a vertex is a
    junction exactly where the other balls' surface is within half an edge (brute force)."""
    balls = [trimesh.creation.icosphere(subdivisions=3, radius=r) for r in (0.1, 0.08, 0.09)]
    for ball, x in zip(balls, (0.0, 0.17, 0.085), strict=True):
        ball.apply_translation([x, 0.0, 0.16 if x == 0.085 else 0.0])
    v = np.vstack([b.vertices for b in balls])
    f = np.vstack([b.faces + sum(len(c.vertices) for c in balls[:i]) for i, b in enumerate(balls)])
    seg = np.repeat(np.arange(3), [len(b.vertices) for b in balls])
    e = np.vstack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    reach = 0.5 * np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1).mean()  # each edge twice: the same mean
    pos, own, other = part_junctions(v, f, seg)
    got = set(zip(map(tuple, np.round(pos, 12)), own.tolist(), other.tolist(), strict=True))
    want = set()
    for p in range(3):
        for q in range(3):
            if p != q:
                _, dist, _ = trimesh.proximity.closest_point(balls[q], balls[p].vertices)
                want |= {(tuple(np.round(x, 12)), p, q) for x in balls[p].vertices[dist <= reach]}
    assert len(want) > 20
    assert got == want


def _same_result(got, want):
    for a, b in zip(got.garments, want.garments, strict=True):
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)
    for a, b in zip(got.global_normals, want.global_normals, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(got.segments, want.segments, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(got.correspondence, want.correspondence, strict=True):
        np.testing.assert_array_equal(a.triangle, b.triangle)
        np.testing.assert_array_equal(a.bary, b.bary)


def _from_scratch(body, garments, **params):
    bf_module.BODIES.clear()
    return resolve_layers(body, garments, **params)


def test_the_same_garments_resolved_again_reuse_what_was_found_and_never_a_stale_answer():
    """A second resolve with another offset skips the body search yet equals one from scratch;
    what the first result handed out may be changed by its caller; a garment changed in place,
    or a setting the search depends on, is found anew."""
    body = body_tube()
    garments = list(noisy_sleeves(n=30))
    first = _from_scratch(body, garments)
    assert first.stats["garments_kept"] == 0
    again = resolve_layers(body, garments, offset=0.004)
    assert again.stats["garments_kept"] == 2
    _same_result(again, _from_scratch(body, garments, offset=0.004))

    # the caller's arrays are its own: scribbling on them changes nothing kept
    resolve_layers(body, garments)
    handed = resolve_layers(body, garments)
    handed.global_normals[0] *= -1
    handed.correspondence[0].bary[:] = 0
    handed.segments[1][:] = 7
    after = resolve_layers(body, garments)
    assert after.stats["garments_kept"] == 2
    _same_result(after, _from_scratch(body, garments))

    # the inner sleeve moved in place (the same array): it is searched again, the outer is kept
    resolve_layers(body, garments)
    garments[0].vertices[:, :2] *= 0.99
    moved = resolve_layers(body, garments)
    assert moved.stats["garments_kept"] == 1
    _same_result(moved, _from_scratch(body, garments))

    resolve_layers(body, garments)
    shorter = resolve_layers(body, garments, probe_distance=0.02)
    assert shorter.stats["garments_kept"] == 0
    _same_result(shorter, _from_scratch(body, garments, probe_distance=0.02))


def test_what_is_kept_of_garments_stays_within_its_memory_budget(monkeypatch):
    body = body_tube()
    garments = list(noisy_sleeves(n=30))
    want = _from_scratch(body, garments)
    one = bf_module.body_facts(body.vertices, body.faces).prepared_kept.held_bytes() // 2
    monkeypatch.setattr(bf_module, "PREPARED_BYTES", int(1.5 * one))  # room for one sleeve, not two
    bf_module.BODIES.clear()
    resolve_layers(body, garments)
    again = resolve_layers(body, garments)
    assert again.stats["garments_kept"] == 1
    _same_result(again, want)
    monkeypatch.setattr(bf_module, "PREPARED_BYTES", 0)
    bf_module.BODIES.clear()
    resolve_layers(body, garments)
    assert resolve_layers(body, garments).stats["garments_kept"] == 0

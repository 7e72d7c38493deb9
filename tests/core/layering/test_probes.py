"""How far probes reach: a part's default widened to where its lower layers' cloth hangs."""

import numpy as np
import trimesh

from core.layering import probes, resolve_layers
from sample_scenes.shapes import Folds, tube
from tests.core.layered_cases import capped_cylinder, mesh


def _thin_legged():
    """A torso (r 15 cm) on two thin legs (r 3 cm at x = -/+9 cm), as S5 parts (a mannequin's)."""
    parts = [capped_cylinder(0.15, 0.5, n=48), capped_cylinder(0.03, 0.5, (-0.09, 0.0), n=48),
             capped_cylinder(0.03, 0.5, (0.09, 0.0), n=48)]
    parts[0].apply_translation([0, 0, 0.75])
    parts[1].apply_translation([0, 0, 0.25])
    parts[2].apply_translation([0, 0, 0.25])
    ids = np.concatenate([np.full(len(p.vertices), s) for p, s in zip(parts, (0, 3, 4), strict=True)])
    return trimesh.util.concatenate(parts), ids


def _loose_trousers(seed=0):
    """Two noisy layers hanging 4-5 cm off a 3 cm leg (the part's default reach: its radius): they
    cross each other beyond the reach."""
    rng = np.random.default_rng(seed)
    out = []
    for r in (0.072, 0.075):
        v, f = tube(r, 0.05, 0.45, grid=(48, 16), folds=Folds(0.006, rng, floor=0.068))
        out.append(mesh(v + [0.09, 0, 0], f))
    return out


def test_a_thin_parts_reach_widens_to_its_lower_layers_farthest_point(monkeypatch):
    """The left leg's default reach is its radius (3 cm); the lower trouser layer hangs up to 5 cm
    off it. The reach becomes that layer's farthest distance from the body (trimesh's exact closest
    points, the reference) plus the gap, no more than WIDEST times the default; then no point of it
    lies beyond the reach. The right leg (nothing on it) and a reach the caller gave stay."""
    body, parts = _thin_legged()
    trousers = _loose_trousers()
    _, dist, _ = trimesh.proximity.closest_point(body, trousers[0].vertices)
    monkeypatch.setattr(probes, "WIDEST", 1.0)  # the body's measure alone
    narrow = resolve_layers(body, trousers, body_segments=parts, scheme="S5")
    assert narrow.stats["probe_distance"][4] < dist.max()
    monkeypatch.undo()
    wide = resolve_layers(body, trousers, body_segments=parts, scheme="S5")
    reach = wide.stats["probe_distance"]
    gap = wide.stats["offset"]  # the gap between layers: the offset d, with no outward shells
    assert abs(reach[4] - min(dist.max() + gap, probes.WIDEST * narrow.stats["probe_distance"][4])) < 1e-9
    assert reach[3] == narrow.stats["probe_distance"][3]  # the right leg wears nothing
    assert wide.stats["vertices_far_from_body"] == 0
    given = resolve_layers(body, trousers, body_segments=parts, scheme="S5", probe_distance=0.02)
    assert given.stats["probe_distance"][4] == 0.02



def test_the_render_engine_reaches_as_far_as_the_resolve():
    """One rule: on the thin leg in loose trousers the render engine's probes take the reach the
    resolve takes, widened the same way, point for point (both read the part at the nearest
    surface point); the right leg (no cloth) and the torso keep their radius in both; a reach
    the caller gave is the reach."""
    body, parts = _thin_legged()
    trousers = _loose_trousers()
    resolved = resolve_layers(body, trousers, body_segments=parts, scheme="S5")
    reach = resolved.stats["probe_distance"]
    objects = [(body.vertices, body.faces)] + [(t.vertices, t.faces) for t in trousers]
    on_s5 = probes.BodyParts(parts, "S5")
    engine = probes.body_probes(objects, [0, 1, 2], parts=on_s5, traced=[True, True, False],
                                gap=resolved.stats["offset"])
    np.testing.assert_array_equal(engine[1], np.asarray(reach)[resolved.segments[0]])
    assert engine[1].min() > 1.3 * resolved.stats["probe_distance"][3]  # widened past the leg's radius
    np.testing.assert_allclose(engine[0][parts == 3], reach[3], rtol=1e-9)
    np.testing.assert_allclose(engine[0][parts == 0], reach[0], rtol=1e-9)
    given = probes.body_probes(objects, [0, 1, 2], given=np.full(len(reach), 0.02), parts=on_s5,
                               traced=[True, True, False])
    np.testing.assert_array_equal(given[1], 0.02)


def test_the_render_engines_default_gap_is_the_resolves_with_the_arms_spread():
    """Given no gap, the engine widens the thin leg's reach by the resolve's default offset: on the
    mannequin with its arms spread 1.4 m wide (its box then outgrows what its skin spans, so
    the body's size is the skin's, parameters.body_size), point for point the resolve's reach."""
    from core.geometry.vectors import size_of
    from core.layering.parameters import OFFSET_SHARE

    body, parts = _thin_legged()
    arms = []
    for side in (-1, 1):
        arm = capped_cylinder(0.03, 0.5, n=24)
        arm.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
        arm.apply_translation([side * 0.45, 0.0, 0.95])
        arms.append(arm)
    spread = trimesh.util.concatenate([body, *arms])
    ids = np.concatenate([parts, np.full(len(arms[0].vertices), 1), np.full(len(arms[1].vertices), 2)])
    trousers = _loose_trousers()
    resolved = resolve_layers(spread, trousers, body_segments=ids, scheme="S5")
    assert resolved.stats["offset"] < 0.95 * OFFSET_SHARE * size_of(spread.vertices)
    objects = [(spread.vertices, spread.faces)] + [(t.vertices, t.faces) for t in trousers]
    engine = probes.body_probes(objects, [0, 1, 2], parts=probes.BodyParts(ids, "S5"), traced=[True, True, False])
    np.testing.assert_array_equal(engine[1], np.asarray(resolved.stats["probe_distance"])[resolved.segments[0]])


def test_a_points_part_and_radius_are_read_at_its_nearest_body_point():
    """Against brute force: trimesh's exact closest points (triangle and point), their
    barycentric weights, the part of the corner with the largest, the radius blended by them.
    Points scattered round a torso on two legs, where the parts meet too."""
    from core.layering.body_facts import body_facts

    body, parts = _thin_legged()
    rng = np.random.default_rng(5)
    points = body.vertices[rng.integers(0, len(body.vertices), 600)] + rng.normal(scale=0.02, size=(600, 3))
    facts = body_facts(body.vertices, body.faces)
    found = probes.nearest_part(facts, points, np.zeros((0, 3), np.int64), parts, None)
    closest, distance, triangle = trimesh.proximity.closest_point(body, points)
    bary = trimesh.triangles.points_to_barycentric(body.triangles[triangle], closest)
    corner = body.faces[triangle, np.argmax(bary, axis=1)]
    # no tie: the largest weight clear of the next, and no other part's triangles as near (the
    # legs' caps lie inside the torso, where two parts' surfaces can be equally near)
    other = np.full(len(points), np.inf)
    for p in np.unique(parts):
        own = np.flatnonzero(parts[body.faces[:, 0]] == p)
        near = trimesh.proximity.closest_point(body.submesh([own], append=True), points)[1]
        other = np.where(parts[corner] != p, np.minimum(other, near), other)
    weights = np.sort(bary, axis=1)
    clear = (weights[:, -1] - weights[:, -2] > 1e-6) & (other - distance > 1e-6)
    np.testing.assert_array_equal(found.part[clear], parts[corner][clear])
    assert clear.mean() > 0.95
    np.testing.assert_allclose(found.distance, distance, atol=1e-5)  # the pick is float32 (fcpw)
    radius = np.einsum("ij,ij->i", bary, facts.radius[body.faces[triangle]])
    np.testing.assert_allclose(found.radius[clear], radius[clear], atol=1e-6)
    again = probes.nearest_part(facts, points, np.zeros((0, 3), np.int64), parts, None)
    assert again is found  # kept for the next frame of what did not move

"""How far probes reach: a part's default widened to where its lower layers' cloth hangs."""

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from core.layering import probes, resolve_layers
from sample_scenes.shapes import tube
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
        v, f = tube(r, 0.05, 0.45, n_around=48, n_along=16, noise=0.006, rng=rng, min_radius=0.068)
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
    """One rule: on the thin leg in loose trousers the render engine's probes (nearest body vertex)
    take the part's reach the resolve takes (nearest surface point), widened the same way, within
    the body's longest edge (the two nearest points' distances differ by less); the right leg
    (no cloth) and the torso keep their radius in both; a reach the caller gave is the reach."""
    body, parts = _thin_legged()
    trousers = _loose_trousers()
    resolved = resolve_layers(body, trousers, body_segments=parts, scheme="S5")
    reach = resolved.stats["probe_distance"]
    objects = [(body.vertices, body.faces)] + [(t.vertices, t.faces) for t in trousers]
    engine = probes.body_probes(objects, [0, 1, 2], parts=parts, scheme="S5", traced=[True, True, False],
                                gap=resolved.stats["offset"])
    # how much farther a trouser point's nearest body vertex is than its nearest surface point
    # (trimesh's exact closest points and a k-d tree: the references)
    _, surface, _ = trimesh.proximity.closest_point(body, trousers[0].vertices)
    vertex = cKDTree(body.vertices).query(trousers[0].vertices)[0]
    np.testing.assert_allclose(engine[1], reach[4], atol=(vertex - surface).max() + 1e-9)  # the left leg's
    assert engine[1].min() > 1.3 * resolved.stats["probe_distance"][3]  # widened past the leg's radius
    np.testing.assert_allclose(engine[0][parts == 3], reach[3], rtol=1e-9)
    np.testing.assert_allclose(engine[0][parts == 0], reach[0], rtol=1e-9)
    given = probes.body_probes(objects, [0, 1, 2], given=np.full(len(reach), 0.02), parts=parts, scheme="S5",
                               traced=[True, True, False])
    np.testing.assert_array_equal(given[1], 0.02)

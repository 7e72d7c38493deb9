"""The 3D bell against geometry that does not depend on the code: the analytic volume of the
shell between two half-ellipsoids, the stroke field's symmetry about the axis, and volume
kept through a contraction."""

import numpy as np
import pytest

from core.jellyfish import bell3d, default_config, default_creature
from core.jellyfish.bell import BellShape

SHAPE = BellShape()


def _bell(model):
    faces = [f for f in model.faces if max(f) < model.bell_vertices]
    return model.verts[:model.bell_vertices], faces


def test_the_turned_bell_converges_to_the_analytic_shell_volume_at_second_order():
    exact = 2.0 / 3.0 * np.pi * 0.05**2 * (SHAPE.height - SHAPE.inner_height)
    assert bell3d.exact_volume(SHAPE) == pytest.approx(exact, rel=1e-15)
    errors = []
    for n in (16, 32, 64):
        v, f = _bell(bell3d.build(SHAPE, bell3d.Anatomy(segments=2 * n, per_curve=n, velum=0)))
        errors.append(abs(bell3d.volume(v, f) / exact - 1))
    assert errors[-1] < 2e-3
    assert 3.0 < errors[0] / errors[1] < 5.0 and 3.0 < errors[1] / errors[2] < 5.0


def test_the_bell_is_closed_and_outward_and_its_parts_hang_where_they_should():
    model = bell3d.build(SHAPE, bell3d.Anatomy(segments=24, per_curve=10, veins=5, tentacles=7, tentacle_length=2.0))
    v, f = _bell(model)
    edges = {}
    for face in f:
        for a, b in zip(face, face[1:] + face[:1], strict=True):
            edges[(a, b)] = edges.get((a, b), 0) + 1
    # closed and consistently wound: every directed edge once, and its reverse once
    assert all(n == 1 for n in edges.values()) and all((b, a) in edges for a, b in edges)
    assert bell3d.volume(v, f) > 0
    assert len(model.veins) == 5 and len(model.tentacles) == 7
    assert min(t[:, 2].min() for t in model.tentacles) == pytest.approx(-2.0 * SHAPE.diameter)
    assert max(np.hypot(c[:, 0], c[:, 1]).max() for c in model.veins) < 0.5 * SHAPE.diameter
    with pytest.raises(ValueError, match="segments"):
        bell3d.revolve(np.array([[0, 1.0], [1, 0], [0, 0.5]]), 2)
    with pytest.raises(ValueError, match="axis"):
        bell3d.revolve(np.array([[0.1, 1.0], [1, 0], [0, 0.5]]), 8)


def test_the_stroke_field_moves_the_controls_as_in_2d_and_is_symmetric_about_the_axis():
    cfg = default_config()
    creature = default_creature(cfg)
    field = bell3d.StrokeField(SHAPE, creature, 0.5 * cfg.box, angles=8)
    q, d = creature.controls, creature.destinations - creature.controls
    for phi in (0.0, np.pi / 4, 3 * np.pi / 4):
        c, s = np.cos(phi), np.sin(phi)
        at = np.column_stack([q[:, 0] * c, q[:, 0] * s, q[:, 1]])
        want = np.column_stack([d[:, 0] * c, d[:, 0] * s, d[:, 1]])
        assert np.allclose(field(at), want, atol=1e-9 * SHAPE.diameter)
    rng = np.random.default_rng(0)
    p = rng.uniform(-0.05, 0.05, (50, 3))
    turn = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])  # a quarter turn maps the 8 angles onto themselves
    assert np.allclose(field(p @ turn.T), field(p) @ turn.T, atol=1e-9 * SHAPE.diameter)
    apex = np.array([[0, 0, SHAPE.height], [0, 0, SHAPE.inner_height]])
    assert np.abs(field(apex)).max() < 1e-9 * SHAPE.diameter


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_a_normal_offset_gives_back_the_rest_volume_through_the_contraction(scale):
    cfg = default_config()
    v, f = _bell(bell3d.build(SHAPE, bell3d.Anatomy(segments=32, per_curve=12, velum=0)))
    field = bell3d.StrokeField(SHAPE, default_creature(cfg), 0.5 * cfg.box)
    normals = bell3d.vertex_normals(v, f)
    rest = bell3d.volume(v * scale, f)
    moved = (v + field(v)) * scale
    assert bell3d.volume(moved, f) < 0.9 * rest  # the bare space map squeezes the mesoglea
    t = bell3d.volume_offset(moved, f, normals, rest)
    assert 0 < t < 0.1 * SHAPE.diameter * scale
    assert bell3d.volume(moved + t * normals, f) == pytest.approx(rest, rel=1e-9)

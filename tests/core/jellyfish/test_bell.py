"""The bell's contour, contraction phase, space map and fold check against closed forms."""

import numpy as np
import pytest

from core.jellyfish.bell import (
    BellMap,
    BellShape,
    Creature,
    check_folds,
    contour,
    mirrored,
    phase,
    polygon_area,
    resample,
    self_intersections,
)

SHAPE = BellShape()
BOX = 0.10


def test_contour_lies_on_the_two_ellipses():
    p, left = contour(SHAPE)
    assert len(p) == SHAPE.nodes
    a = SHAPE.diameter / 2
    np.testing.assert_allclose(p[0], [a, 0], atol=1e-15)
    np.testing.assert_allclose(p[left], [-a, 0], atol=1e-15)
    up, low = p[:left + 1], p[left + 1:]
    np.testing.assert_allclose((up[:, 0] / a) ** 2 + (up[:, 1] / SHAPE.height) ** 2, 1.0, atol=1e-12)
    np.testing.assert_allclose((low[:, 0] / a) ** 2 + (low[:, 1] / SHAPE.inner_height) ** 2, 1.0, atol=1e-12)
    # counter-clockwise, area close to the crescent's pi a (H - h) / 2
    want = np.pi * a * (SHAPE.height - SHAPE.inner_height) / 2
    assert polygon_area(p) == pytest.approx(want, rel=0.01)
    assert self_intersections(p) == 0


def test_phase_rises_then_falls_smoothly():
    c = 0.3
    assert phase(0.0, c) == pytest.approx(0.0)
    assert phase(c, c) == pytest.approx(1.0)
    assert phase(1.0, c) == pytest.approx(0.0, abs=1e-12)
    t = np.linspace(0, 1, 2001)
    s = phase(t, c)
    assert (np.abs(np.diff(s)) < 0.01).all()  # continuous
    assert s.min() >= 0 and s.max() <= 1 + 1e-12
    # zero speed at rest and at full contraction
    h = 1e-6
    for t0 in (h, c):
        assert abs(phase(t0 + h, c) - phase(t0 - h if t0 > h else 0.0, c)) / (2 * h) < 1e-3


def _creature(dx=-0.012, dy=-0.008):
    a = SHAPE.diameter / 2
    ctrl = np.array([[a, 0.0], [0.7 * a, SHAPE.height * np.sqrt(1 - 0.49)]])
    return Creature(ctrl, ctrl + [[dx, dy], [0.3 * dx, 0.3 * dy]], 0.3)


def test_map_moves_controls_to_destinations_and_keeps_anchors():
    cr = _creature()
    m = BellMap(SHAPE, cr, BOX)
    q, d = mirrored(cr.controls), mirrored(cr.destinations)
    np.testing.assert_allclose(q + m.displacement_at(q, 1.0), d, atol=1e-12)
    np.testing.assert_allclose(q + m.displacement_at(q, 0.5), 0.5 * (q + d), atol=1e-12)
    fixed = m.centers[:10]
    np.testing.assert_allclose(m.displacement_at(fixed, 1.0), 0.0, atol=1e-12)
    # mirror symmetric: x -> -x maps to the mirrored displacement
    p, _ = contour(SHAPE)
    np.testing.assert_allclose(m.displacement_at(p * [-1, 1], 1.0), m.displacement_at(p, 1.0) * [-1, 1], atol=1e-12)
    assert m.bending_energy() > 0
    assert check_folds(SHAPE, m) is None


@pytest.mark.parametrize("s", [0.0, 0.3, 1.0])
def test_rest_of_undoes_the_map(s):
    m = BellMap(SHAPE, _creature(), BOX)
    p, _ = contour(SHAPE)
    rest = p * 0.9 + [0.0, 0.002]  # points inside the bell as well as on it
    np.testing.assert_allclose(m.rest_of(rest + m.displacement_at(rest, s), s), rest, atol=1e-12)


def test_no_deformation_no_energy():
    m = BellMap(SHAPE, _creature(0.0, 0.0), BOX)
    assert abs(m.bending_energy()) < 1e-15
    assert np.abs(m.displacement_at(contour(SHAPE)[0], 1.0)).max() < 1e-15


def test_a_margin_pulled_through_the_bell_is_refused():
    reason = check_folds(SHAPE, BellMap(SHAPE, _creature(-0.005, 0.05), BOX))
    assert reason is not None and ("folds" in reason or "inside out" in reason)


def test_resample_is_even_and_keeps_the_margins():
    fine = BellShape(nodes=400)
    p, left = contour(SHAPE)
    q, qleft = resample(p, 0.002, left)
    np.testing.assert_allclose(q[0], p[0], atol=1e-15)
    np.testing.assert_allclose(q[qleft], p[left], atol=1e-15)
    for curve in (q[:qleft + 1], np.vstack([q[qleft:], q[:1]])):
        gaps = np.linalg.norm(np.diff(curve, axis=0), axis=1)
        assert gaps.max() / gaps.min() < 1.1
        assert gaps.mean() == pytest.approx(0.002, rel=0.1)
    # the spline follows the true ellipse better than the 40-node polygon does
    a = fine.diameter / 2
    up = q[:qleft + 1]
    err = np.abs(np.sqrt((up[:, 0] / a) ** 2 + (up[:, 1] / fine.height) ** 2) - 1).max()
    assert err < 2e-3


@pytest.mark.parametrize("bad", [dict(diameter=0.0), dict(inner_height=0.05), dict(nodes=7), dict(diameter=np.nan)])
def test_bad_shapes_are_refused(bad):
    with pytest.raises(ValueError):
        BellShape(**bad)


def test_bad_creatures_are_refused():
    with pytest.raises(ValueError, match="contraction"):
        Creature(np.zeros((1, 2)), np.zeros((1, 2)), 0.0)
    with pytest.raises(ValueError, match="finite"):
        Creature(np.zeros((1, 2)), np.full((1, 2), np.nan), 0.3)

"""A body's velocity imposed inside the projection (core.jellyfish.body_projection) against the
same constrained problem solved densely: the projection applied to every unit value on the body
assembles the operator, scipy's least squares solves it."""

import numpy as np
import pytest
from scipy.linalg import lstsq, null_space

from core.jellyfish.body_projection import ImposedBody, project_with_body
from core.jellyfish.fluid_box import Box, Liquid
from core.jellyfish.particle_fluid import LatticeFluid


def disc_in_a_swirl(nx=24):
    f = LatticeFluid(Box(1.0, 1.0, periodic=(True, True)), nx=nx, liquid=Liquid(viscosity=1e-3, density=1.0))
    x, y = f.points.T
    u = np.column_stack([np.sin(2 * np.pi * y), 0.3 * np.cos(2 * np.pi * x)])  # off the body: a shear flow
    disc = np.linalg.norm(f.points - [0.5, 0.45], axis=1) < 0.16
    # the body's own motion: a swelling and a spin (divergent: no field takes it exactly)
    rel = f.points[disc] - [0.5, 0.45]
    own = 0.4 * rel + 0.7 * np.column_stack([-rel[:, 1], rel[:, 0]])
    return f, u, disc, own


def dense_answer(f, u, body, dt):
    """The constrained least squares assembled column by column: the body's values g (2k), with a
    free speed U, make the projected field's values on the body nearest the body's velocity
    (+ U), g keeping the momentum exactly (g = a particular solution + scipy's null space of the
    momentum row)."""
    project = lambda v: f.project(v, dt)[0]  # noqa: E731
    mask, k, free = body.mask, int(body.mask.sum()), body.free_axis
    base = u.copy()
    base[mask] = 0.0
    vol = f.volume[mask]
    cols = []
    for j in range(2 * k):
        e = np.zeros((f.n, 2))
        e[np.flatnonzero(mask)[j // 2], j % 2] = 1.0
        cols.append(project(e)[mask].ravel())
    s = np.array(cols).T
    b = (body.velocity - project(base)[mask]).ravel()
    if free is None:
        g = lstsq(s, b)[0]
        speed = 0.0
    else:
        row = np.zeros((k, 2))
        row[:, free] = vol / vol.sum()
        particular = np.zeros((k, 2))
        particular[:, free] = (body.momentum - base[:, free] @ f.volume) / vol.sum()
        null = null_space(row.ravel()[None])
        axis = np.zeros((k, 2))
        axis[:, free] = -1.0
        x = lstsq(np.column_stack([s @ null, axis.ravel()]), b - s @ particular.ravel())[0]
        g, speed = particular.ravel() + null @ x[:-1], x[-1]
    field = base.copy()
    field[mask] = g.reshape(k, 2)
    return project(field), speed


@pytest.mark.parametrize("free", [None, 1])
def test_corrections_converge_to_the_dense_constrained_projection(free):
    f, u, disc, own = disc_in_a_swirl()
    momentum = float(u[:, 1] @ f.volume)
    body = ImposedBody(disc, own, free_axis=free, momentum=momentum)
    exact_u, exact_speed = dense_answer(f, u, body, 0.01)
    project = lambda v: f.project(v, 0.01)  # noqa: E731
    runs = [project_with_body(project, u, body, f.volume, c) for c in (0, 1, 2, 4, 8, 40)]
    errors = [np.abs(r.u - exact_u).max() for r in runs]
    # each correction is a GMRES step on the bordered system: the miss never grows, and
    # the field reaches the dense answer
    misses = [r.miss for r in runs]
    assert all(b <= a * (1 + 1e-9) for a, b in zip(misses, misses[1:], strict=False))
    assert errors[1] < 0.6 * errors[0] and errors[-1] < 1e-6 * np.abs(exact_u).max()
    assert abs(runs[-1].speed - exact_speed) < 1e-6
    # the miss reported is the field's distance on the body from the body's velocity, its free speed included
    for r in runs:
        wanted = own.copy()
        if free is not None:
            wanted[:, free] += r.speed
        assert r.miss == pytest.approx(np.abs(r.u[body.mask] - wanted).max(), rel=1e-12, abs=1e-15)
    if free is not None:  # the water's and the body's momentum along the axis is kept by every answer
        for r in runs:
            assert r.u[:, 1] @ f.volume == pytest.approx(momentum, abs=1e-12)


def test_a_body_the_field_already_carries_costs_no_correction():
    # a divergence-free field already equal to the body's velocity on it: the answer is itself
    f, _, disc, _ = disc_in_a_swirl()
    x, y = f.points.T
    u = np.column_stack([np.sin(2 * np.pi * y), np.cos(2 * np.pi * x)])
    r = project_with_body(lambda v: f.project(v, 0.01), u, ImposedBody(disc, u[disc]), f.volume, 4)
    assert np.abs(r.u - u).max() < 1e-10 and r.miss < 1e-10


def test_an_empty_body_is_the_plain_projection():
    f, u, disc, _ = disc_in_a_swirl()
    empty = np.zeros(f.n, bool)
    r = project_with_body(lambda v: f.project(v, 0.01), u, ImposedBody(empty, np.zeros((0, 2)), 1), f.volume, 3)
    np.testing.assert_allclose(r.u, f.project(u, 0.01)[0], atol=1e-14)


def test_bad_corrections_are_refused():
    f, u, disc, own = disc_in_a_swirl(8)
    with pytest.raises(ValueError, match="corrections"):
        project_with_body(lambda v: f.project(v, 0.01), u, ImposedBody(disc, own), f.volume, -1)
    with pytest.raises(ValueError, match="tolerance"):
        project_with_body(lambda v: f.project(v, 0.01), u, ImposedBody(disc, own), f.volume, 4, tolerance=0.0)


@pytest.mark.parametrize("free", [None, 1])
def test_corrections_stop_at_the_tolerance_and_no_sooner(free):
    """To a tolerance, the corrections stop at the first GMRES iteration whose field meets the
    body's velocity to that share of its fastest speed imposed (root mean square over the body's
    values, measured on the field returned): the same field as that many fixed corrections, one
    fewer not meeting it; a tighter tolerance takes more and lands nearer the dense answer."""
    f, u, disc, own = disc_in_a_swirl()
    momentum = float(u[:, 1] @ f.volume)
    body = ImposedBody(disc, own, free_axis=free, momentum=momentum)
    project = lambda v: f.project(v, 0.01)  # noqa: E731
    exact_u, _ = dense_answer(f, u, body, 0.01)
    # the fastest speed imposed: the body's own motion, plus the free speed its momentum asks at first
    target = own.copy()
    if free is not None:
        vol, off = f.volume[disc], np.where(disc, 0.0, u[:, free])
        target[:, free] += (momentum - off @ f.volume - own[:, free] @ vol) / vol.sum()
    scale = np.abs(target).max()

    def rms_miss(r):
        wanted = own.copy()
        if free is not None:
            wanted[:, free] += r.speed
        return np.sqrt(np.mean((r.u[disc] - wanted) ** 2))

    taken, errors = [], []
    for tolerance in (0.05, 0.005):
        r = project_with_body(project, u, body, f.volume, 40, tolerance=tolerance)
        same = project_with_body(project, u, body, f.volume, r.corrections)
        fewer = project_with_body(project, u, body, f.volume, r.corrections - 1)
        np.testing.assert_allclose(r.u, same.u, atol=1e-12)
        assert rms_miss(r) <= tolerance * scale * (1 + 1e-9) < rms_miss(fewer)
        taken.append(r.corrections)
        errors.append(np.abs(r.u - exact_u).max())
    assert 0 < taken[0] < taken[1] < 40 and errors[1] < errors[0]

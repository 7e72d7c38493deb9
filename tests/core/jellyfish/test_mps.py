"""MPS particle operators on regular lattices against exact derivatives and the thesis' constants."""

import numpy as np
import pytest
from scipy.integrate import quad

from core.jellyfish.mps import Neighbours, lambda_continuous, lattice, weight

H = 0.01
RE = 2.1 * H


def test_weight_shape():
    assert weight(0.0, RE) == 2.0
    assert weight(0.5 * RE - 1e-12, RE) == pytest.approx(1.0)
    assert weight(0.5 * RE + 1e-12, RE) == pytest.approx(1.0)
    assert weight(RE, RE) == 0.0 and weight(2 * RE, RE) == 0.0


@pytest.mark.parametrize("re", [1.0, 0.3, 2.5])
def test_lambda_is_the_seeds_31_over_140(re):
    """At any radius (a scaling wrong by a power of r_e passes at r_e = 1 only)."""
    num = quad(lambda r: weight(r, re) * r**3, 0, re, points=[0.5 * re])[0]
    den = quad(lambda r: weight(r, re) * r, 0, re, points=[0.5 * re])[0]
    assert lambda_continuous(re) == pytest.approx(num / den, rel=1e-12)


def _interior_lattice(n=20):
    p = lattice(n, n, H)
    nb = Neighbours.build(p, RE)
    inner = np.all((p > RE + 1e-9) & (p < n * H - RE - 1e-9), axis=1)
    n0 = nb.density()[inner][0]
    lam = nb.lam()[inner][0]
    return p, nb, inner, n0, lam


def test_laplacian_of_a_quadratic_is_exact_on_the_lattice():
    p, nb, inner, n0, lam = _interior_lattice()
    phi = 3 * p[:, 0] ** 2 + p[:, 1] ** 2 - p[:, 0] * p[:, 1] + 2 * p[:, 0]
    np.testing.assert_allclose(nb.laplacian(phi, n0, lam)[inner], 8.0, rtol=1e-10)
    # the matrix form is the same operator
    np.testing.assert_allclose(nb.laplacian_matrix(n0, lam) @ phi, nb.laplacian(phi, n0, lam), rtol=1e-12, atol=1e-9)
    # vector values go column by column
    both = nb.laplacian(np.column_stack([phi, 2 * phi]), n0, lam)
    np.testing.assert_allclose(both[:, 1], 2 * both[:, 0], rtol=1e-12)


def test_gradient_and_divergence_of_linear_fields_are_exact():
    p, nb, inner, n0, _ = _interior_lattice()
    phi = 2.5 * p[:, 0] - 4.0 * p[:, 1] + 1.0
    np.testing.assert_allclose(nb.gradient(phi, n0)[inner], np.tile([2.5, -4.0], (inner.sum(), 1)), rtol=1e-10)
    u = np.column_stack([3 * p[:, 0] + p[:, 1], 2 * p[:, 0] - 7 * p[:, 1]])
    np.testing.assert_allclose(nb.divergence(u, n0)[inner], -4.0, rtol=1e-10)


def test_periodic_derivatives_converge_at_second_order():
    errs = []
    for n in (16, 32, 64):
        h = 1.0 / n
        p = lattice(n, n, h)
        nb = Neighbours.build(p, 2.1 * h, box=(1.0, 1.0))
        n0, lam = nb.density()[0], nb.lam()[0]
        k = 2 * np.pi
        phi = np.sin(k * p[:, 0]) * np.cos(k * p[:, 1])
        lap = nb.laplacian(phi, n0, lam)
        grad = nb.gradient(phi, n0)
        errs.append((np.abs(lap + 2 * k * k * phi).max() / (2 * k * k),
                     np.abs(grad[:, 0] - k * np.cos(k * p[:, 0]) * np.cos(k * p[:, 1])).max() / k))
    errs = np.array(errs)
    rates = np.log2(errs[:-1] / errs[1:])
    assert (rates > 1.8).all(), rates


def test_variable_radius_makes_an_unsymmetric_matrix():
    p = lattice(8, 8, H)
    re = np.full(len(p), RE)
    re[:8] = 3.1 * H
    nb = Neighbours.build(p, re)
    m = nb.laplacian_matrix(nb.density().max(), lambda_continuous(RE))
    assert abs(m - m.T).max() > 0


def test_blocked_pairs_do_not_interact():
    p = lattice(6, 6, H)
    left = p[:, 0] < 3 * H
    nb = Neighbours.build(p, RE, blocked=lambda i, j: left[i] != left[j])
    assert (left[nb.i] == left[nb.j]).all()


def test_shepard_keeps_constants_and_interior_linear_fields():
    p, nb, inner, _, _ = _interior_lattice()
    np.testing.assert_allclose(nb.shepard(np.full(len(p), 3.0)), 3.0)
    lin = np.column_stack([p[:, 0], 2 * p[:, 1]])
    np.testing.assert_allclose(nb.shepard(lin)[inner], lin[inner], atol=1e-12)


def test_bad_radius_is_refused():
    with pytest.raises(ValueError, match="r_e"):
        Neighbours.build(lattice(3, 3, H), 0.0)

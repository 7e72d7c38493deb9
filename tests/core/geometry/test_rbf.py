"""core.rbf.VolumeSpline against scipy's RBFInterpolator, the thesis' bending-energy matrix
formed explicitly, and affine maps it must reproduce exactly."""

import numpy as np
import pytest
from scipy.interpolate import RBFInterpolator

from core.geometry.rbf import VolumeSpline

SCIPY_EPS = {"gaussian": 1.3}


def _case(dim, n=60, m=2, seed=0):
    rng = np.random.default_rng(seed)
    c = rng.uniform(-1.0, 1.0, (n, dim))
    v = np.column_stack([np.sin(2 * c[:, 0]) + c[:, -1] ** 2, np.cos(c.sum(1))])[:, :m]
    q = rng.uniform(-1.2, 1.2, (200, dim))
    return c, v, q


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kernel", ["thin_plate_spline", "cubic", "gaussian"])
def test_equals_scipy(dim, kernel):
    c, v, q = _case(dim)
    eps = SCIPY_EPS.get(kernel)
    ours = VolumeSpline(c, v, kernel=kernel, epsilon=eps)(q)
    ref = RBFInterpolator(c, v, kernel=kernel, degree=1, epsilon=eps or 1.0)(q)
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-8 * np.abs(ref).max())
    # and it interpolates
    np.testing.assert_allclose(VolumeSpline(c, v, kernel=kernel, epsilon=eps)(c), v, atol=1e-9)


def test_scalar_values_keep_their_shape():
    c, v, q = _case(2)
    out = VolumeSpline(c, v[:, 0])(q)
    assert out.shape == (len(q),)


@pytest.mark.parametrize("kernel", ["thin_plate_spline", "cubic"])
def test_bending_energy_is_the_seeds_matrix_form(kernel):
    c, v, _ = _case(2, n=25)
    n = len(c)
    r = np.linalg.norm(c[:, None] - c[None], axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(r > 0, r * r * np.log(r), 0.0) if kernel == "thin_plate_spline" else r**3
    b = np.hstack([np.ones((n, 1)), c])
    t = np.block([[a, b], [b.T, np.zeros((3, 3))]])
    omega = np.linalg.inv(t)[:n, :n]  # "the inverse N x N upper left submatrix of T"
    want = sum(v[:, k] @ omega @ v[:, k] for k in range(v.shape[1]))
    got = VolumeSpline(c, v, kernel=kernel).bending_energy()
    assert got > 0
    assert got == pytest.approx(want, rel=1e-8)


@pytest.mark.parametrize("dim", [2, 3])
def test_affine_map_has_zero_energy_and_is_reproduced(dim):
    rng = np.random.default_rng(3)
    c = rng.normal(size=(30, dim))
    m, t = rng.normal(size=(dim, dim)), rng.normal(size=dim)
    s = VolumeSpline(c, c @ m.T + t)
    q = rng.normal(size=(100, dim)) * 3
    np.testing.assert_allclose(s(q), q @ m.T + t, atol=1e-9)
    assert abs(s.bending_energy()) < 1e-12


@pytest.mark.parametrize("scale", [1e-3, 1e3, 1e-6, 1e6])
def test_any_scale_gives_the_same_map(scale):
    c, v, q = _case(2, n=40)
    unit = VolumeSpline(c, v)
    scaled = VolumeSpline(c * scale + 7 * scale, v * scale)
    np.testing.assert_allclose(scaled(q * scale + 7 * scale), unit(q) * scale, rtol=0,
                               atol=1e-9 * scale * np.abs(unit(q)).max())
    # thin-plate bending energy of values scaled like the coordinates is unchanged
    assert scaled.bending_energy() == pytest.approx(unit.bending_energy(), rel=1e-7)


def test_coincident_centres_with_equal_values_are_merged():
    c, v, q = _case(2, n=30)
    c2, v2 = np.vstack([c, c[:5]]), np.vstack([v, v[:5]])
    s = VolumeSpline(c2, v2)
    assert s.merged == 5
    np.testing.assert_allclose(s(q), VolumeSpline(c, v)(q), atol=1e-10)


@pytest.mark.parametrize("column", [0, 1])
def test_coincident_centres_with_different_values_are_refused(column):
    """Values that differ in every column, or in one only: either is a contradiction."""
    c, v, _ = _case(2, n=30)
    with pytest.raises(ValueError, match="coincide"):
        VolumeSpline(np.vstack([c, c[:1]]), np.vstack([v, v[:1] + 1.0]))
    other = v[:1].copy()
    other[0, column] += 1.0
    with pytest.raises(ValueError, match="coincide"):
        VolumeSpline(np.vstack([c, c[:1]]), np.vstack([v, other]))


def test_collinear_and_coplanar_centres_are_refused():
    t = np.linspace(0, 1, 10)
    with pytest.raises(ValueError, match="one line"):
        VolumeSpline(np.column_stack([t, 2 * t + 1]), t)
    rng = np.random.default_rng(1)
    uv = rng.normal(size=(20, 2))
    plane = uv @ np.array([[1.0, 0.0, 1.0], [0.0, 1.0, -2.0]])
    with pytest.raises(ValueError, match="one plane"):
        VolumeSpline(plane, uv[:, 0])


def test_a_thin_but_valid_set_of_centres_is_accepted_and_interpolates():
    """Centres along a line bent off it by 1e-5 of their spread (a bell's margin nearly straight):
    the linear part is determined, the spline goes through every value and equals scipy's."""
    t = np.linspace(0, 1, 12)
    c = np.column_stack([t, 2 * t + 1 + 1e-5 * np.sin(7 * t)])
    v = np.column_stack([np.cos(3 * t), t ** 2])
    s = VolumeSpline(c, v)
    np.testing.assert_allclose(s(c), v, atol=1e-8)
    q = c[:-1] + 0.5 * np.diff(c, axis=0)
    ref = RBFInterpolator(c, v, kernel="thin_plate_spline", degree=1)(q)
    np.testing.assert_allclose(s(q), ref, atol=1e-6 * np.abs(ref).max())


@pytest.mark.parametrize("bad, match", [
    (dict(centers=np.zeros((2, 2)), values=np.zeros(2)), "at least 3"),
    (dict(centers=np.full((5, 2), np.nan), values=np.zeros(5)), "finite"),
    (dict(centers=np.zeros((5, 4)), values=np.zeros(5)), r"\(N, 2\)"),
    (dict(centers=np.eye(3)[:, :2], values=np.zeros(4)), "values"),
    (dict(centers=np.eye(3)[:, :2], values=np.zeros(3), kernel="multiquadric"), "kernel"),
    (dict(centers=np.eye(3)[:, :2], values=np.zeros(3), kernel="gaussian"), "epsilon"),
])
def test_bad_input_is_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        VolumeSpline(**bad)


def test_thousands_of_centres():
    c, v, q = _case(2, n=3000, seed=5)
    ours = VolumeSpline(c, v)(q)
    ref = RBFInterpolator(c, v, kernel="thin_plate_spline", degree=1)(q)
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-6 * np.abs(ref).max())

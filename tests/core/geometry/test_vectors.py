"""Row-wise vector helpers against numpy's own."""

import numpy as np
import pytest

from core.geometry.vectors import inverse3, matmul3, size_of


def test_the_3x3_inverse_is_numpys_and_a_singular_matrix_is_refused():
    rng = np.random.default_rng(2)
    for _ in range(50):
        m = rng.normal(size=(3, 3)) * rng.uniform(0.01, 100)
        np.testing.assert_allclose(inverse3(m) @ m, np.eye(3), atol=1e-9)
        np.testing.assert_allclose(inverse3(m), np.linalg.inv(m), rtol=1e-7, atol=1e-9 * np.abs(np.linalg.inv(m)).max())
    scale = np.diag([2.0, -3.0, 0.5])
    np.testing.assert_allclose(inverse3(scale), np.diag([0.5, -1 / 3, 2.0]), rtol=1e-15)
    with pytest.raises(np.linalg.LinAlgError):
        inverse3([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 0.0]])


def test_the_rows_times_a_3x3_matrix_are_numpys_product():
    rng = np.random.default_rng(5)
    for n in (0, 1, 7, 20_000):
        v = rng.normal(size=(n, 3)) * rng.uniform(1e-6, 1e6)
        m = rng.normal(size=(3, 3))
        got = matmul3(v, m)
        assert got.shape == (n, 3)
        np.testing.assert_allclose(got, v @ m, rtol=1e-12, atol=1e-12 * (np.abs(v).max(initial=0) + 1))
    # a strided slice and a transposed matrix (the callers' v @ M.T) read as numpy reads them
    big = rng.normal(size=(100, 6))
    m = rng.normal(size=(4, 4))
    np.testing.assert_allclose(matmul3(big[:, 1:4], m[:3, :3].T), big[:, 1:4] @ m[:3, :3].T, rtol=1e-12, atol=1e-12)


def test_the_size_is_the_box_diagonal_in_the_points_own_axes_and_does_not_turn():
    rng = np.random.default_rng(6)
    half = np.array([0.9, 0.25, 0.1])  # a box standing along the axes: its own diagonal
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    np.testing.assert_allclose(size_of(corners), 2 * np.linalg.norm(half), rtol=1e-12)
    pts = rng.normal(size=(5000, 3)) * [3.0, 1.0, 0.2]
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))  # a turn (or a mirror): the size stays
    np.testing.assert_allclose(size_of(pts @ q.T + [5.0, -2.0, 1e3]), size_of(pts), rtol=1e-9)
    # the reference: the points projected on the eigenvectors of their scatter (numpy's own products)
    c = pts - pts.mean(0)
    _, axes = np.linalg.eigh(c.T @ c)
    np.testing.assert_allclose(size_of(pts), np.linalg.norm(np.ptp(c @ axes, axis=0)), rtol=1e-12)
    assert size_of(pts[:1]) == 0.0

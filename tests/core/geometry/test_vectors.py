"""Row-wise vector helpers against numpy's own."""

import numpy as np
import pytest

from core.geometry.vectors import inverse3


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

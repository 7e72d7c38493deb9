"""The column-pass helpers give bit for bit what numpy's broadcast expressions give."""

import numpy as np

from core.vectors import along, divide_rows, norms, shifted


def _rows(n=1000, seed=0):
    rng = np.random.default_rng(seed)
    # magnitudes from 1e-300 to 1e300, signs mixed: any reordering of the arithmetic shows
    return rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-300, 300, size=(n, 1))


def test_helpers_equal_the_broadcast_expressions_exactly():
    v, w = _rows(seed=1), _rows(seed=2)
    t = np.abs(_rows(seed=3)[:, 0])
    centre = np.array([1e10, -3.5, 2e-8])
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        np.testing.assert_array_equal(norms(v), np.linalg.norm(v, axis=1))
        np.testing.assert_array_equal(along(v, w, t), v + w * t[:, None])
        np.testing.assert_array_equal(divide_rows(v, t), v / t[:, None])
        got = shifted(v, centre, np.float32)
        np.testing.assert_array_equal(got, (v - centre).astype(np.float32))
    assert got.dtype == np.float32 and got.flags.c_contiguous
    np.testing.assert_array_equal(shifted(v, centre), v - centre)


def test_helpers_take_strided_and_empty_rows():
    v = _rows(seed=4)[::3]
    t = np.linspace(1.0, 2.0, len(v))
    np.testing.assert_array_equal(along(v, v, t), v + v * t[:, None])
    empty = np.zeros((0, 3))
    assert along(empty, empty, np.zeros(0)).shape == (0, 3)
    assert divide_rows(empty, np.zeros(0)).shape == (0, 3)
    assert shifted(empty, np.zeros(3), np.float32).shape == (0, 3)

"""Row-wise vector helpers for the hot loops.

Why DeformRT works on (n, 3) arrays column by column, here and across core: numpy's reductions
over the short axis of (n, 3) rows (norm, all, any, min, max over axis=1), np.cross, einsum and
gathers of (m, 3, 3) corners go element by element through a generic loop, several times slower
than three operations on contiguous columns; where a column is strided, a contiguous copy first
pays for itself. Where the code below and elsewhere goes column by column, this is why."""

from __future__ import annotations

import numpy as np


def norms(v: np.ndarray) -> np.ndarray:
    """Lengths of the rows of an (n, 3) array: the same numbers as ``np.linalg.norm(v, axis=1)``
    (the same sum, in the same order), several times faster, which its generic reduction is not."""
    v = np.asarray(v)
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


def unit(v: np.ndarray) -> np.ndarray:
    """The rows of an (n, 3) array scaled to length one; rows of length zero stay zero."""
    length = norms(v)[:, None]
    return np.divide(v, length, out=np.zeros_like(v, dtype=float), where=length > 0)


def inverse3(m) -> np.ndarray:
    """The inverse of a 3x3 matrix by its cofactors: numpy's LAPACK inverse wakes the BLAS
    threads for nine numbers (about 2 ms a call inside Blender next to Embree's threads)."""
    m = np.asarray(m, dtype=np.float64)
    columns = np.cross(m[[1, 2, 0]], m[[2, 0, 1]])  # b x c, c x a, a x b of the rows a, b, c
    det = float(m[0] @ columns[0])
    if det == 0.0 or not np.isfinite(det):
        raise np.linalg.LinAlgError("Singular matrix")
    return columns.T / det


def cross(a: np.ndarray, b: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Row-wise cross products of two (n, 3) arrays (into ``out`` if given): np.cross's numbers,
    column by column, several times faster on (n, 3) rows."""
    out = np.empty(np.broadcast_shapes(np.shape(a), np.shape(b))) if out is None else out
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def matmul3(v: np.ndarray, m) -> np.ndarray:
    """``v @ m`` for an (n, 3) array and a 3x3 matrix, column by column. A matrix product of many
    rows wakes OpenBLAS's threads, which then spin on the other core for the rest of a playback
    frame (a played ramp took 1.67 times its wall time in CPU time, 1.06 without); nine
    multiply-adds a row need none."""
    v, m = np.asarray(v, dtype=np.float64), np.asarray(m, dtype=np.float64)
    out = np.empty((len(v), 3))
    for j in range(3):
        out[:, j] = v[:, 0] * m[0, j] + v[:, 1] * m[1, j] + v[:, 2] * m[2, j]
    return out


def rows(a: np.ndarray, index) -> np.ndarray:
    """``a[index]`` for an integer index array (any shape): the rows it names. np.take gathers
    rows of a 2-D array 4-10x faster than indexing does in numpy 1.26, which takes a generic
    path for every trailing axis. Not for boolean masks."""
    return np.take(a, index, axis=0)


def box(*arrays) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of the box around the rows of all the given (n, 3) arrays, column by
    column (numpy 1.26 reduces along axis 0 of (n, 3) 10-20x slower); inverted (inf, -inf) if
    they hold no row."""
    pts = [np.asarray(v) for v in arrays if len(v)]
    if not pts:
        return np.full(3, np.inf), np.full(3, -np.inf)
    return (np.array([min(v[:, k].min() for v in pts) for k in range(3)]),
            np.array([max(v[:, k].max() for v in pts) for k in range(3)]))


__all__ = ["box", "cross", "matmul3", "norms", "rows", "size_of", "unit"]


def size_of(vertices) -> float:
    """The diagonal of the box around the points in their own principal axes: a size that does
    not change when the scene is turned (an axis-aligned box's diagonal grows by up to 70%), and
    equals the axis-aligned one for a figure standing along the axes. Column by column, with no
    matrix product (see matmul3)."""
    v = np.asarray(vertices, dtype=np.float64)
    if len(v) < 2:
        return 0.0
    c = [v[:, k] - v[:, k].mean() for k in range(3)]
    moments = np.array([[float((c[i] * c[j]).sum()) for j in range(3)] for i in range(3)])
    _, axes = np.linalg.eigh(moments)
    spans = [float(np.ptp(c[0] * axes[0, k] + c[1] * axes[1, k] + c[2] * axes[2, k])) for k in range(3)]
    return float(np.sqrt(sum(s * s for s in spans)))

"""Direct solves with an operator that is the same at every row of a lattice periodic along y
(the axis of the water round a bell): in Fourier modes along y it falls apart into one small
dense system per mode, across a row (nx unknowns), instead of one sparse system over the whole
lattice.

The lattice's particle (ix, iy) is unknown iy * nx + ix (``mps.lattice``). An operator A the same
at every row couples (ix, iy) to (jx, iy + d) by a[ix, d, jx] whatever iy is, so on a mode
p = P exp(2 pi i m y / ny) it acts as the nx x nx matrix B_m = sum_d a[:, d, :] exp(2 pi i m d / ny).
Solving is a real FFT along y of the right-hand side, one multiplication by B_m's inverse per
mode and the inverse FFT: about 0.1 ms for 50 x 100 particles, where a sparse LU of the whole
lattice fills to 200 entries a row and takes ten times as long.
"""

import numpy as np


class AxialModes:
    """The inverse of a (n, n) operator the same at every row of an nx x ny lattice periodic in y.
    ``pin``: for an operator whose constants are its null space (a pressure Laplacian), the
    column of the row-mean (mode 0) held at zero; the caller makes the right-hand side solvable
    and shifts the answer to the constant it wants."""

    def __init__(self, matrix, nx: int, ny: int, pin: int | None = None):
        if matrix.shape != (nx * ny, nx * ny):
            raise ValueError(f"the operator is {matrix.shape}, the lattice has {nx} x {ny} particles")
        self.nx, self.ny, self.pin = nx, ny, pin
        first_row = matrix[:nx].toarray().reshape(nx, ny, nx)  # [ix, d, jx]
        blocks = np.moveaxis(np.fft.ifft(first_row, axis=1)[:, :ny // 2 + 1, :] * ny, 1, 0)
        # the first row stands for every row only if the operator is the same at each
        probe = np.random.default_rng(0).normal(size=nx * ny)
        by_modes = np.fft.irfft((blocks @ self._modes(probe)[:, :, None])[..., 0], n=ny, axis=0).ravel()
        exact = matrix @ probe
        if not np.allclose(by_modes, exact, rtol=0.0, atol=1e-9 * (np.abs(exact).max() + 1e-300)):
            raise ValueError("the operator is not the same at every row of the lattice: it has no solve by modes")
        if pin is not None:
            blocks[0, pin, :] = 0.0
            blocks[0, pin, pin] = 1.0
        self.inverse = _inverses(blocks)

    def _modes(self, values):
        return np.fft.rfft(np.asarray(values, float).reshape(self.ny, self.nx), axis=0)

    def solve(self, b: np.ndarray) -> np.ndarray:
        modes = self._modes(b)
        if self.pin is not None:
            modes[0, self.pin] = 0.0
        solved = (self.inverse @ modes[:, :, None])[..., 0]
        return np.fft.irfft(solved, n=self.ny, axis=0).ravel()


def _inverses(blocks: np.ndarray) -> np.ndarray:
    """The inverse of each of a stack of square matrices by Gauss-Jordan elimination in place
    with partial pivoting, in numpy's elementwise operations: LAPACK's (OpenBLAS's) rounds
    differently with the number of threads it is given, and a search's strokes must score the
    same on a laptop's pool and a cluster's single-threaded workers."""
    m, n, _ = blocks.shape
    a = blocks.astype(complex)
    every = np.arange(m)
    swaps = np.empty((n, m), np.int64)
    for k in range(n):
        pivot = k + np.argmax(np.abs(a[:, k:, k]), axis=1)
        swaps[k] = pivot
        row = a[every, k].copy()
        a[every, k] = a[every, pivot]
        a[every, pivot] = row
        lead = a[:, k, k].copy()
        if (np.abs(lead) == 0).any():
            raise np.linalg.LinAlgError("a mode's matrix is singular")
        a[:, k, k] = 1.0
        a[:, k] /= lead[:, None]
        factor = a[:, :, k].copy()
        factor[:, k] = 0.0
        a[:, :, k] = 0.0
        a[:, k, k] = 1.0 / lead
        a -= factor[:, :, None] * a[:, k][:, None, :]
    # the rows swapped on the way are the inverse's columns swapped back, last first
    for k in range(n - 1, -1, -1):
        col = a[every, :, k].copy()
        a[every, :, k] = a[every, :, swaps[k]]
        a[every, :, swaps[k]] = col
    return a


__all__ = ["AxialModes"]

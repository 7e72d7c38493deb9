"""The volume spline of thesis section 2.3: radial basis functions plus a degree-one polynomial.

f(P) = sum_j lambda_j phi(|P - P_j|) + nu_0 + nu . P, with the weights from the block
system [[A, B], [B^T, 0]] [lambda; nu] = [h; 0] (eq. 2.4-2.6). Used for the jellyfish bell's
space mapping (eq. 3.1) and its bending energy h^T A^-1 h (section 3.5).
"""

import numpy as np
import scipy.linalg

KERNELS = ("thin_plate_spline", "cubic", "gaussian")
# How the weights change when coordinates are divided by s: lambda = lambda' / s**k, because
# phi(r / s) = phi(r) / s**k plus (thin plate only) a multiple of r^2, which the side
# conditions turn into part of the polynomial.
_WEIGHT_POWER = {"thin_plate_spline": 2, "cubic": 3, "gaussian": 0}


def _kernel(name, r, epsilon):
    if name == "thin_plate_spline":
        with np.errstate(divide="ignore", invalid="ignore"):
            out = r * r * np.log(r)
        return np.where(r > 0.0, out, 0.0)
    if name == "cubic":
        return r * r * r
    return np.exp(-((epsilon * r) ** 2))


def _distances(a, b):
    d2 = (a * a).sum(1)[:, None] + (b * b).sum(1)[None, :] - 2.0 * a @ b.T
    return np.sqrt(np.maximum(d2, 0.0))


class VolumeSpline:
    """Interpolates ``values`` (N,) or (N, m) at ``centers`` (N, 2) or (N, 3).

    Centres closer than ``merge_tol`` (relative to their extent) are merged when their
    values agree and refused otherwise; centres all on one line (2D) or plane (3D) are
    refused, because the linear part is then not determined. Coordinates are shifted and
    scaled to unit size before solving, so millimetres and kilometres behave alike.
    ``epsilon`` is the Gaussian's shape parameter in the caller's units (as scipy's)."""

    def __init__(self, centers, values, kernel="thin_plate_spline", epsilon=None, merge_tol=1e-9):
        if kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
        if kernel == "gaussian" and (epsilon is None or not np.isfinite(epsilon) or epsilon <= 0):
            raise ValueError("the gaussian kernel needs a finite epsilon > 0")
        c = np.asarray(centers, dtype=np.float64)
        h = np.asarray(values, dtype=np.float64)
        if c.ndim != 2 or c.shape[1] not in (2, 3):
            raise ValueError(f"centers must be (N, 2) or (N, 3), got {c.shape}")
        self._scalar = h.ndim == 1
        h = h.reshape(len(h), -1) if h.ndim else h
        if len(h) != len(c):
            raise ValueError(f"{len(c)} centers but {len(h)} values")
        if not (np.isfinite(c).all() and np.isfinite(h).all()):
            raise ValueError("centers and values must be finite (no NaN or inf)")
        dim = c.shape[1]
        if len(c) < dim + 1:
            raise ValueError(f"a {dim}D volume spline needs at least {dim + 1} centers, got {len(c)}")
        self.kernel, self.dim = kernel, dim
        self._shift = c.mean(0)
        self._scale = float(np.abs(c - self._shift).max()) or 1.0
        x = (c - self._shift) / self._scale
        x, h, self.merged = _merge_coincident(x, h, merge_tol)
        self.centers = x * self._scale + self._shift
        self.values = h
        poly = np.hstack([np.ones((len(x), 1)), x])
        sv = np.linalg.svd(poly, compute_uv=False)
        if sv[-1] <= 1e-9 * sv[0]:
            shape = "one line" if dim == 2 else "one plane"
            raise ValueError(f"the centers lie on {shape}: the spline's linear part is not determined "
                             "(add a center off it)")
        self._eps = None if epsilon is None else float(epsilon) * self._scale
        n = len(x)
        t = np.zeros((n + dim + 1, n + dim + 1))
        t[:n, :n] = _kernel(kernel, _distances(x, x), self._eps)
        t[:n, n:] = poly
        t[n:, :n] = poly.T
        rhs = np.vstack([h, np.zeros((dim + 1, h.shape[1]))])
        try:
            sol = scipy.linalg.solve(t, rhs, assume_a="sym")
        except (np.linalg.LinAlgError, scipy.linalg.LinAlgError) as exc:
            raise ValueError(f"the spline's system is singular: {exc}") from None
        if not np.isfinite(sol).all():
            raise ValueError("the spline's system is singular (non-finite weights)")
        self._x = x
        self._lam, self._nu = sol[:n], sol[n:]

    @property
    def weights(self) -> np.ndarray:
        """lambda in the caller's units, (N, m)."""
        return self._lam / self._scale ** _WEIGHT_POWER[self.kernel]

    def __call__(self, points, chunk=4096) -> np.ndarray:
        p = np.asarray(points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != self.dim:
            raise ValueError(f"points must be (M, {self.dim}), got {p.shape}")
        x = (p - self._shift) / self._scale
        out = np.empty((len(x), self._lam.shape[1]))
        for s in range(0, len(x), chunk):
            q = x[s:s + chunk]
            out[s:s + chunk] = _kernel(self.kernel, _distances(q, self._x), self._eps) @ self._lam
            out[s:s + chunk] += self._nu[0] + q @ self._nu[1:]
        return out[:, 0] if self._scalar else out

    def bending_energy(self) -> float:
        """h^T A^-1 h summed over the value columns, A^-1 being the upper-left N x N block of
        the inverse of the block matrix (the thesis' bending energy matrix): equal to lambda . h,
        zero exactly when the values come from an affine map."""
        return float((self.weights * self.values).sum())


def _merge_coincident(x, h, tol):
    """Keep one of each group of centres closer than ``tol`` (unit-scaled) if their values agree."""
    if len(x) < 2:
        return x, h, 0
    from scipy.spatial import cKDTree

    pairs = cKDTree(x).query_pairs(max(tol, 1e-15), output_type="ndarray")
    if not len(pairs):
        return x, h, 0
    spread = float(np.abs(h).max()) or 1.0
    bad = np.abs(h[pairs[:, 0]] - h[pairs[:, 1]]).max(1) > 1e-9 * spread
    if bad.any():
        i, j = pairs[np.argmax(bad)]
        raise ValueError(f"centers {i} and {j} coincide but have different values: the spline cannot "
                         "pass through both")
    drop = np.zeros(len(x), dtype=bool)
    drop[np.maximum(pairs[:, 0], pairs[:, 1])] = True
    keep = ~drop
    return x[keep], h[keep], int(drop.sum())

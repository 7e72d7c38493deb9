"""Particle operators of the moving-particle semi-implicit family (thesis 3.4, eq. 3.2-3.9).

A ``Neighbours`` set holds every interacting pair (i, j) once per direction, the weight
w(|r_ij|, r_e,i) with r_e per particle (variable near boundaries makes the Laplacian
unsymmetric, as in the thesis) and optionally a periodic box. Extra "ghost" particles that
mirror or copy real ones (walls, periodic images) can be appended by the caller; the
operators then see ``values`` for real and ghost particles alike and return rows for the
first ``n_rows`` particles.
"""

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree


def weight(r, re):
    """Eq. 3.2: 2 - (2r/re)^2 inside re/2, (2r/re - 2)^2 out to re, zero beyond."""
    x = 2.0 * np.asarray(r, float) / re
    return np.where(x < 1.0, 2.0 - x * x, np.where(x < 2.0, (x - 2.0) ** 2, 0.0))


def lambda_continuous(re):
    """The 2D Laplacian constant of eq. 3.5 for this weight: 31/140 re^2."""
    return 31.0 / 140.0 * re * re


@dataclass
class Neighbours:
    i: np.ndarray  # row particle
    j: np.ndarray  # neighbour
    r: np.ndarray  # (pairs, 2) r_j - r_i (minimum image in a periodic box)
    dist: np.ndarray
    w: np.ndarray  # w(|r_ij|, re_i)
    n_rows: int
    n_points: int
    _grad: list | None = field(default=None, repr=False, compare=False)  # gradient matrices, made on first use

    @classmethod
    def build(cls, points, re, n_rows=None, box=None, blocked=None):
        """Pairs within r_e of each of the first ``n_rows`` points (default all).

        re: scalar or one radius per point (the row's radius is used). box: (Lx, Ly) for
        a periodic domain [0, Lx) x [0, Ly). blocked(i, j) -> bool mask of pairs that must
        not interact (e.g. across a thin solid)."""
        p = np.asarray(points, float)
        n = len(p)
        n_rows = n if n_rows is None else int(n_rows)
        re_all = np.broadcast_to(np.asarray(re, float), (n,)).copy()
        if not (np.isfinite(re_all).all() and (re_all > 0).all()):
            raise ValueError("r_e must be finite and > 0")
        tree = cKDTree(p, boxsize=box) if box is not None else cKDTree(p)
        lists = tree.query_ball_point(p[:n_rows], re_all[:n_rows], return_sorted=False)
        counts = np.fromiter((len(x) for x in lists), dtype=np.int64, count=n_rows)
        i = np.repeat(np.arange(n_rows), counts)
        j = np.fromiter((k for x in lists for k in x), dtype=np.int64, count=int(counts.sum()))
        keep = i != j
        i, j = i[keep], j[keep]
        r = p[j] - p[i]
        if box is not None:
            b = np.asarray(box, float)
            r -= b * np.round(r / b)
        if blocked is not None and len(i):
            ok = ~np.asarray(blocked(i, j), bool)
            i, j, r = i[ok], j[ok], r[ok]
        dist = np.linalg.norm(r, axis=1)
        w = weight(dist, re_all[i])
        return cls(i, j, r, dist, w, n_rows, n)

    def density(self) -> np.ndarray:
        """Eq. 3.3: particle number density per row."""
        return np.bincount(self.i, weights=self.w, minlength=self.n_rows)

    def lam(self) -> np.ndarray:
        """Per row, sum w r^2 / sum w: the Laplacian constant that makes the Laplacian of a
        quadratic exact on the particle arrangement it is measured on."""
        sw = self.density()
        swr = np.bincount(self.i, weights=self.w * self.dist**2, minlength=self.n_rows)
        return np.divide(swr, sw, out=np.zeros_like(sw), where=sw > 0)

    def _gradient_matrices(self):
        """Per axis k, the sparse (n_rows, n_points) matrix of sum_j (phi_j - phi_i) r_ij,k w / |r_ij|^2:
        made once, as the operators are applied every step."""
        if self._grad is None:
            c = self.w / self.dist**2
            self._grad = []
            for k in range(self.r.shape[1]):
                v = c * self.r[:, k]
                off = sp.csr_matrix((v, (self.i, self.j)), shape=(self.n_rows, self.n_points))
                diag = sp.csr_matrix((-np.bincount(self.i, weights=v, minlength=self.n_rows),
                                      (np.arange(self.n_rows), np.arange(self.n_rows))),
                                     shape=(self.n_rows, self.n_points))
                self._grad.append((off + diag).tocsr())
        return self._grad

    def gradient(self, phi, n0, dim=2):
        """Eq. 3.4: (d/n0) sum (phi_j - phi_i) r_ij w / |r_ij|^2."""
        phi = np.asarray(phi, float)
        return dim / n0 * np.column_stack([g @ phi for g in self._gradient_matrices()])

    def divergence(self, u, n0, dim=2):
        """Eq. 3.7: (d/n0) sum (u_j - u_i) . r_ij w / |r_ij|^2."""
        u = np.asarray(u, float)
        return dim / n0 * sum(g @ u[:, k] for k, g in enumerate(self._gradient_matrices()))

    def laplacian(self, phi, n0, lam, dim=2):
        """Eq. 3.5: (2d / (lam n0)) sum (phi_j - phi_i) w; phi may be (n,) or (n, m)."""
        phi = np.asarray(phi, float)
        diff = (phi[self.j] - phi[self.i]) * (self.w if phi.ndim == 1 else self.w[:, None])
        if phi.ndim == 1:
            s = np.bincount(self.i, weights=diff, minlength=self.n_rows)
        else:
            s = np.column_stack([np.bincount(self.i, weights=diff[:, k], minlength=self.n_rows)
                                 for k in range(phi.shape[1])])
        scale = 2.0 * dim / (np.asarray(lam) * n0)
        return s * (scale if np.ndim(scale) == 0 or phi.ndim == 1 else scale[:, None])

    def laplacian_matrix(self, n0, lam, column_of=None, coefficient=None, dim=2):
        """The Laplacian as a sparse (n_rows, n_unknowns) matrix. ``column_of`` maps every
        point to the unknown it takes its value from (a ghost to its source), default itself;
        ``coefficient`` scales that value per point (-1 for a mirrored velocity component)."""
        col = np.arange(self.n_points) if column_of is None else np.asarray(column_of)
        scale = 2.0 * dim / (np.broadcast_to(np.asarray(lam, float), (self.n_rows,)) * n0)
        vals = self.w * scale[self.i]
        n_unknowns = int(col.max()) + 1
        coef = vals if coefficient is None else vals * np.asarray(coefficient, float)[self.j]
        off = sp.coo_matrix((coef, (self.i, col[self.j])), shape=(self.n_rows, n_unknowns))
        diag = np.bincount(self.i, weights=vals, minlength=self.n_rows)
        d = sp.coo_matrix((-diag, (np.arange(self.n_rows), np.arange(self.n_rows))), shape=(self.n_rows, n_unknowns))
        return (off + d).tocsr()

    def shepard(self, values):
        """Partition-of-unity average of ``values`` over each row's neighbours and itself."""
        v = np.asarray(values, float)
        w0 = weight(0.0, 1.0)
        sw = self.density() + w0
        if v.ndim == 1:
            return (np.bincount(self.i, weights=self.w * v[self.j], minlength=self.n_rows) + w0 * v[:self.n_rows]) / sw
        out = np.column_stack([np.bincount(self.i, weights=self.w * v[self.j, k], minlength=self.n_rows)
                               for k in range(v.shape[1])])
        return (out + w0 * v[:self.n_rows]) / sw[:, None]


def lattice(nx, ny, h, origin=(0.0, 0.0)):
    """Cell-centred lattice points (nx * ny, 2), row-major in y."""
    x = origin[0] + (np.arange(nx) + 0.5) * h
    y = origin[1] + (np.arange(ny) + 0.5) * h
    gx, gy = np.meshgrid(x, y)
    return np.column_stack([gx.ravel(), gy.ravel()])

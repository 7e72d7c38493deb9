"""A body's velocity imposed inside the pressure projection (direct forcing solved as one
constrained problem instead of imposing and projecting in turn).

Imposing a body's velocity on the particles it covers and then projecting leaves those
particles short of it: the projection spreads the imposed impulse over the water round the
body, and a thin margin leaks. Imposing and projecting again (multi-direct forcing) converges
as the Richardson iteration on "the projected field's values on the body are the body's", and
slowly: the margin's modes barely move per round. The same projections spent as Krylov (GMRES)
iterations on that linear problem converge faster. A body free to move along an axis adds
its speed as one more unknown, held to the momentum balance exactly (every correction keeps
the momentum of water and body), so the speed and the flow are solved together.

The field is projected once with the body's velocity imposed (the plain direct forcing); each
correction after it is one GMRES iteration and costs one more projection. Carrying the last
step's shortfall into the next step's guess was tried and left the bell leakier (GMRES's
corrections, or the part of the body's velocity no divergence-free field can take, pile up).
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ImposedBody:
    """What a body imposes for one step. ``velocity`` (one row per covered particle, m/s) is its
    own motion there; with ``free_axis`` it also moves along that axis at one speed U, the one
    that keeps ``momentum`` (the sum of velocity x particle volume along the axis over water and
    body, the body as dense as the water)."""

    mask: np.ndarray
    velocity: np.ndarray
    free_axis: int | None = None
    momentum: float = 0.0


@dataclass
class Projected:
    u: np.ndarray  # the kept field: projected, the body's velocity on its particles to the corrections' accuracy
    p: np.ndarray
    speed: float  # the body's solved speed along its free axis (0 without one)
    miss: float  # largest |u - body velocity| over the body's particles, m/s
    corrections: int = 0  # GMRES iterations taken (projections after the first)


def project_with_body(project, u, body: ImposedBody, volume, corrections: int, tolerance: float | None = None
                      ) -> Projected:
    """``u`` off the body with the body's velocity on it, projected, then ``corrections`` GMRES
    iterations towards the divergence-free field whose values on the body are the body's, in
    ``corrections`` + 1 projections. With ``tolerance``, the iterations stop once the body's
    values miss by at most that share of the fastest speed imposed on it (root mean square over
    its particles), ``corrections`` then the most they may take. ``project(field) -> (field,
    pressure)`` must be linear (sides at rest)."""
    if int(corrections) != corrections or corrections < 0:
        raise ValueError(f"corrections must be a whole number >= 0, got {corrections}")
    if tolerance is not None and not (np.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance must be a share > 0 of the body's speed (or None), got {tolerance}")
    mask = np.asarray(body.mask, bool)
    k = int(mask.sum())
    free = body.free_axis
    base = np.array(u, float)
    base[mask] = 0.0
    vol = volume[mask]
    own = np.asarray(body.velocity, float).reshape(k, 2)
    # the free speed that keeps the momentum with the body's own motion on its particles
    speed0 = 0.0
    if free is not None and k:
        speed0 = (body.momentum - base[:, free] @ volume - own[:, free] @ vol) / vol.sum()
    target = own.copy()
    if free is not None:
        target[:, free] += speed0
    field = base.copy()
    field[mask] = target
    u0, p0 = project(field)
    split = _MomentumSplit(vol, free)
    # in the residual's units: a root mean square miss over the body's 2k values
    enough = None if tolerance is None else tolerance * float(np.abs(target).max(initial=0.0)) * np.sqrt(2 * k)
    fields, y = _gmres(project, mask, split, (target - u0[mask]).ravel(), int(corrections), enough)
    u_out, p_out, speed = u0.copy(), p0.copy(), speed0
    for coef, (z, pu, pp) in zip(y, fields, strict=False):
        u_out += coef * pu
        p_out += coef * pp
        speed += coef * split.speed(z)
    miss_vec = own - u_out[mask]
    if free is not None:
        miss_vec[:, free] += speed
    return Projected(u_out, p_out, float(speed), float(np.abs(miss_vec).max(initial=0.0)), len(fields))


class _MomentumSplit:
    """The unknowns of the bordered system (a change dg of the values put on the body, a change
    dU of its free speed) as one vector z of the body's size: dg = z less its component along
    the momentum row (so every correction keeps the momentum exactly, not only as well as the
    least squares keeps an equation), dU = that component over sqrt(k) (a uniform speed on k
    particles has the norm of z's component). The operator z -> P(E dg) on the body - dU e_free
    is then square. Without a free axis, dg = z."""

    def __init__(self, vol, free):
        self.free = free
        self.k = len(vol)
        if free is not None:
            row = np.zeros((self.k, 2))
            row[:, free] = vol
            self.normal = row.ravel() / np.linalg.norm(row)

    def values(self, z):
        return z if self.free is None else z - (self.normal @ z) * self.normal

    def speed(self, z):
        return 0.0 if self.free is None else float(self.normal @ z) / np.sqrt(self.k)


def _gmres(project, mask, split, residual, iterations, enough=None):
    """GMRES on z -> P(E dg(z)) on the body - dU(z) e_free, from the residual of the plain
    projection, keeping each basis vector's projected field so that the answer costs no further
    projection; at most ``iterations``, fewer once the residual's norm is at most ``enough``.
    Returns [(z, P E dg(z), its pressure), ...] and the basis vectors' coefficients."""
    beta = float(np.linalg.norm(residual))
    if iterations == 0 or beta == 0.0 or (enough is not None and beta <= enough):
        return [], []
    k, n = int(mask.sum()), len(mask)
    qs = [residual / beta]
    h = np.zeros((iterations + 1, iterations))
    fields = []
    for j in range(iterations):
        z = qs[j]
        e = np.zeros((n, 2))
        e[mask] = split.values(z).reshape(k, 2)
        pu, pp = project(e)
        fields.append((z, pu, pp))
        a = pu[mask].copy()
        if split.free is not None:
            a[:, split.free] -= split.speed(z)
        a = a.ravel()
        for i in range(j + 1):  # modified Gram-Schmidt
            h[i, j] = qs[i] @ a
            a -= h[i, j] * qs[i]
        h[j + 1, j] = np.linalg.norm(a)
        if h[j + 1, j] <= 1e-13 * beta:  # the answer lies in the space already spanned
            h = h[:j + 2, :j + 1]
            break
        if enough is not None:  # the residual of the small least-squares problem is GMRES's own
            sub = h[:j + 2, :j + 1]
            rhs = np.zeros(j + 2)
            rhs[0] = beta
            coef = np.linalg.lstsq(sub, rhs, rcond=None)[0]
            if np.linalg.norm(sub @ coef - rhs) <= enough:
                return fields, coef
        qs.append(a / h[j + 1, j])
    rhs = np.zeros(h.shape[0])
    rhs[0] = beta
    return fields, np.linalg.lstsq(h, rhs, rcond=None)[0]

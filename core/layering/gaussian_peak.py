"""The largest of several truncated Gaussian bumps at each point, without listing every
(point, bump) pair: a point's largest a_i exp(-|x - h_i|^2 / 2c^2) is the bump that minimises
|x - h_i|^2 - 2c^2 ln a_i, which is its nearest neighbour among the centres lifted into a fourth
dimension by sqrt(2c^2 ln(a_max / a_i)). One k-d tree query per point then replaces the pairs
within reach (hundreds per point along a hem: most of the boundary pass's time)."""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree

from ..geometry.parallel import tree_workers
from ..geometry.vectors import norms


def largest_gaussian(points: np.ndarray, centres: np.ndarray, amplitude: np.ndarray, c: float,
                     reach: float) -> np.ndarray:
    """Per point, max over centres i with |x - h_i| <= reach of a_i exp(-|x - h_i|^2 / 2c^2),
    or 0 where no centre is within reach. ``amplitude`` >= 0, ``c`` > 0."""
    out = np.zeros(len(points))
    keep = amplitude > 0  # a zero bump adds nothing, and has no logarithm
    if not len(points) or not keep.any():
        return out
    h, a = centres[keep], amplitude[keep]
    lift = np.sqrt(2.0 * c * c * (np.log(a.max()) - np.log(a)))
    # a bump within reach is no farther in four dimensions than this: the bound prunes the search,
    # and a point it leaves without any has no bump within reach
    bound = np.nextafter(np.sqrt(reach * reach + lift.max() ** 2), np.inf)
    _, best = cKDTree(np.column_stack([h, lift])).query(np.column_stack([points, np.zeros(len(points))]),
                                                          distance_upper_bound=bound, workers=tree_workers(len(points)))
    found = best < len(h)
    gap = np.full(len(points), np.inf)
    gap[found] = norms(points[found] - h[best[found]])
    inside = gap <= reach
    out[inside] = a[best[inside]] * np.exp(-(gap[inside] ** 2) / (2 * c * c))
    # where the best bump lies beyond reach, the truncated maximum is another bump's (or none):
    # asked pair by pair
    far = np.flatnonzero(found & ~inside)
    if len(far):
        # the "ndarray" form keeps pairs at distance 0 (a point exactly on a centre)
        pairs = cKDTree(h).sparse_distance_matrix(cKDTree(points[far]), reach, output_type="ndarray")
        w = a[pairs["i"]] * np.exp(-(pairs["v"] ** 2) / (2 * c * c))
        # each point's largest weight (all >= 0), as a sparse row maximum: np.maximum.at is 2-3x slower
        per_pair = sparse.csr_matrix((w, (pairs["j"], pairs["i"])), shape=(len(far), len(h)))
        out[far] = per_pair.max(axis=1).toarray().ravel()
    return out


__all__ = ["largest_gaussian"]

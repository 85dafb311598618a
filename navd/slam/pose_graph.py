"""A 2D pose graph: keyframe poses tied by relative-pose constraints, optimized by scipy.

Each edge (i, j, z, w) says "pose j seen from pose i is z", with weights w = 1/sigma for
(x, y, yaw). The residual of an edge is w * (z⁻¹ ⊕ (x_i⁻¹ ⊕ x_j)) as (dx, dy, dyaw), and
the graph is solved with scipy.optimize.least_squares (trust region, sparse Jacobian by
finite differences over the known sparsity). Node 0 is held fixed.

Edges marked ``robust`` (loop closures, which can be wrong) pull through a soft-L1 loss on
their whole weighted residual, so a wrong one pulls less than a right one; the chain of
tracked edges is trusted and stays quadratic. (With every edge robust, the aces trajectory
was seen to jump where loops pulled. A Huber loss was seen to leave a 2 m loop open: once
the loop residual is in its linear part, the trust region stops early. soft-L1 closes it.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import lil_matrix

__all__ = ["Edge", "optimize"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Edge:
    """Pose ``j`` seen from pose ``i`` is ``z`` (x [m], y [m], yaw [rad]), with weights."""

    i: int
    j: int
    z: tuple[float, float, float]
    weights: tuple[float, float, float]
    robust: bool = False


# [sigma] where a robust edge's pull stops growing linearly with its residual
ROBUST_SCALE = 3.0


_Graph = tuple[
    FloatArray,
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    FloatArray,
    FloatArray,
    npt.NDArray[np.bool_],
]


def _residuals(flat: FloatArray, graph: _Graph) -> FloatArray:
    fixed, ii, jj, z, w, robust = graph
    poses = np.vstack([fixed[None, :], flat.reshape(-1, 3)])
    a, b = poses[ii], poses[jj]
    # x_i⁻¹ ⊕ x_j
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    rel_x = c * dx + s * dy
    rel_y = -s * dx + c * dy
    rel_t = b[:, 2] - a[:, 2]
    # z⁻¹ ⊕ rel
    cz, sz = np.cos(z[:, 2]), np.sin(z[:, 2])
    ex = cz * (rel_x - z[:, 0]) + sz * (rel_y - z[:, 1])
    ey = -sz * (rel_x - z[:, 0]) + cz * (rel_y - z[:, 1])
    et = np.remainder(rel_t - z[:, 2] + np.pi, 2 * np.pi) - np.pi
    r = np.column_stack([ex, ey, et]) * w
    if robust.any():
        # soft-L1 on the squared norm q: cost 2 f^2 (sqrt(1 + q / f^2) - 1), reached by
        # scaling the residual vector by sqrt(cost / q) = sqrt(2 / (sqrt(1 + q / f^2) + 1)).
        q = np.sum(r[robust] ** 2, axis=1)
        r[robust] *= np.sqrt(2.0 / (np.sqrt(1.0 + q / ROBUST_SCALE**2) + 1.0))[:, None]
    out: FloatArray = r.ravel()
    return out


def optimize(poses: FloatArray, edges: list[Edge], max_nfev: int = 50) -> FloatArray:
    """Poses (N x 3) that best satisfy ``edges``, pose 0 unchanged."""
    # scipy.optimize costs most of a second to import: only when a graph is solved.
    from scipy.optimize import least_squares  # noqa: PLC0415

    n = poses.shape[0]
    if n < 2 or not edges:
        return poses.copy()
    ii = np.array([e.i for e in edges])
    jj = np.array([e.j for e in edges])
    z = np.array([e.z for e in edges], dtype=np.float64)
    w = np.array([e.weights for e in edges], dtype=np.float64)
    robust = np.array([e.robust for e in edges], dtype=np.bool_)
    sparsity = lil_matrix((3 * len(edges), 3 * (n - 1)), dtype=np.int8)
    for k, (i, j) in enumerate(zip(ii, jj, strict=True)):
        for node in (i, j):
            if node > 0:
                sparsity[3 * k : 3 * k + 3, 3 * (node - 1) : 3 * node] = 1
    result = least_squares(
        _residuals,
        poses[1:].ravel(),
        jac_sparsity=sparsity.tocsr(),
        method="trf",
        max_nfev=max_nfev,
        args=((poses[0], ii, jj, z, w, robust),),
    )
    solved: FloatArray = np.vstack([poses[:1], result.x.reshape(-1, 3)])
    solved[:, 2] = np.remainder(solved[:, 2] + np.pi, 2 * np.pi) - np.pi
    return solved

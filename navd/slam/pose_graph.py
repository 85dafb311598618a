"""A 2D pose graph: keyframe poses tied by relative-pose constraints, solved by sparse
Levenberg-Marquardt.

Each edge (i, j, z, w) says "pose j seen from pose i is z", with weights w = 1/sigma for
(x, y, yaw). The residual of an edge is w * (z⁻¹ ⊕ (x_i⁻¹ ⊕ x_j)) as (dx, dy, dyaw). Each
iteration linearizes every edge with its analytic Jacobian (two 3 x 3 blocks), forms the
sparse normal equations and solves them with scipy's sparse LU (`navd bench scan` times
it). Node 0 is held fixed.

Edges marked ``robust`` (loop closures, which can be wrong) pull through a soft-L1 loss on
their whole weighted residual, 2 f² (sqrt(1 + q / f²) - 1) for the squared norm q, so a
wrong one pulls less than a right one; the chain of tracked edges is trusted and stays
quadratic. The loss enters the
normal equations as a weight per edge, its derivative 1 / sqrt(1 + q / f²) at the current
residual (iteratively reweighted least squares); a step is kept only if it lowers the robust
cost, else the damping grows.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2, wrap_angles

__all__ = ["Edge", "graph_distances", "optimize"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Edge:
    """Pose ``j`` seen from pose ``i`` is ``z``, with weights (1/sigma of x, y, yaw)."""

    i: int
    j: int
    z: Pose2
    weights: tuple[float, float, float]
    robust: bool = False


# [sigma] where a robust edge's pull stops growing linearly with its residual
ROBUST_SCALE = 3.0
# Levenberg-Marquardt: the first damping (relative to the normal matrix's diagonal), and
# convergence: a step below this [m or rad] or a relative cost drop below this.
INITIAL_DAMPING = 1e-4
STEP_TOLERANCE = 1e-7
COST_TOLERANCE = 1e-12


@dataclass(frozen=True, slots=True)
class _Graph:
    ii: npt.NDArray[np.int64]
    jj: npt.NDArray[np.int64]
    z: FloatArray
    w: FloatArray
    robust: npt.NDArray[np.bool_]


def _graph(edges: list[Edge]) -> _Graph:
    return _Graph(
        ii=np.array([e.i for e in edges], dtype=np.int64),
        jj=np.array([e.j for e in edges], dtype=np.int64),
        z=np.array([e.z for e in edges], dtype=np.float64).reshape(-1, 3),
        w=np.array([e.weights for e in edges], dtype=np.float64).reshape(-1, 3),
        robust=np.array([e.robust for e in edges], dtype=np.bool_),
    )


def _residuals(poses: FloatArray, g: _Graph) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Weighted residuals (E x 3), and the relative pose x_i⁻¹ ⊕ x_j's translation parts."""
    a, b = poses[g.ii], poses[g.jj]
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    rel_x = c * dx + s * dy
    rel_y = -s * dx + c * dy
    cz, sz = np.cos(g.z[:, 2]), np.sin(g.z[:, 2])
    ux, uy = rel_x - g.z[:, 0], rel_y - g.z[:, 1]
    r = np.column_stack(
        [cz * ux + sz * uy, -sz * ux + cz * uy, wrap_angles(b[:, 2] - a[:, 2] - g.z[:, 2])]
    )
    return r * g.w, rel_x, rel_y


def _edge_costs(r: FloatArray, robust: npt.NDArray[np.bool_]) -> tuple[FloatArray, FloatArray]:
    """Each edge's cost (half its loss) and its loss weight for the normal equations."""
    q = np.sum(r**2, axis=1)
    f2 = ROBUST_SCALE**2
    cost = np.where(robust, f2 * (np.sqrt(1.0 + q / f2) - 1.0), 0.5 * q)
    weight = np.where(robust, 1.0 / np.sqrt(1.0 + q / f2), 1.0)
    return cost, weight


def _jacobian_blocks(
    poses: FloatArray, g: _Graph, rel_x: FloatArray, rel_y: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """d residual / d pose_i and d residual / d pose_j (E x 3 x 3 each), weights applied."""
    phi = poses[g.ii, 2] + g.z[:, 2]
    cp, sp = np.cos(phi), np.sin(phi)
    cz, sz = np.cos(g.z[:, 2]), np.sin(g.z[:, 2])
    n = g.ii.size
    d_j = np.zeros((n, 3, 3))
    d_j[:, 0, 0], d_j[:, 0, 1] = cp, sp
    d_j[:, 1, 0], d_j[:, 1, 1] = -sp, cp
    d_j[:, 2, 2] = 1.0
    d_i = -d_j
    d_i[:, 0, 2] = cz * rel_y - sz * rel_x
    d_i[:, 1, 2] = -sz * rel_y - cz * rel_x
    return d_i * g.w[:, :, None], d_j * g.w[:, :, None]


def graph_distances(edges: Sequence[Edge], count: int, source: int) -> FloatArray:
    """[m] the shortest path from pose ``source`` to each of the first ``count`` poses.

    A loop edge is short (it ties a pose to the old one beside it), so a place the graph has
    already tied to the robot's recent path is near it here however far the robot drove
    since.

    Args:
        edges: the graph's edges, each as long as its translation, either way; edges to
            poses from ``count`` on are left out, and of two edges between the same poses
            the shorter counts.
        count: how many poses (0 .. count - 1).
        source: the pose the paths start at.

    Returns:
        ``count`` path lengths [m]: 0 at ``source``, inf where no path leads.
    """
    from scipy.sparse import coo_matrix  # noqa: PLC0415 (as in optimize: loaded when used)
    from scipy.sparse.csgraph import dijkstra  # noqa: PLC0415

    ii = np.fromiter((e.i for e in edges), np.int64, len(edges))
    jj = np.fromiter((e.j for e in edges), np.int64, len(edges))
    length = np.fromiter((math.hypot(e.z.x, e.z.y) for e in edges), float, len(edges))
    inside = (ii < count) & (jj < count)
    lo, hi, length = np.minimum(ii, jj)[inside], np.maximum(ii, jj)[inside], length[inside]
    # One entry per pair of poses, the shortest (a sparse matrix adds up duplicates), and
    # never exactly 0 (to keep a loop edge of no length from reading as no edge).
    order = np.lexsort((length, hi, lo))
    lo, hi, length = lo[order], hi[order], length[order]
    first = np.ones(lo.size, dtype=np.bool_)
    first[1:] = (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
    weights = np.maximum(length[first], 1e-9)
    matrix = coo_matrix((weights, (lo[first], hi[first])), shape=(count, count))
    out: FloatArray = dijkstra(matrix.tocsr(), directed=False, indices=source)
    return out


def optimize(poses: FloatArray, edges: list[Edge], max_iterations: int = 100) -> FloatArray:
    """Poses (N x 3) that best satisfy ``edges``, pose 0 unchanged."""
    # scipy.sparse.linalg costs a fraction of a second to import: only when a graph is solved.
    from scipy.sparse import coo_matrix, diags  # noqa: PLC0415
    from scipy.sparse.linalg import spsolve  # noqa: PLC0415

    n = poses.shape[0]
    if n < 2 or not edges:
        return poses.copy()
    g = _graph(edges)
    m = len(edges)
    # The sparse structure: edge k's three rows against the three columns of its two poses
    # (pose 0 is fixed: it has no columns).
    rows = np.broadcast_to(3 * np.arange(m)[:, None, None] + np.arange(3)[None, :, None], (m, 3, 3))
    cols_i = np.broadcast_to(3 * (g.ii - 1)[:, None, None] + np.arange(3)[None, None, :], (m, 3, 3))
    cols_j = np.broadcast_to(3 * (g.jj - 1)[:, None, None] + np.arange(3)[None, None, :], (m, 3, 3))
    keep_i = np.broadcast_to((g.ii > 0)[:, None, None], (m, 3, 3))
    keep_j = np.broadcast_to((g.jj > 0)[:, None, None], (m, 3, 3))
    row_index = np.concatenate([rows[keep_i], rows[keep_j]])
    col_index = np.concatenate([cols_i[keep_i], cols_j[keep_j]])

    x = poses.astype(np.float64, copy=True)
    r, rel_x, rel_y = _residuals(x, g)
    costs, weights = _edge_costs(r, g.robust)
    cost = float(costs.sum())
    damping = INITIAL_DAMPING
    for _ in range(max_iterations):
        d_i, d_j = _jacobian_blocks(x, g, rel_x, rel_y)
        root = np.sqrt(weights)[:, None, None]
        data = np.concatenate([(d_i * root)[keep_i], (d_j * root)[keep_j]])
        jac = coo_matrix((data, (row_index, col_index)), shape=(3 * m, 3 * (n - 1))).tocsr()
        normal = (jac.T @ jac).tocsc()
        gradient = jac.T @ (r * np.sqrt(weights)[:, None]).ravel()
        diagonal = np.maximum(normal.diagonal(), 1e-9)
        while True:
            step = spsolve(normal + diags(damping * diagonal, format="csc"), -gradient)
            trial = x.copy()
            trial[1:] += step.reshape(-1, 3)
            r_trial, rx_trial, ry_trial = _residuals(trial, g)
            costs_trial, weights_trial = _edge_costs(r_trial, g.robust)
            cost_trial = float(costs_trial.sum())
            if cost_trial <= cost or damping > 1e12:
                break
            damping *= 10.0
        if cost_trial > cost:
            break  # no step lowers the cost: at the optimum
        drop = cost - cost_trial
        x, r, rel_x, rel_y, weights, cost = (
            trial,
            r_trial,
            rx_trial,
            ry_trial,
            weights_trial,
            cost_trial,
        )
        damping = max(damping / 10.0, 1e-12)
        if np.abs(step).max() < STEP_TOLERANCE or drop <= COST_TOLERANCE * max(cost, 1e-300):
            break
    x[:, 2] = wrap_angles(x[:, 2])
    x[0] = poses[0]
    return x

"""Numba kernel of the exact Euclidean distance transform of a grid.

``distance_to`` gives every cell its distance, in cells, to the nearest cell set in a mask:
the distance down each column to its nearest set cell, then along every row the lower
envelope of parabolas of Felzenszwalb and Huttenlocher (2012, "Distance transforms of
sampled functions"), linear in the cells. The distances are exact: the square root of a
whole number of squared cells, as ``scipy.ndimage.distance_transform_edt`` gives them (the
test compares the two), without loading scipy.ndimage (9 MB of the daemon's resident memory
for this one function). It is most of what building a costmap costs (``navd bench planning``).

``any_within`` says whether any of a few points (stations along a route) lies within a radius
of any of many (a scan's obstacle points), stopping at the first such pair: the route's
blocked check, asked at every scan.

``nearest_on_polyline`` finds the point of a route nearest the robot, asked several times a
control step.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["any_within", "distance_to", "nearest_on_polyline"]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]


@njit(cache=True, nogil=True)
def _along_row(
    grid: FloatArray, r: int, v: npt.NDArray[np.int64], h: FloatArray, z: FloatArray
) -> None:
    """Row ``r`` of ``grid`` holds each cell's distance down its column to the nearest set
    cell (inf for none); replace it with sqrt(min over p of (q - p)^2 + grid[r, p]^2), the
    distance in the plane: the lower envelope of the parabolas of the row's cells (v: their
    columns, h: g^2 + p^2, z: where each begins to be the lowest)."""
    cols = grid.shape[1]
    k = -1
    for q in range(cols):
        g = grid[r, q]
        if g == math.inf:
            continue
        hq = g * g + q * q
        if k < 0:
            k = 0
            v[0] = q
            h[0] = hq
            z[0] = -math.inf
            continue
        s = (hq - h[k]) / (2.0 * (q - v[k]))
        while s <= z[k]:  # the new parabola is lower wherever the last one was lowest
            k -= 1
            s = (hq - h[k]) / (2.0 * (q - v[k]))
        k += 1
        v[k] = q
        h[k] = hq
        z[k] = s
    if k < 0:  # no set cell in any column: nothing to be near
        for q in range(cols):
            grid[r, q] = math.inf
        return
    z[k + 1] = math.inf
    k = 0
    for q in range(cols):
        while z[k + 1] < q:
            k += 1
        d = q - v[k]
        grid[r, q] = math.sqrt(d * d + h[k] - v[k] * v[k])


@njit(cache=True, nogil=True)
def distance_to(mask: BoolArray) -> FloatArray:
    """[cells] Euclidean distance from every cell to the nearest cell set in ``mask``
    (rows x columns); 0 on the set cells, inf everywhere when none is set."""
    rows, cols = mask.shape
    if rows == 0:
        return np.empty((0, cols))
    # Down the columns the nearest set cell is a count of steps, found in two sweeps over the
    # rows (down, then up) that read and write whole rows in memory order. (The envelope run
    # down each column, a row's stride between cells, took 4/5 of the time at 2000².)
    grid = np.empty((rows, cols))
    for c in range(cols):
        grid[0, c] = 0.0 if mask[0, c] else math.inf
    for r in range(1, rows):
        for c in range(cols):
            grid[r, c] = 0.0 if mask[r, c] else grid[r - 1, c] + 1.0
    for r in range(rows - 2, -1, -1):
        for c in range(cols):
            grid[r, c] = min(grid[r, c], grid[r + 1, c] + 1.0)
    v = np.empty(cols, dtype=np.int64)
    h = np.empty(cols)
    z = np.empty(cols + 1)
    for r in range(rows):
        _along_row(grid, r, v, h, z)
    return grid


@njit(cache=True, nogil=True)
def any_within(a: FloatArray, b: FloatArray, radius_m: float) -> bool:
    """Whether some point of ``a`` (N x 2) lies within ``radius_m`` [m] of some point of ``b``
    (M x 2), strictly."""
    r2 = radius_m * radius_m
    if a.shape[0] == 0:
        return False
    lo_x, hi_x = a[:, 0].min() - radius_m, a[:, 0].max() + radius_m
    lo_y, hi_y = a[:, 1].min() - radius_m, a[:, 1].max() + radius_m
    for j in range(b.shape[0]):
        bx, by = b[j, 0], b[j, 1]
        if bx < lo_x or bx > hi_x or by < lo_y or by > hi_y:
            continue  # beyond reach of every point of a
        for i in range(a.shape[0]):
            dx, dy = a[i, 0] - bx, a[i, 1] - by
            if dx * dx + dy * dy < r2:
                return True
    return False


@njit(cache=True, nogil=True)
def nearest_on_polyline(
    points: FloatArray, first: int, x: float, y: float
) -> tuple[int, float, float]:
    """The point nearest (x, y) [m] on the segments of an N x 2 polyline (N >= 2) from
    segment ``first`` on: (segment, fraction along it 0..1, distance [m]); the first of
    equally near segments."""
    best, best_t, best_d = first, 0.0, math.inf
    for i in range(first, points.shape[0] - 1):
        ax, ay = points[i, 0], points[i, 1]
        abx, aby = points[i + 1, 0] - ax, points[i + 1, 1] - ay
        length2 = max(abx * abx + aby * aby, 1e-12)
        t = min(max(((x - ax) * abx + (y - ay) * aby) / length2, 0.0), 1.0)
        d = math.hypot(ax + t * abx - x, ay + t * aby - y)
        if d < best_d:
            best, best_t, best_d = i, t, d
    return best, best_t, best_d

"""numba kernels of scan odometry: point-to-point ICP of a scan onto a local voxel map, in the
plane.

The method is KISS-ICP's (Vizzo et al., "KISS-ICP: In Defense of Point-to-Point ICP", RA-L
2023), written here for 2D scans: a scan thinned to one point per 1.5 voxels is aligned to the
local map from a constant-velocity guess, each point paired with the nearest map point in
its 3 x 3 neighbouring voxels within a gate, the pairs weighted by a Geman-McClure kernel;
then the scan, thinned less, is added to the map, and voxels beyond the sensor's range are
dropped.

The map is an open-addressing hash table (linear probing) of square voxels held in three
arrays the caller owns: ``keys`` (a voxel's packed cell indices; ``EMPTY`` where free,
``TOMBSTONE`` where a voxel was dropped), ``points`` (up to ``MAX_POINTS`` points a voxel,
[m]) and ``counts``. The table's length is a power of two, and the caller keeps its voxels
and tombstones together at most half of it (rehashing when they would be more), so a probe
always ends at a free slot.
Every kernel releases the interpreter lock: the daemon's event loop runs while a scan is
registered in a worker.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = [
    "EMPTY",
    "MAX_POINTS",
    "TOMBSTONE",
    "align",
    "best_yaw",
    "drop_far",
    "insert_points",
    "nearest",
    "rehash",
    "thin",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

# Two keys no cell within 2**31 voxels of the origin packs to:
EMPTY = np.iinfo(np.int64).min  # a free slot
TOMBSTONE = EMPTY + 1  # a dropped voxel's slot: probes go on past it
MAX_POINTS = 20  # points a voxel keeps at most
_MIX = 6364136223846793005  # an odd 64-bit multiplier (Knuth's MMIX LCG) to spread the keys


@njit(cache=True, nogil=True, inline="always")
def _key(ix: int, iy: int) -> int:
    """Two cell indices packed into one 64-bit key (32 bits each, two's complement)."""
    return (ix << 32) | (iy & 0xFFFFFFFF)


@njit(cache=True, nogil=True, inline="always")
def _slot(keys: IntArray, key: int) -> int:
    """The slot holding ``key``, or ``-1 - s`` with ``s`` the free slot it would take."""
    mask = keys.shape[0] - 1
    h = key * _MIX
    i = (h ^ (h >> 29)) & mask
    while True:
        k = keys[i]
        if k == key:
            return int(i)
        if k == EMPTY:
            return int(-1 - i)
        i = (i + 1) & mask


@njit(cache=True, nogil=True)
def thin(points: FloatArray, voxel_m: float) -> FloatArray:
    """The first point of each ``voxel_m`` square cell, order kept (N x 2 [m])."""
    n = points.shape[0]
    size = 16
    while size < 2 * n:
        size *= 2
    seen = np.full(size, EMPTY, dtype=np.int64)
    kept = np.empty((n, 2))
    m = 0
    for i in range(n):
        key = _key(math.floor(points[i, 0] / voxel_m), math.floor(points[i, 1] / voxel_m))
        s = _slot(seen, key)
        if s < 0:
            seen[-1 - s] = key
            kept[m, 0] = points[i, 0]
            kept[m, 1] = points[i, 1]
            m += 1
    return kept[:m].copy()


@njit(cache=True, nogil=True)
def nearest(
    keys: IntArray,
    points: FloatArray,
    counts: IntArray,
    voxel_m: float,
    x: float,
    y: float,
    gate_m: float,
) -> tuple[float, float, float]:
    """The map point nearest to (x, y) [m] among the 3 x 3 voxels around it and within
    ``gate_m``: (its x, its y, the squared distance [m²]); the squared distance is +inf when
    there is none."""
    ix = math.floor(x / voxel_m)
    iy = math.floor(y / voxel_m)
    best = gate_m * gate_m
    found = False
    bx = by = 0.0
    for dx in range(-1, 2):
        for dy in range(-1, 2):
            s = _slot(keys, _key(ix + dx, iy + dy))
            if s < 0:
                continue
            for j in range(counts[s]):
                ex = points[s, j, 0] - x
                ey = points[s, j, 1] - y
                d2 = ex * ex + ey * ey
                if d2 <= best:
                    best, bx, by, found = d2, points[s, j, 0], points[s, j, 1], True
    return bx, by, (best if found else math.inf)


@njit(cache=True, nogil=True)
def best_yaw(
    source: FloatArray,
    keys: IntArray,
    points: FloatArray,
    counts: IntArray,
    voxel_m: float,
    guess: FloatArray,
    span_rad: float,
    step_rad: float,
    fine: bool,
) -> float:
    """[rad] The yaw within ``span_rad`` of the guess's (in steps of ``step_rad``; the
    guess's own wins a tie) at which ``source`` best meets the map. A point scores 1 if its
    voxel is in the map (coarse: one probe a point), or with ``fine``, ``1 - d² / voxel²``
    for the nearest map point d [m] away within a voxel.

    ICP pairs a point only with map points in the voxels around it, so it cannot mend a yaw
    more than a few tenths of a degree per metre of range off; this search can (a robot that
    starts or stops turning between two scans).
    """
    steps = int(span_rad / step_rad + 1e-9)
    v2 = voxel_m * voxel_m
    best, best_score = guess[2], -1.0
    for k in range(2 * steps + 1):
        offset = step_rad * ((k + 1) // 2) * (1 if k % 2 == 1 else -1)
        yaw = guess[2] + offset
        c, s = math.cos(yaw), math.sin(yaw)
        score = 0.0
        for i in range(source.shape[0]):
            px = c * source[i, 0] - s * source[i, 1] + guess[0]
            py = s * source[i, 0] + c * source[i, 1] + guess[1]
            if fine:
                _, _, d2 = nearest(keys, points, counts, voxel_m, px, py, voxel_m)
                if d2 < v2:
                    score += 1.0 - d2 / v2
            elif (
                _slot(
                    keys,
                    _key(math.floor(px / voxel_m), math.floor(py / voxel_m)),
                )
                >= 0
            ):
                score += 1.0
        if score > best_score:
            best, best_score = yaw, score
    return float(best)


@njit(cache=True, nogil=True)
def align(
    source: FloatArray,
    keys: IntArray,
    points: FloatArray,
    counts: IntArray,
    voxel_m: float,
    guess: FloatArray,
    gate_m: float,
    kernel_m: float,
    max_iterations: int,
    tolerance: float,
) -> tuple[FloatArray, int, int]:
    """The pose (x [m], y [m], yaw [rad]) that lays ``source`` (N x 2, robot frame [m]) on
    the map, by Gauss-Newton from ``guess`` (its yaw need not be wrapped; the result's is,
    once a step ran): each step pairs every point with its nearest map point within
    ``gate_m`` and weights the pair by the Geman-McClure kernel of scale
    ``kernel_m`` (``(k² / (k² + r²))²``, r the pair's distance). Stops when a step moves
    less than ``tolerance`` (metres and radians together), or after ``max_iterations``.

    Returns the pose, the iterations run and the pairs of the last step (0: nothing to
    align to; the guess comes back).
    """
    x, y, yaw = guess[0], guess[1], guess[2]
    k2 = kernel_m * kernel_m
    iterations = pairs = 0
    for _ in range(max_iterations):
        iterations += 1
        c, s = math.cos(yaw), math.sin(yaw)
        # The normal equations of the step: the robot moved by (tx, ty), turned by dyaw.
        h00 = h01 = h02 = h11 = h12 = h22 = 0.0
        g0 = g1 = g2 = 0.0
        pairs = 0
        for i in range(source.shape[0]):
            px = c * source[i, 0] - s * source[i, 1] + x
            py = s * source[i, 0] + c * source[i, 1] + y
            qx, qy, d2 = nearest(keys, points, counts, voxel_m, px, py, gate_m)
            if d2 == math.inf:
                continue
            pairs += 1
            w = k2 / (k2 + d2)
            w *= w
            rx, ry = px - qx, py - qy
            # The step turns about the robot, not the odometry frame's origin (which may be
            # kilometres away): with a = p - (x, y), the Jacobian rows are
            # d(px)/d(tx, ty, dyaw) = (1, 0, -ay) and d(py)/... = (0, 1, ax).
            ax, ay = px - x, py - y
            h00 += w
            h02 -= w * ay
            h11 += w
            h12 += w * ax
            h22 += w * (ax * ax + ay * ay)
            g0 += w * rx
            g1 += w * ry
            g2 += w * (ax * ry - ay * rx)
        if pairs < 3:
            break
        # Solve H d = -g for the symmetric 3 x 3 H (h01 is zero) by cofactors.
        c00 = h11 * h22 - h12 * h12
        c01 = h02 * h12 - h01 * h22
        c02 = h01 * h12 - h02 * h11
        det = h00 * c00 + h01 * c01 + h02 * c02
        if not det > 1e-12 * (h00 * h11 * h22 + 1e-300):
            break  # degenerate: nothing constrains some direction
        c11 = h00 * h22 - h02 * h02
        c12 = h01 * h02 - h00 * h12
        c22 = h00 * h11 - h01 * h01
        tx = -(c00 * g0 + c01 * g1 + c02 * g2) / det
        ty = -(c01 * g0 + c11 * g1 + c12 * g2) / det
        dyaw = -(c02 * g0 + c12 * g1 + c22 * g2) / det
        x, y = x + tx, y + ty
        yaw = math.atan2(math.sin(yaw + dyaw), math.cos(yaw + dyaw))
        if math.sqrt(tx * tx + ty * ty + dyaw * dyaw) < tolerance:
            break
    return np.array([x, y, yaw]), iterations, pairs


@njit(cache=True, nogil=True)
def insert_points(
    keys: IntArray,
    points: FloatArray,
    counts: IntArray,
    voxel_m: float,
    scan: FloatArray,
    pose: FloatArray,
    spacing_m: float,
) -> int:
    """Add ``scan`` (N x 2, robot frame [m]) seen from ``pose`` to the map: a point joins its
    voxel when the voxel has room and no point within ``spacing_m``. The caller leaves the
    table room for N new voxels. Returns how many voxels are new."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    spacing2 = spacing_m * spacing_m
    added = 0
    for i in range(scan.shape[0]):
        x = c * scan[i, 0] - s * scan[i, 1] + pose[0]
        y = s * scan[i, 0] + c * scan[i, 1] + pose[1]
        key = _key(math.floor(x / voxel_m), math.floor(y / voxel_m))
        slot = _slot(keys, key)
        if slot < 0:
            slot = -1 - slot
            keys[slot] = key
            counts[slot] = 0
            added += 1
        n = counts[slot]
        if n >= points.shape[1]:
            continue
        close = False
        for j in range(n):
            ex, ey = points[slot, j, 0] - x, points[slot, j, 1] - y
            if ex * ex + ey * ey < spacing2:
                close = True
                break
        if not close:
            points[slot, n, 0] = x
            points[slot, n, 1] = y
            counts[slot] = n + 1
    return added


@njit(cache=True, nogil=True)
def drop_far(keys: IntArray, points: FloatArray, x: float, y: float, reach_m: float) -> int:
    """Drop every voxel whose first point is beyond ``reach_m`` of (x, y) [m] (its slot
    becomes a tombstone, which probes pass over); returns how many were dropped."""
    reach2 = reach_m * reach_m
    dropped = 0
    for s in range(keys.shape[0]):
        if keys[s] > TOMBSTONE:  # a voxel
            ex, ey = points[s, 0, 0] - x, points[s, 0, 1] - y
            if ex * ex + ey * ey > reach2:
                keys[s] = TOMBSTONE
                dropped += 1
    return dropped


@njit(cache=True, nogil=True)
def rehash(
    keys: IntArray,
    points: FloatArray,
    counts: IntArray,
    into_keys: IntArray,
    into_points: FloatArray,
    into_counts: IntArray,
) -> int:
    """Copy every voxel into the empty ``into_*`` table (of any power-of-two length with
    room for them), leaving the tombstones behind; returns how many were copied."""
    into_keys[:] = EMPTY
    kept = 0
    for s in range(keys.shape[0]):
        key = keys[s]
        if key <= TOMBSTONE:  # free, or a dropped voxel's
            continue
        t = -1 - _slot(into_keys, key)
        into_keys[t] = key
        n = counts[s]
        into_counts[t] = n
        into_points[t, :n] = points[s, :n]
        kept += 1
    return kept

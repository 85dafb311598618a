"""Numba kernels of the DWA local planner: obstacle look-up structures, rollouts, choice.

Obstacles near the robot arrive as points in the map frame (scan hits and costmap obstacle
cells). Two structures make them cheap to test against thousands of footprint poses:

- a local distance grid (chamfer transform, steps 1 and sqrt 2 cells): a lower bound on the
  distance from any pose to the nearest point, so a pose far from everything is cleared with
  one look-up;
- buckets (points sorted by square cell, CSR layout): the exact footprint test for poses
  close to something reads only the points in the 3 x 3 buckets around the pose.

The points are first gathered from around the robot and merged into small cells
(``snap_near``), and the (v, ω) samples are drawn from the dynamic window
(``window_samples``) in one call each: a control cycle made of dozens of small NumPy calls
cost three times as much in the daemon, between the other threads' work, as alone.

NumPy formulations of the dynamic window and the snapping are checked against the kernels in
tests/planning/test_dwa.py.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from navd.geometry import footprint_distance
from navd.geometry import wrap_angle_kernel as wrap

__all__ = [
    "CHAMFER_RATIO",
    "CLEARANCE",
    "GOAL",
    "HEADING",
    "METRICS",
    "OSCILLATION",
    "PATH",
    "bucket_points",
    "chamfer_distance",
    "choose",
    "rollouts",
    "snap_near",
    "window_samples",
]

FloatArray = npt.NDArray[np.float64]
Float32Array = npt.NDArray[np.float32]
IntArray = npt.NDArray[np.int64]

# Metric columns (seed 001 §3.11): goal proximity, closeness to the global path, obstacle
# clearance, oscillation, target-heading alignment. Collisions reject a rollout outright.
GOAL, PATH, CLEARANCE, OSCILLATION, HEADING = range(5)
METRICS = 5
# The longest ratio of an 8-connected path length to the straight distance (at 22.5°).
CHAMFER_RATIO = 1.0 / math.cos(math.pi / 8.0)
SQRT2 = math.sqrt(2.0)


@njit(cache=True, nogil=True)
def window_samples(
    v_now: float,
    w_now: float,
    dv: float,
    dw: float,
    band_lo: float,
    band_hi: float,
    linear_samples: int,
    angular_samples: int,
    min_speed: float,
    rotate_only: bool,
    backward: bool,
    max_yaw: float,
    table_speeds: FloatArray,
    table_rates: FloatArray,
) -> FloatArray:
    """K x 2 (v, ω) samples [m/s, rad/s] of the dynamic window around (v_now, w_now).

    Speeds: ``linear_samples`` across the part of [band_lo, band_hi] within ``dv`` of v_now
    (out of reach: the one step towards the band); turning on the spot (``rotate_only``):
    the speed nearest 0 within reach; forward with ``min_speed`` > 0: only those at least that
    fast (or the top one). Each speed takes ``angular_samples`` yaw rates across what ``dw``
    reaches of its cap: ``max_yaw``, and the yaw-rate table (|v| -> top rate, linearly
    interpolated) where it has entries; a yaw rate beyond the cap eases off towards it.

    Args:
        v_now, w_now: [m/s, rad/s] the command in force.
        dv, dw: [m/s, rad/s] what the accelerations change in one control period.
        band_lo, band_hi: [m/s] the speeds allowed (forward: 0 to the profile's cap;
            backing out: negative).
        linear_samples, angular_samples: samples across the window.
        min_speed: [m/s] least forward |v| (stuck handling), 0 for any.
        rotate_only, backward: turning on the spot; backing out.
        max_yaw: [rad/s] the robot's top yaw rate.
        table_speeds, table_rates: [m/s, rad/s] the yaw-rate table (empty: none).
    """
    lo, hi = max(band_lo, v_now - dv), min(band_hi, v_now + dv)
    if lo > hi:  # the band lies out of reach this period: change speed towards it
        lo = v_now - dv if band_hi < v_now - dv else v_now + dv
        hi = lo
    if rotate_only:
        speeds = np.array([min(max(0.0, v_now - dv), v_now + dv)])
    else:
        speeds = _linspace(lo, hi, linear_samples)
    if not backward and min_speed > 0.0:
        least = min(min_speed, abs(hi))
        keep = np.abs(speeds) >= least
        speeds = speeds[keep] if keep.any() else speeds[-1:]
    if table_speeds.size > 0:
        caps = np.minimum(max_yaw, np.interp(np.abs(speeds), table_speeds, table_rates))
    else:
        caps = np.full(speeds.size, max_yaw)
    fractions = _linspace(0.0, 1.0, angular_samples)
    out = np.empty((speeds.size * angular_samples, 2))
    for i in range(speeds.size):
        cap = caps[i]
        w_lo = max(-cap, w_now - dw)
        w_hi = min(cap, w_now + dw)
        if w_lo > w_hi:  # turning faster than this speed allows: ease off towards its cap
            w_lo = min(max(w_now, -cap), cap)
            w_hi = w_lo
        for j in range(angular_samples):
            out[i * angular_samples + j, 0] = speeds[i]
            out[i * angular_samples + j, 1] = w_lo + (w_hi - w_lo) * fractions[j]
    return out


@njit(cache=True, nogil=True)
def _linspace(start: float, stop: float, num: int) -> FloatArray:
    """NumPy's ``linspace`` with its rounding: start + i * ((stop - start) / (num - 1)), the
    last one ``stop`` exactly (numba's own rounds otherwise)."""
    out = np.empty(num)
    step = (stop - start) / (num - 1) if num > 1 else 0.0
    for i in range(num):
        out[i] = i * step + start
    if num > 1:
        out[num - 1] = stop
    return out


@njit(cache=True, nogil=True)
def snap_near(points: FloatArray, x: float, y: float, half: float, snap: float) -> FloatArray:
    """[m] the centres of the ``snap`` [m] cells holding the ``points`` [m, N x 2] within the
    square of half-size ``half`` [m] around (x, y) [m], each once, in the order of their
    packed (column, row) keys."""
    keys = np.empty(points.shape[0], dtype=np.int64)
    n = 0
    for k in range(points.shape[0]):
        px, py = points[k, 0], points[k, 1]
        if abs(px - x) <= half and abs(py - y) <= half:
            col = np.int64(math.floor(px / snap))
            row = np.int64(math.floor(py / snap))
            keys[n] = (col << 32) + (row & 0xFFFFFFFF)
            n += 1
    keys = np.sort(keys[:n])
    out = np.empty((n, 2))
    m = 0
    for k in range(n):
        if k > 0 and keys[k] == keys[k - 1]:
            continue
        col = keys[k] >> 32
        row = keys[k] & 0xFFFFFFFF
        if row >= 1 << 31:
            row -= 1 << 32
        out[m, 0] = (col + 0.5) * snap
        out[m, 1] = (row + 0.5) * snap
        m += 1
    return out[:m]


@njit(cache=True, nogil=True)
def chamfer_distance(
    points: FloatArray, origin_x: float, origin_y: float, res: float, rows: int, cols: int
) -> Float32Array:
    """[m] 8-connected chamfer distance from each cell centre to the nearest occupied cell.

    A cell is occupied if a point falls in it. The result d satisfies
    d / CHAMFER_RATIO - res * sqrt 2 <= true distance to the nearest point (the points may
    lie anywhere in their cells); cells beyond every point keep a large value.
    """
    big = np.float32(1e9)
    grid = np.full((rows, cols), big, dtype=np.float32)
    for k in range(points.shape[0]):
        c = math.floor((points[k, 0] - origin_x) / res)
        r = math.floor((points[k, 1] - origin_y) / res)
        if 0 <= r < rows and 0 <= c < cols:
            grid[r, c] = 0.0
    diag = np.float32(SQRT2 * res)
    step = np.float32(res)
    for r in range(rows):
        for c in range(cols):
            d = grid[r, c]
            if c > 0:
                d = min(d, grid[r, c - 1] + step)
            if r > 0:
                d = min(d, grid[r - 1, c] + step)
                if c > 0:
                    d = min(d, grid[r - 1, c - 1] + diag)
                if c < cols - 1:
                    d = min(d, grid[r - 1, c + 1] + diag)
            grid[r, c] = d
    for r in range(rows - 1, -1, -1):
        for c in range(cols - 1, -1, -1):
            d = grid[r, c]
            if c < cols - 1:
                d = min(d, grid[r, c + 1] + step)
            if r < rows - 1:
                d = min(d, grid[r + 1, c] + step)
                if c < cols - 1:
                    d = min(d, grid[r + 1, c + 1] + diag)
                if c > 0:
                    d = min(d, grid[r + 1, c - 1] + diag)
            grid[r, c] = d
    return grid


@njit(cache=True, nogil=True)
def bucket_points(
    points: FloatArray, origin_x: float, origin_y: float, size: float, rows: int, cols: int
) -> tuple[IntArray, IntArray]:
    """Sort points into square buckets of ``size`` [m] (compressed rows).

    Returns:
        (start, order): the points of bucket b = row * cols + col are
        ``points[order[start[b]:start[b + 1]]]``. Points outside the buckets are left out.
    """
    n = points.shape[0]
    bucket = np.empty(n, dtype=np.int64)
    start = np.zeros(rows * cols + 1, dtype=np.int64)
    for k in range(n):
        c = math.floor((points[k, 0] - origin_x) / size)
        r = math.floor((points[k, 1] - origin_y) / size)
        if 0 <= r < rows and 0 <= c < cols:
            bucket[k] = r * cols + c
            start[bucket[k] + 1] += 1
        else:
            bucket[k] = -1
    for b in range(rows * cols):
        start[b + 1] += start[b]
    fill = start[:-1].copy()
    order = np.empty(start[-1], dtype=np.int64)
    for k in range(n):
        b = bucket[k]
        if b >= 0:
            order[fill[b]] = k
            fill[b] += 1
    return start, order


@njit(cache=True, nogil=True)
def _nearest(
    points: FloatArray,
    bucket_start: IntArray,
    bucket_order: IntArray,
    local: FloatArray,
    x: float,
    y: float,
    cos_yaw: float,
    sin_yaw: float,
    kind: int,
    half_length: float,
    half_width: float,
) -> float:
    """[m] exact distance from the footprint at (x, y) heading (cos_yaw, sin_yaw) to the
    nearest point within one bucket width of (x, y) (1e9 when there is none).

    The buckets are circumradius + margin wide, so every point that can come within the margin
    of the footprint is within one bucket width of its centre."""
    bucket = local[5]
    b_rows = int(local[6])
    b_cols = int(local[7])
    bc = math.floor((x - local[0]) / bucket)
    br = math.floor((y - local[1]) / bucket)
    reach2 = bucket * bucket
    nearest = 1e9
    for rr in range(max(br - 1, 0), min(br + 2, b_rows)):
        for cc in range(max(bc - 1, 0), min(bc + 2, b_cols)):
            b = rr * b_cols + cc
            for i in range(bucket_start[b], bucket_start[b + 1]):
                q = bucket_order[i]
                dx = points[q, 0] - x
                dy = points[q, 1] - y
                if dx * dx + dy * dy > reach2:
                    continue  # cheaper than the footprint test, and too far to matter
                d = footprint_distance(
                    points[q, 0],
                    points[q, 1],
                    x,
                    y,
                    cos_yaw,
                    sin_yaw,
                    kind,
                    half_length,
                    half_width,
                )
                nearest = min(nearest, d)
    return nearest


@njit(cache=True, nogil=True)
def rollouts(
    pose: FloatArray,
    velocities: FloatArray,
    dt: float,
    steps: int,
    footprint: FloatArray,
    points: FloatArray,
    local: FloatArray,
    distance: Float32Array,
    bucket_start: IntArray,
    bucket_order: IntArray,
    path_field: Float32Array,
    path_frame: FloatArray,
    target: FloatArray,
    metrics: FloatArray,
    colliding: npt.NDArray[np.bool_],
) -> None:
    """Roll out each (v, ω) for ``steps`` steps of ``dt`` and score it.

    Each rollout holds (v, ω) constant from ``pose`` (x, y, yaw): exact arcs, no integration
    error. A rollout collides if at any step an obstacle point is closer than the margin to
    the footprint; a robot already closer than the margin (pushed, or an obstacle came to it)
    may still move, as long as no step comes closer than it is now. The metrics (lower is
    better, seed 001 §3.11):

    - GOAL: squared distance [m²] from the last pose to the target point;
    - PATH: mean distance [m] of the poses to the global path;
    - CLEARANCE: 1 / (smallest clearance [m] along the rollout, within [0.01, cap]): exact
      near obstacles, else the distance grid's value at the centre minus the inscribed radius;
    - OSCILLATION: |v - v_prev| / v_span + |ω - ω_prev| / ω_span, plus 1 when ω reverses;
    - HEADING: |last yaw - target yaw| / (π/2).

    Args:
        pose: [x m, y m, yaw rad].
        velocities: K x 2 (v m/s, ω rad/s).
        dt, steps: [s] rollout step and count.
        footprint: [kind, half_length m, half_width m, circumradius m, margin m, clearance
            cap m, inscribed radius m].
        points: M x 2 obstacle points [m].
        local: [origin x m, origin y m, cell m, rows, cols, bucket m, bucket rows,
            bucket cols] of the distance grid and the buckets (same origin; buckets at least
            circumradius + margin wide, so the 3 x 3 around a pose hold every point that can
            touch it).
        distance: the chamfer grid of ``points``.
        bucket_start, bucket_order: ``bucket_points`` of ``points``.
        path_field: [m] distance to the global path on a grid.
        path_frame: [origin x m, origin y m, cell m, value outside m] of ``path_field``.
        target: [x m, y m, yaw rad, v_prev m/s, ω_prev rad/s, v_span m/s, ω_span rad/s].
        metrics: K x METRICS, written.
        colliding: K flags, written.
    """
    kind = int(footprint[0])
    half_length = footprint[1]
    half_width = footprint[2]
    circumradius = footprint[3]
    margin = footprint[4]
    cap = footprint[5]
    inscribed = footprint[6]
    ox = local[0]
    oy = local[1]
    cell = local[2]
    rows = int(local[3])
    cols = int(local[4])
    p_rows, p_cols = path_field.shape
    slack = cell * SQRT2
    x0 = pose[0]
    y0 = pose[1]
    yaw0 = pose[2]
    # A robot already inside the margin may move, but never closer than it is.
    cos0 = math.cos(yaw0)
    sin0 = math.sin(yaw0)
    here = _nearest(
        points, bucket_start, bucket_order, local, x0, y0, cos0, sin0, kind, half_length, half_width
    )
    allowed = min(margin, here - 1e-3)
    for k in range(velocities.shape[0]):
        v = velocities[k, 0]
        w = velocities[k, 1]
        hit = False
        clearance = cap
        path_sum = 0.0
        x = x0
        y = y0
        # The heading turns by w dt each step: rotate (cos, sin) instead of calling trig.
        step_cos = math.cos(w * dt)
        step_sin = math.sin(w * dt)
        cos_yaw = cos0
        sin_yaw = sin0
        for s in range(1, steps + 1):
            t = s * dt
            cos_yaw, sin_yaw = (
                cos_yaw * step_cos - sin_yaw * step_sin,
                sin_yaw * step_cos + cos_yaw * step_sin,
            )
            if abs(w) < 1e-9:
                x = x0 + v * t * cos0
                y = y0 + v * t * sin0
            else:
                x = x0 + v / w * (sin_yaw - sin0)
                y = y0 - v / w * (cos_yaw - cos0)
            # Obstacles: a lower bound from the distance grid, the exact footprint test only
            # when something may be within the margin.
            c = math.floor((x - ox) / cell)
            r = math.floor((y - oy) / cell)
            center = 1e9
            if 0 <= r < rows and 0 <= c < cols:
                center = distance[r, c] / CHAMFER_RATIO
            clearance = min(clearance, center - inscribed)
            if center - slack < circumradius + margin:
                nearest = _nearest(
                    points,
                    bucket_start,
                    bucket_order,
                    local,
                    x,
                    y,
                    cos_yaw,
                    sin_yaw,
                    kind,
                    half_length,
                    half_width,
                )
                clearance = min(clearance, nearest)
                if nearest < allowed:
                    hit = True
                    break
            # Closeness to the global path.
            pc = math.floor((x - path_frame[0]) / path_frame[2])
            pr = math.floor((y - path_frame[1]) / path_frame[2])
            if 0 <= pr < p_rows and 0 <= pc < p_cols:
                path_sum += path_field[pr, pc]
            else:
                path_sum += path_frame[3]
        colliding[k] = hit
        metrics[k, GOAL] = (x - target[0]) ** 2 + (y - target[1]) ** 2
        metrics[k, PATH] = path_sum / steps
        metrics[k, CLEARANCE] = 1.0 / min(max(clearance, 0.01), cap)
        reverse = 1.0 if w * target[4] < 0.0 else 0.0
        metrics[k, OSCILLATION] = (
            abs(v - target[3]) / target[5] + abs(w - target[4]) / target[6] + reverse
        )
        yaw = yaw0 + w * steps * dt
        metrics[k, HEADING] = abs(wrap(yaw - target[2])) / (0.5 * math.pi)


@njit(cache=True, nogil=True)
def choose(
    metrics: FloatArray, colliding: npt.NDArray[np.bool_], weights: FloatArray
) -> tuple[int, FloatArray]:
    """The best rollout by the normalized weighted cost (seed 001 eq. 3.5 to 3.6).

    Each metric is min-max normalized over the rollouts that do not collide (0 when they all
    agree), weighted and summed; the lowest total wins.

    Returns:
        (index of the best rollout or -1 when every rollout collides, totals: inf where
        colliding).
    """
    k_count = metrics.shape[0]
    totals = np.full(k_count, np.inf)
    lo = np.full(METRICS, np.inf)
    hi = np.full(METRICS, -np.inf)
    for k in range(k_count):
        if colliding[k]:
            continue
        for m in range(METRICS):
            lo[m] = min(lo[m], metrics[k, m])
            hi[m] = max(hi[m], metrics[k, m])
    best = -1
    best_total = np.inf
    for k in range(k_count):
        if colliding[k]:
            continue
        total = 0.0
        for m in range(METRICS):
            span = hi[m] - lo[m]
            if span > 0.0:
                total += weights[m] * (metrics[k, m] - lo[m]) / span
        totals[k] = total
        if total < best_total:
            best_total = total
            best = k
    return best, totals

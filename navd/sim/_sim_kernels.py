"""Numba kernels of the simulator: lidar ray casting and footprint contact on a fine grid.

The world is a boolean occupancy grid (row = y) plus moving discs. NumPy twins live in
tests/sim/sim_reference.py.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from navd.geometry import footprint_distance

__all__ = ["cast_rays", "footprint_contact"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@njit(cache=True, nogil=True)
def cast_rays(
    grid: BoolArray,
    origin_x: float,
    origin_y: float,
    res: float,
    x: float,
    y: float,
    angles: FloatArray,
    max_range: float,
    discs: FloatArray,
) -> FloatArray:
    """[m] the range along each ray from (x, y) to the first occupied cell or disc.

    Grid cells are walked exactly (Amanatides and Woo); a ray enters an occupied cell at the
    returned range. Discs (K x 3: centre x, y and radius [m]) are intersected analytically.
    Rays that hit nothing within ``max_range`` return inf.

    Args:
        grid: rows x cols, True where occupied.
        origin_x, origin_y: [m] the corner of cell (0, 0).
        res: [m] cell size.
        x, y: [m] the sensor's position.
        angles: [rad] the rays' directions in the world frame.
        max_range: [m] longest range returned.
        discs: K x 3 moving obstacles.
    """
    rows, cols = grid.shape
    out = np.full(angles.size, np.inf)
    gx = (x - origin_x) / res
    gy = (y - origin_y) / res
    for k in range(angles.size):
        dx = math.cos(angles[k])
        dy = math.sin(angles[k])
        best = max_range
        # Grid traversal in cell units.
        c = math.floor(gx)
        r = math.floor(gy)
        step_c = 1 if dx > 0 else -1
        step_r = 1 if dy > 0 else -1
        t_dc = abs(1.0 / dx) if dx != 0.0 else np.inf
        t_dr = abs(1.0 / dy) if dy != 0.0 else np.inf
        next_c = ((c + 1 - gx) if dx > 0 else (gx - c)) * t_dc if dx != 0.0 else np.inf
        next_r = ((r + 1 - gy) if dy > 0 else (gy - r)) * t_dr if dy != 0.0 else np.inf
        t = 0.0
        limit = max_range / res
        while t <= limit:
            if 0 <= r < rows and 0 <= c < cols:
                if grid[r, c]:
                    best = min(best, t * res)
                    break
            elif (
                (c < 0 and step_c < 0)
                or (c >= cols and step_c > 0)
                or (r < 0 and step_r < 0)
                or (r >= rows and step_r > 0)
            ):
                break  # outside the grid and moving away from it
            if next_c < next_r:
                t = next_c
                next_c += t_dc
                c += step_c
            else:
                t = next_r
                next_r += t_dr
                r += step_r
        for j in range(discs.shape[0]):
            # |p + t d - centre| = radius, smallest t > 0.
            ox = x - discs[j, 0]
            oy = y - discs[j, 1]
            b = ox * dx + oy * dy
            cc = ox * ox + oy * oy - discs[j, 2] ** 2
            disc = b * b - cc
            if disc >= 0.0:
                hit = -b - math.sqrt(disc)
                if hit > 0.0:
                    best = min(best, hit)
        if best < max_range:
            out[k] = best
    return out


@njit(cache=True, nogil=True)
def footprint_contact(
    grid: BoolArray,
    origin_x: float,
    origin_y: float,
    res: float,
    x: float,
    y: float,
    yaw: float,
    kind: int,
    half_length: float,
    half_width: float,
    discs: FloatArray,
) -> float:
    """[m] clearance of the footprint at (x, y, yaw) to the world: the distance from the
    footprint to the nearest occupied cell centre or disc edge, negative when overlapping.

    Only cells within the footprint's circumradius + 0.5 m are looked at; farther clearance is
    reported as 0.5 m + what was seen (a cap, not an exact value).

    Args:
        kind: 0 circle (radius half_length), 1 rectangle.
        half_length, half_width: [m] the footprint's half extents.
    """
    rows, cols = grid.shape
    reach = math.hypot(half_length, half_width) + 0.5
    c0 = max(math.floor((x - reach - origin_x) / res), 0)
    c1 = min(math.floor((x + reach - origin_x) / res), cols - 1)
    r0 = max(math.floor((y - reach - origin_y) / res), 0)
    r1 = min(math.floor((y + reach - origin_y) / res), rows - 1)
    cos_yaw = math.cos(yaw)
    sin_yaw = math.sin(yaw)
    best = 0.5
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            if not grid[r, c]:
                continue
            px = origin_x + (c + 0.5) * res - x
            py = origin_y + (r + 0.5) * res - y
            best = min(
                best,
                footprint_distance(
                    px, py, 0.0, 0.0, cos_yaw, sin_yaw, kind, half_length, half_width
                ),
            )
    for j in range(discs.shape[0]):
        # The disc's centre distance minus its radius (exact for a circle footprint; for a
        # rectangle, the distance to the rectangle minus the radius).
        d = footprint_distance(
            discs[j, 0], discs[j, 1], x, y, cos_yaw, sin_yaw, kind, half_length, half_width
        )
        best = min(best, d - discs[j, 2])
    return best

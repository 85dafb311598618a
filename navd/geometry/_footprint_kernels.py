"""The footprint's distance for numba kernels: how far a point is from the robot's outline
(a circle or a rectangle) at a pose, for the local planner's rollouts, the collision guard's
sweep and the simulator's contacts."""

from __future__ import annotations

import math

from numba import njit

__all__ = ["footprint_distance"]


@njit(cache=True, nogil=True, inline="always")
def footprint_distance(
    px: float,
    py: float,
    x: float,
    y: float,
    cos_yaw: float,
    sin_yaw: float,
    kind: int,
    half_length: float,
    half_width: float,
) -> float:
    """[m] signed distance from point (px, py) to a footprint at (x, y, yaw); < 0 inside.

    kind 0 is a circle of radius half_length; kind 1 a rectangle of half extents
    (half_length, half_width) along the robot's x and y.
    """
    dx = px - x
    dy = py - y
    if kind == 0:
        return math.sqrt(dx * dx + dy * dy) - half_length
    qx = abs(cos_yaw * dx + sin_yaw * dy) - half_length
    qy = abs(-sin_yaw * dx + cos_yaw * dy) - half_width
    outside = math.sqrt(max(qx, 0.0) ** 2 + max(qy, 0.0) ** 2)
    return outside + min(max(qx, qy), 0.0)

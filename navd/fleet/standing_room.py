"""Whether the robot can stand at a place on its map: a node whose place the map shows
taken by a wall or another obstacle (within the robot's radius) is refused when the order
comes (an ``orderError`` naming it), not found out by the planner seconds into the drive.
Unknown cells do not count: a map still being made is no reason to refuse."""

from __future__ import annotations

import math

import numpy as np

from navd.lifecycle.messages import MapUpdate

__all__ = ["OCCUPIED_PERCENT", "StandingRoom"]

OCCUPIED_PERCENT = 65  # a cell this likely occupied is taken (the planner's threshold)


class StandingRoom:
    """The latest map, and where on it the robot's disc of ``radius_m`` [m] fits."""

    def __init__(self, radius_m: float) -> None:
        self.radius_m = radius_m
        self._map: MapUpdate | None = None

    def take(self, update: MapUpdate) -> None:
        """The map as it is now (kept by reference: it is read-only)."""
        self._map = update

    def blocked(self, x_m: float, y_m: float) -> bool:
        """Whether an occupied cell lies within the robot's radius of (x, y) on the map;
        False with no map yet or off the map."""
        grid = self._map
        if grid is None:
            return False
        res = grid.resolution_m
        reach = math.ceil(self.radius_m / res)
        col = math.floor((x_m - grid.origin_x_m) / res)
        row = math.floor((y_m - grid.origin_y_m) / res)
        rows, cols = grid.occupancy.shape
        r0, r1 = max(row - reach, 0), min(row + reach + 1, rows)
        c0, c1 = max(col - reach, 0), min(col + reach + 1, cols)
        if r0 >= r1 or c0 >= c1:
            return False
        window = grid.occupancy[r0:r1, c0:c1]
        ys = grid.origin_y_m + (np.arange(r0, r1) + 0.5) * res - y_m
        xs = grid.origin_x_m + (np.arange(c0, c1) + 0.5) * res - x_m
        inside = ys[:, None] ** 2 + xs[None, :] ** 2 <= self.radius_m**2
        return bool(np.any((window >= OCCUPIED_PERCENT) & inside))

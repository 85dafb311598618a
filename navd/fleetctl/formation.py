"""Formations (seed 000): where each robot of a group stands around the group's centre, which
robot takes which place, and how far a group is from its shape.

Places are offsets in the group's frame (x along its heading, y to its left), centred on the
group's centre (their mean is zero), ``spacing_m`` apart between neighbours.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy.optimize import linear_sum_assignment

from navd.fleetctl.errors import GroupGoalError

__all__ = ["FORMATIONS", "Formation", "assign", "places", "shape_error", "slots"]

FloatArray = npt.NDArray[np.float64]
Formation = Literal["line", "column", "triangle"]
FORMATIONS: tuple[Formation, ...] = ("line", "column", "triangle")


def slots(kind: Formation, count: int, spacing_m: float) -> FloatArray:
    """[m] count x 2 offsets of the places in the group's frame.

    - line: side by side, across the heading;
    - column: one behind another, along it;
    - triangle: rows of 1, 2, 3... robots behind the first, each row ``spacing_m`` *
      sqrt(3)/2 behind the one before (equilateral triangles of side ``spacing_m``).
    """
    if count < 1:
        raise GroupGoalError(f"a formation needs at least one robot, got {count}")
    k = np.arange(count, dtype=np.float64)
    if kind == "line":
        offsets = np.column_stack([np.zeros(count), ((count - 1) / 2.0 - k) * spacing_m])
    elif kind == "column":
        offsets = np.column_stack([((count - 1) / 2.0 - k) * spacing_m, np.zeros(count)])
    elif kind == "triangle":
        rows: list[tuple[float, float]] = []
        row = 0
        while len(rows) < count:
            for j in range(row + 1):
                rows.append((-row * spacing_m * math.sqrt(3.0) / 2.0, (row / 2.0 - j) * spacing_m))
            row += 1
        offsets = np.array(rows[:count])
    else:
        raise GroupGoalError(f"unknown formation {kind!r}; known: {', '.join(FORMATIONS)}")
    centred: FloatArray = offsets - offsets.mean(axis=0)
    return centred


def places(center_xy_m: tuple[float, float], heading_rad: float, offsets: FloatArray) -> FloatArray:
    """[m] the places of ``offsets`` for a group centred at ``center_xy_m`` facing
    ``heading_rad``, in the map frame."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    rotation = np.array([[c, -s], [s, c]])
    placed: FloatArray = np.asarray(center_xy_m, dtype=np.float64) + offsets @ rotation.T
    return placed


def assign(robots_xy_m: FloatArray, places_xy_m: FloatArray) -> npt.NDArray[np.int64]:
    """For each robot, the index of its place: the assignment with the least total distance
    driven (Kuhn-Munkres)."""
    cost = np.hypot(
        robots_xy_m[:, None, 0] - places_xy_m[None, :, 0],
        robots_xy_m[:, None, 1] - places_xy_m[None, :, 1],
    )
    rows, cols = linear_sum_assignment(cost)
    order = np.empty(len(rows), dtype=np.int64)
    order[rows] = cols
    return order


def shape_error(robots_xy_m: FloatArray, offsets: FloatArray) -> float:
    """[m] how far the group is from its shape: the formation laid over the robots as well as
    it fits (the rotation and shift of least squares, Kabsch's), and the largest distance of
    a robot from its place in it. Free of where the group is and which way it faces."""
    if robots_xy_m.shape[0] < 2:
        return 0.0
    measured = robots_xy_m - robots_xy_m.mean(axis=0)
    wanted = offsets - offsets.mean(axis=0)
    h = wanted.T @ measured
    angle = math.atan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    c, s = math.cos(angle), math.sin(angle)
    laid = wanted @ np.array([[c, s], [-s, c]])
    return float(np.hypot(*(measured - laid).T).max())

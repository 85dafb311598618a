"""Replanning toward the same goal without a search, while the last route is still the best.

A route found by A* is the cheapest from its start, and so is every tail of it: the cheapest
route from any point on it to the goal is the rest of it. When the robot asks again for the
same goal (the replan timer, a detour it was pushed into) and stands on or beside the route,
the rest of the route from where it stands is the answer if the grid has not changed in a
way that could make it wrong:

- the frame, the goal and the search settings are the same;
- no cell the rest of the route passes over changed or is blocked, the step from the robot's
  cell onto it included (walked cell by cell from centre to centre as the smoothing walks
  its segments, with both cells beside a corner the line passes through);
- no cell got cheaper that a better route could pass through. A route through cell x costs
  at least octile(robot, x) + octile(x, goal) cells (a step never costs less than its
  length), so a cell that got cheaper matters only if that sum is below what the rest of the
  route costs; cells beyond that ellipse are ignored.

Then every other route costs at least what it cost when the route was chosen, and the rest
of the route is what a new search from its nearest point would find (within the search's
bound and the smoothing's slack). From the robot, up to ``max_offset_m`` beside the route,
it costs at most twice the offset's steps more than the best route from there: the best
route from the robot, with the step back to the route, is a route from the route.

The grids are compared cell by cell (the last cost array is kept by reference: costmaps are
built anew for every plan, never changed in place): about a millisecond on a 2000 x 2000
grid, against tens for a search.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.planning._astar_kernels import path_changed, route_costs_to_goal
from navd.planning.costmap import Costmap, GridFrame

__all__ = ["RouteMemory", "remembered_route", "route_costs"]

FloatArray = npt.NDArray[np.float64]
CellArray = npt.NDArray[np.int64]

SQRT2 = math.sqrt(2.0)
# [cells] Slack on the octile bound: the robot and the goal lie anywhere within their cells.
CELL_SLACK = 2.0


@dataclass(frozen=True, slots=True)
class RouteMemory:
    """A route as it was planned, with what it was planned on.

    Attributes:
        frame: the grid's frame.
        cost: the grid's cell costs (kept by reference, never changed).
        goal_xy_m: [m] the goal.
        cost_weight: A*'s weight of cell costs.
        smooth: whether the route was straightened.
        points_m: [m] N x 2 route from the start to the goal.
        to_goal: [cells] N costs of the rest of the route from each point (weighted).
    """

    frame: GridFrame
    cost: npt.NDArray[np.float32]
    goal_xy_m: tuple[float, float]
    cost_weight: float
    smooth: bool
    points_m: FloatArray
    to_goal: FloatArray


def route_costs(cost: npt.NDArray[np.float32], cells: CellArray, cost_weight: float) -> FloatArray:
    """[cells] Cost from each of an 8-connected route's cells to its last, as A* weighs steps:
    L * (1 + w * (c_a + c_b) / 2) for a step of length L from a to b."""
    return route_costs_to_goal(cost, np.ascontiguousarray(cells, dtype=np.int64), cost_weight)


def remembered_route(
    memory: RouteMemory | None,
    costmap: Costmap,
    *,
    start_xy_m: tuple[float, float],
    goal_xy_m: tuple[float, float],
    cost_weight: float,
    smooth: bool,
    max_offset_m: float,
) -> tuple[FloatArray, float] | None:
    """The rest of the remembered route from the robot, and its cost [cells], if it is still
    the best (module docstring); None when a search is needed."""
    if (
        memory is None
        or memory.frame != costmap.frame
        or memory.goal_xy_m != goal_xy_m
        or memory.cost_weight != cost_weight
        or memory.smooth != smooth
        or memory.points_m.shape[0] < 2
    ):
        return None
    points, to_goal = memory.points_m, memory.to_goal
    segment, along, offset_m = _nearest_segment(points, start_xy_m)
    if offset_m > max_offset_m:
        return None
    frame = costmap.frame
    rest = np.vstack([np.asarray(start_xy_m, dtype=np.float64), points[segment + 1 :]])
    # What the rest costs: from the robot's foot on the route on, with the step to it.
    ahead = to_goal[segment] + along * (to_goal[segment + 1] - to_goal[segment])
    cost = float(ahead) + offset_m / frame.resolution_m
    remaining = max(float(to_goal[segment]), cost)  # the more cautious, for the bound below
    new, old = costmap.cost, memory.cost
    cells = _inside(frame, frame.cells_of(rest))
    if cells is None or path_changed(new, old, cells):
        return None  # the rest of the route (or the step onto it) got costlier, or blocked
    cheaper = None if new is old else new < old
    if cheaper is not None and cheaper.any():
        rows, cols = np.nonzero(cheaper)
        if _could_shorten(
            frame, rows, cols, start_xy_m=start_xy_m, goal_xy_m=goal_xy_m, remaining=remaining
        ):
            return None
    return rest, cost


def _nearest_segment(points: FloatArray, xy: tuple[float, float]) -> tuple[int, float, float]:
    """(index of the polyline's segment nearest ``xy``, the fraction along it of the nearest
    point, the distance [m]); the last of equally near ones, so a robot at a vertex continues
    on the segment after it."""
    a = points[:-1]
    ab = points[1:] - a
    p = np.asarray(xy, dtype=np.float64)
    length2 = np.maximum((ab**2).sum(axis=1), 1e-12)
    t = np.clip(((p - a) * ab).sum(axis=1) / length2, 0.0, 1.0)
    d = np.hypot(*(a + t[:, None] * ab - p).T)
    i = int(d.size - 1 - np.argmin(d[::-1]))
    return i, float(t[i]), float(d[i])


def _inside(frame: GridFrame, cells: CellArray) -> CellArray | None:
    """``cells`` if every one lies in the grid, else None."""
    rows, cols = cells[:, 0], cells[:, 1]
    if (
        (rows < 0).any()
        or (rows >= frame.rows).any()
        or (cols < 0).any()
        or (cols >= frame.cols).any()
    ):
        return None
    return cells


def _could_shorten(
    frame: GridFrame,
    rows: npt.NDArray[np.intp],
    cols: npt.NDArray[np.intp],
    *,
    start_xy_m: tuple[float, float],
    goal_xy_m: tuple[float, float],
    remaining: float,
) -> bool:
    """True if a route through any of the cells (rows, cols) could cost less than
    ``remaining`` [cells]: its octile length via the cell is the least it can cost."""
    sr, sc = frame.cell_of(*start_xy_m)
    gr, gc = frame.cell_of(*goal_xy_m)
    least = _octile(rows - sr, cols - sc) + _octile(rows - gr, cols - gc)
    return bool(np.any(least < remaining + CELL_SLACK))


def _octile(dr: npt.NDArray[np.intp], dc: npt.NDArray[np.intp]) -> FloatArray:
    """[cells] Length of the shortest 8-connected route over (dr, dc)."""
    a, b = np.abs(dr), np.abs(dc)
    return np.maximum(a, b) + (SQRT2 - 1.0) * np.minimum(a, b)

"""The global planner: A* over the costmap from the robot to the goal, optionally smoothed."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.planning._astar_kernels import shortcut
from navd.planning.cell_search import CellSearch
from navd.planning.costmap import Costmap
from navd.planning.errors import GoalUnreachableError, StartBlockedError
from navd.planning.route_reuse import RouteMemory, remembered_route, route_costs

__all__ = ["GlobalPlanner", "PlannedPath", "SearchSettings", "path_length"]

FloatArray = npt.NDArray[np.float64]

# Smoothing may raise the route's cost by this much on the 0..1 scale, and jumps at most this
# many cells at once.
SMOOTH_SLACK = 0.05
SMOOTH_REACH_CELLS = 200
# A robot too close to an obstacle plans from the nearest free cell this near [m].
START_ESCAPE_M = 0.5
# A replan toward the same goal continues the last route if the robot is this near it [m]
# and nothing changed that could make it wrong (``reuse``).
REUSE_OFFSET_M = 0.15


@dataclass(frozen=True, slots=True)
class PlannedPath:
    """A route found by A*.

    Attributes:
        points_m: [m] N x 2 map points from the robot to the goal.
        cost: [m] A* route cost: length weighted by the cells' costs.
        cells_expanded: how many cells the search expanded (0 when reused): jump points, or
            cells taken out of buckets (not those a pass along floor went over).
        reused: the rest of the last route toward the same goal, still the best (``reuse``).
        fine_length_m: [m] for a far goal (``horizon``), how much of the route, from the
            robot on, was planned at full resolution (the rest is coarse); None: all of it.
    """

    points_m: FloatArray
    cost: float
    cells_expanded: int
    reused: bool = False
    fine_length_m: float | None = None

    @property
    def length_m(self) -> float:
        """[m] length of the polyline."""
        return path_length(self.points_m)


def path_length(points_m: FloatArray) -> float:
    """[m] length of an N x 2 polyline."""
    if points_m.shape[0] < 2:
        return 0.0
    return float(np.hypot(*np.diff(points_m, axis=0).T).sum())


@dataclass(frozen=True, slots=True)
class SearchSettings:
    """How A* weighs and shapes a route.

    Attributes:
        cost_weight: w in the step cost L * (1 + w * mean cell cost).
        smooth: straighten the route by line of sight.
    """

    cost_weight: float
    smooth: bool


class GlobalPlanner:
    """A* from the robot to a goal, with working memory kept between searches and the last
    route continued while it is still the best (one search at a time; see ``cell_search``
    and ``reuse``)."""

    def __init__(self) -> None:
        self._search = CellSearch()
        self._last: RouteMemory | None = None

    def forget_last_route(self) -> None:
        """Search afresh on the next plan (the benchmarks time searches, not reuse)."""
        self._last = None

    def plan(
        self,
        costmap: Costmap,
        start_xy_m: tuple[float, float],
        goal_xy_m: tuple[float, float],
        settings: SearchSettings,
    ) -> PlannedPath:
        """The cheapest route from ``start_xy_m`` to ``goal_xy_m`` [m, map frame], weighed and
        shaped as ``settings`` say.

        Raises:
            StartBlockedError: the start is off the map, or too close to obstacles with no free cell
                within START_ESCAPE_M.
            GoalUnreachableError: the goal is off the map ("off the map"), unexplored while
                unknown cells are forbidden ("unknown"), too close to an obstacle or in a
                keep-out zone ("occupied"), or no route leads there ("no route").
        """
        frame = costmap.frame
        weight = settings.cost_weight
        rest = remembered_route(
            self._last,
            costmap,
            start_xy_m=start_xy_m,
            goal_xy_m=goal_xy_m,
            cost_weight=weight,
            smooth=settings.smooth,
            max_offset_m=REUSE_OFFSET_M,
        )
        if rest is not None:
            return PlannedPath(rest[0], rest[1] * frame.resolution_m, 0, reused=True)
        self._last = None
        start = frame.cell_of(*start_xy_m)
        goal = frame.cell_of(*goal_xy_m)
        if not frame.contains(*start):
            raise StartBlockedError(
                f"the robot at ({start_xy_m[0]:.2f}, {start_xy_m[1]:.2f}) m is off the map"
            )
        robot_cell = start
        start = self._free_start(costmap, start, start_xy_m)
        where = f"goal ({goal_xy_m[0]:.2f}, {goal_xy_m[1]:.2f}) m"
        if not frame.contains(*goal):
            x1 = frame.origin_x_m + frame.cols * frame.resolution_m
            y1 = frame.origin_y_m + frame.rows * frame.resolution_m
            raise GoalUnreachableError(
                f"{where} is off the map (x {frame.origin_x_m:.2f}..{x1:.2f}, "
                f"y {frame.origin_y_m:.2f}..{y1:.2f})",
                "off the map",
            )
        if (
            not math.isfinite(costmap.cost[goal])
            and costmap.unknown[goal]
            and costmap.unknown_blocks
        ):
            raise GoalUnreachableError(
                f"{where} is in unexplored space and planning.allow_unknown is false",
                "unknown",
            )
        if not math.isfinite(costmap.cost[goal]):
            raise GoalUnreachableError(
                f"{where} is occupied: {costmap.clearance_m[goal]:.2f} m from an obstacle or a "
                "keep-out zone, too close for the robot",
                "occupied",
            )
        cols = frame.cols
        found = self._search.route(
            costmap, start[0] * cols + start[1], goal[0] * cols + goal[1], settings.cost_weight
        )
        if found is None:
            raise GoalUnreachableError(
                f"no route to {where}: obstacles enclose it or the robot "
                f"({self._search.last_expanded} cells expanded)",
                "no route",
            )
        cells = found.cells
        to_goal = route_costs(costmap.cost, cells, weight)
        if settings.smooth and cells.shape[0] > 2:
            kept = shortcut(costmap.cost, cells, SMOOTH_SLACK, SMOOTH_REACH_CELLS)
            cells, to_goal = cells[kept], to_goal[kept]
        points = frame.centers_of(cells)
        if start == robot_cell:
            points[0] = start_xy_m
        else:
            points = np.vstack([np.asarray(start_xy_m, dtype=np.float64), points])
            escape = math.dist(start_xy_m, points[1]) / frame.resolution_m
            to_goal = np.concatenate([to_goal[:1] + escape, to_goal])
        points[-1] = goal_xy_m
        self._last = RouteMemory(
            frame, costmap.cost, goal_xy_m, weight, settings.smooth, points, to_goal
        )
        return PlannedPath(points, found.cost_cells * frame.resolution_m, found.expanded)

    @staticmethod
    def _free_start(
        costmap: Costmap, start: tuple[int, int], start_xy_m: tuple[float, float]
    ) -> tuple[int, int]:
        """The robot's cell, or the nearest free cell within START_ESCAPE_M if the robot
        stands too close to an obstacle (pushed there, or an obstacle came to it)."""
        if math.isfinite(costmap.cost[start]):
            return start
        reach = max(math.ceil(START_ESCAPE_M / costmap.frame.resolution_m), 1)
        r0, c0 = max(start[0] - reach, 0), max(start[1] - reach, 0)
        window = costmap.cost[r0 : start[0] + reach + 1, c0 : start[1] + reach + 1]
        free = np.argwhere(np.isfinite(window))
        if free.shape[0] == 0:
            raise StartBlockedError(
                f"the robot at ({start_xy_m[0]:.2f}, {start_xy_m[1]:.2f}) m is "
                f"{costmap.clearance_m[start]:.2f} m from an obstacle with no free cell within "
                f"{START_ESCAPE_M} m to plan from"
            )
        offsets = free + np.array([r0 - start[0], c0 - start[1]])
        nearest = free[np.argmin(np.hypot(offsets[:, 0], offsets[:, 1]))]
        return (int(nearest[0] + r0), int(nearest[1] + c0))

"""Far goals: a coarse route over the whole area, the fine route in a window around the robot.

A goal hundreds of metres away would need a full-resolution grid of millions of cells. Here
it takes two searches of bounded size instead: A* on a coarse grid of the whole area (the
layers pooled into blocks, about a metre each; ``Layers.coarse_snapshot``) finds the way,
and A* on the full-resolution window around the robot (``Layers.window_snapshot``) finds the
exact route to where the coarse route leaves the window. The route followed is the fine part
and then the rest of the coarse route; the navigator plans again before the robot reaches
the fine part's end (``PlannedPath.fine_length_m``), so the window rolls along with it.
Memory and search time depend on the window and the coarse grid's cap, never on how far
the goal is.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.planning.costmap import Costmap, CostmapSettings, GridFrame, build_costmap
from navd.planning.errors import GoalUnreachableError, PlanningError
from navd.planning.global_planner import GlobalPlanner, PlannedPath, SearchSettings, path_length

__all__ = ["COARSE_CELL_M", "COARSE_MAX_CELLS", "CoarseLayers", "plan_far"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

# The coarse grid: blocks at least this wide [m], and at most this many of them (wider
# blocks over a larger area).
COARSE_CELL_M = 0.5
COARSE_MAX_CELLS = 250_000
# [m] the fine route ends this far inside the window's edge, where the window still sees
# around it.
EDGE_MARGIN_M = 2.0
# Points tried back along the coarse route when the window's end point is blocked.
END_TRIES = 12


@dataclass(frozen=True, slots=True)
class CoarseLayers:
    """The whole area on the coarse lattice: its frame, obstacle and unknown blocks."""

    frame: GridFrame
    obstacles: BoolArray
    unknown: BoolArray


def plan_far(
    window: Costmap,
    coarse: CoarseLayers,
    *,
    settings: tuple[CostmapSettings, SearchSettings],
    start_xy_m: tuple[float, float],
    goal_xy_m: tuple[float, float],
    fine_planner: GlobalPlanner,
) -> PlannedPath:
    """The route to a far goal: fine in ``window`` (the costmap around the robot), coarse
    beyond (see the module docstring).

    Raises:
        StartBlockedError: from the window's search.
        GoalUnreachableError: no end inside the window could be reached.
    """
    costmap_settings, search = settings
    way = _coarse_way(coarse, costmap_settings, search, start_xy_m, goal_xy_m)
    frame = window.frame
    x0, y0 = frame.origin_x_m + EDGE_MARGIN_M, frame.origin_y_m + EDGE_MARGIN_M
    x1 = frame.origin_x_m + frame.cols * frame.resolution_m - EDGE_MARGIN_M
    y1 = frame.origin_y_m + frame.rows * frame.resolution_m - EDGE_MARGIN_M
    dense = _densify(way, frame.resolution_m)
    inside = (dense[:, 0] >= x0) & (dense[:, 0] <= x1) & (dense[:, 1] >= y0) & (dense[:, 1] <= y1)
    leaves = int(np.argmin(inside)) if not inside.all() else dense.shape[0]
    if leaves == dense.shape[0]:  # the goal lies in the window after all
        return fine_planner.plan(window, start_xy_m, goal_xy_m, search)
    # the last point inside, or points back along the way if that one is blocked
    step = max(leaves // END_TRIES, 1)
    error: GoalUnreachableError | None = None
    for end in range(max(leaves - 1, 0), -1, -step):
        target = (float(dense[end, 0]), float(dense[end, 1]))
        try:
            fine = fine_planner.plan(window, start_xy_m, target, search)
        except GoalUnreachableError as err:
            error = err
            continue
        rest = dense[end + 1 :: max(round(1.0 / frame.resolution_m), 1)]
        points = np.vstack([fine.points_m, rest, [goal_xy_m]])
        return PlannedPath(
            points,
            fine.cost + path_length(np.vstack([[target], rest, [goal_xy_m]])),
            fine.cells_expanded,
            fine_length_m=fine.length_m,
        )
    assert error is not None
    raise GoalUnreachableError(
        f"no way out of the {frame.cols * frame.resolution_m:.0f} m window toward the goal "
        f"({error})",
        error.reason,
    )


def _coarse_way(
    coarse: CoarseLayers,
    costmap_settings: CostmapSettings,
    search: SearchSettings,
    start_xy_m: tuple[float, float],
    goal_xy_m: tuple[float, float],
) -> FloatArray:
    """[m] the coarse route from start to goal; the straight line if it finds none (the
    window then finds its way around what it sees, and the next plan tries again)."""
    frame = coarse.frame
    obstacles = coarse.obstacles.copy()
    # the robot's and the goal's own blocks and their neighbours: the window plans there,
    # and a block is coarser than the gap the robot may be standing in
    for x, y in (start_xy_m, goal_xy_m):
        r, c = frame.cell_of(x, y)
        obstacles[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2] = False
    costmap = build_costmap(frame, obstacles, coarse.unknown, costmap_settings)
    try:
        found = GlobalPlanner().plan(costmap, start_xy_m, goal_xy_m, search)
    except PlanningError:
        return np.array([start_xy_m, goal_xy_m], dtype=np.float64)
    return found.points_m


def _densify(points_m: FloatArray, step_m: float) -> FloatArray:
    """[m] the polyline with points at most ``step_m`` apart along it."""
    out = [points_m[:1]]
    for a, b in itertools.pairwise(points_m):
        n = max(math.ceil(float(np.hypot(*(b - a))) / step_m), 1)
        t = np.arange(1, n + 1)[:, None] / n
        out.append(a + t * (b - a))
    return np.vstack(out)

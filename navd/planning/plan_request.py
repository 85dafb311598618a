"""Everything A* needs for one search, copied out of the navigator so it runs in another
thread: the layers' snapshot, the costmap's and the search's settings, start and goal (and
a far goal's coarse layers)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.planning.costmap import Costmap, CostmapSettings, GridFrame, build_costmap
from navd.planning.errors import GoalRefusedError
from navd.planning.global_planner import GlobalPlanner, PlannedPath, SearchSettings
from navd.planning.horizon import COARSE_CELL_M, COARSE_MAX_CELLS, CoarseLayers, plan_far
from navd.planning.layers import Layers
from navd.planning.settings import NavigatorSettings, goal_too_far

__all__ = ["PlanRequest", "plan_request"]

Point = tuple[float, float]


@dataclass(frozen=True, slots=True)
class PlanRequest:
    """Everything A* needs, copied out of the navigator so it can run in another thread."""

    frame: GridFrame
    obstacles: npt.NDArray[np.bool_]
    unknown: npt.NDArray[np.bool_]
    settings: CostmapSettings
    search: SearchSettings
    start_xy_m: Point
    goal_xy_m: Point
    coarse: CoarseLayers | None = None  # a far goal's whole area (the layers: the window)
    via_xy_m: tuple[Point, ...] = ()  # points the route goes through, in order

    def costmap(self) -> Costmap:
        """The layers inflated, with the settings of when it was asked (heavy)."""
        return build_costmap(self.frame, self.obstacles, self.unknown, self.settings)

    def solve(self, planner: GlobalPlanner, costmap: Costmap | None = None) -> PlannedPath:
        """Run A* (heavy) on ``costmap``, or on the layers inflated now.

        Raises:
            GoalUnreachableError, StartBlockedError: from A*.
        """
        if costmap is None:
            costmap = self.costmap()
        if self.coarse is not None:
            settings = (self.settings, self.search)
            return plan_far(
                costmap,
                self.coarse,
                settings=settings,
                start_xy_m=self.start_xy_m,
                goal_xy_m=self.goal_xy_m,
                fine_planner=planner,
            )
        if not self.via_xy_m:
            return planner.plan(costmap, self.start_xy_m, self.goal_xy_m, self.search)
        # through each via point: a search from each to the next, the routes joined
        stops = [self.start_xy_m, *self.via_xy_m, self.goal_xy_m]
        legs = [planner.plan(costmap, a, b, self.search) for a, b in itertools.pairwise(stops)]
        points = np.concatenate([legs[0].points_m, *(leg.points_m[1:] for leg in legs[1:])])
        return PlannedPath(
            points,
            cost=sum(leg.cost for leg in legs),
            cells_expanded=sum(leg.cells_expanded for leg in legs),
        )


def plan_request(
    layers: Layers,
    settings: NavigatorSettings,
    now: float,
    start: Point,
    goal: Point,
    *,
    via: tuple[Point, ...] = (),
) -> PlanRequest:
    """A snapshot of what A* needs from ``start`` through ``via`` to ``goal`` (cheap): solve
    it without holding the navigator. A far goal is planned on the window and the coarse
    layers, straight to it (its via points are passed when come near, or with the goal).

    Raises:
        GoalRefusedError: the goal is too far from the robot, or the area to plan over too
            large.
    """
    too_far = goal_too_far(settings, start, goal)
    if too_far is not None:
        raise GoalRefusedError(too_far)
    costmap, search = settings.costmap, settings.search
    if layers.needs_window(now, start, goal):
        coarse = CoarseLayers(
            *layers.coarse_snapshot(now, [start, goal], COARSE_MAX_CELLS, COARSE_CELL_M)
        )
        frame, obstacles, unknown = layers.window_snapshot(now, start)
        return PlanRequest(frame, obstacles, unknown, costmap, search, start, goal, coarse)
    frame, obstacles, unknown = layers.snapshot(now, [start, *via, goal])
    return PlanRequest(frame, obstacles, unknown, costmap, search, start, goal, None, via)

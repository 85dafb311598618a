"""Everything A* needs for one search, copied out of the navigator so it runs in another
thread: the layers' snapshot, the costmap's and the search's settings, start and goal (and
a far goal's coarse layers)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.planning.costmap import Costmap, CostmapSettings, GridFrame, build_costmap
from navd.planning.global_planner import GlobalPlanner, PlannedPath, SearchSettings
from navd.planning.horizon import CoarseLayers, plan_far

__all__ = ["PlanRequest"]


@dataclass(frozen=True, slots=True)
class PlanRequest:
    """Everything A* needs, copied out of the navigator so it can run in another thread."""

    frame: GridFrame
    obstacles: npt.NDArray[np.bool_]
    unknown: npt.NDArray[np.bool_]
    settings: CostmapSettings
    search: SearchSettings
    start_xy_m: tuple[float, float]
    goal_xy_m: tuple[float, float]
    coarse: CoarseLayers | None = None  # a far goal's whole area (the layers: the window)

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
        return planner.plan(costmap, self.start_xy_m, self.goal_xy_m, self.search)

"""Where a group of robots can be: a map's walls inflated by a robot's radius and margin, the
clearance of any point, whether a robot sees one point from another, and the group centre's
route (A* as navd's planner plans one)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from navd.fleetctl.errors import GroupGoalError
from navd.planning import (
    Costmap,
    CostmapSettings,
    GlobalPlanner,
    GoalUnreachableError,
    GridFrame,
    SearchSettings,
    StartBlockedError,
    build_costmap,
    segment_max_cost,
    static_layer,
)
from navd.slam import load_map

__all__ = ["DEFAULT_RADIUS_M", "GroupMap"]

FloatArray = npt.NDArray[np.float64]
# [m] a robot's radius plus the margin it keeps from walls: navd's defaults (a 0.2 m disc,
# safety.stop_distance_m 0.1)
DEFAULT_RADIUS_M = 0.3
# map cells at or above this occupancy [%] are walls (navd's planning default)
OCCUPIED_PCT = 65
# the centre's route is weighed as navd's planner weighs one (planning.cost_weight,
# planning.cost_decay [1/m]), with its cost reaching ROUTE_INFLATION_M beyond a robot's
# radius (navd's own reaches 0.5 m from walls): the group's centre keeps to the middle of a
# passage, so the places on either side of it have room
ROUTE_COST_WEIGHT = 3.0
ROUTE_COST_DECAY = 3.0
ROUTE_INFLATION_M = 0.5


@dataclass(frozen=True)
class GroupMap:
    """Where a robot of the group can be: a map's walls inflated by ``radius_m``.

    Attributes:
        costmap: the inflated map (its ``clearance_m`` is each cell's distance to a wall).
        radius_m: [m] a robot's radius plus the margin it keeps.
    """

    costmap: Costmap
    radius_m: float

    @classmethod
    def of_grid(
        cls,
        occupied: npt.NDArray[np.bool_],
        origin_xy_m: tuple[float, float],
        resolution_m: float,
        radius_m: float = DEFAULT_RADIUS_M,
        unknown: npt.NDArray[np.bool_] | None = None,
    ) -> GroupMap:
        """From a grid of walls (rows = y, cell (0, 0)'s corner at ``origin_xy_m``)."""
        rows, cols = occupied.shape
        frame = GridFrame(resolution_m, origin_xy_m[0], origin_xy_m[1], rows, cols)
        settings = CostmapSettings(
            robot_radius_m=radius_m,
            inflation_radius_m=radius_m + ROUTE_INFLATION_M,
            cost_decay_per_m=ROUTE_COST_DECAY,
            allow_unknown=False,
            unknown_cost=1.0,
            occupied_threshold_pct=OCCUPIED_PCT,
        )
        nothing = np.zeros_like(occupied) if unknown is None else unknown
        return cls(build_costmap(frame, occupied, nothing, settings), radius_m)

    @classmethod
    def load(cls, yaml_path: Path, radius_m: float = DEFAULT_RADIUS_M) -> GroupMap:
        """From a saved map (navd's or any map_server map); unknown cells are not driven.

        Raises:
            MapFileError: missing or malformed map files, named.
        """
        grid = load_map(yaml_path)
        occupied, unknown = static_layer(grid.occupancy_percent(), OCCUPIED_PCT)
        return cls.of_grid(
            occupied, (grid.origin_x, grid.origin_y), grid.resolution, radius_m, unknown
        )

    def clearance_m(self, points_m: FloatArray) -> FloatArray:
        """[m] each point's distance to the nearest wall (0 off the map or in unknown)."""
        frame = self.costmap.frame
        cells = frame.cells_of(np.atleast_2d(points_m))
        inside = (
            (cells[:, 0] >= 0)
            & (cells[:, 0] < frame.rows)
            & (cells[:, 1] >= 0)
            & (cells[:, 1] < frame.cols)
        )
        out = np.zeros(cells.shape[0])
        r, c = cells[inside, 0], cells[inside, 1]
        known = ~self.costmap.unknown[r, c]
        out[np.flatnonzero(inside)[known]] = self.costmap.clearance_m[r[known], c[known]]
        return out

    def sees(self, a_m: FloatArray, b_m: FloatArray) -> bool:
        """A robot's centre can go straight from ``a_m`` to ``b_m`` [m]: no cell on the way
        is nearer a wall than ``radius_m``, unknown or off the map (the line of sight navd's
        planner smooths its routes with)."""
        frame = self.costmap.frame
        (r0, c0), (r1, c1) = frame.cells_of(np.array([a_m, b_m]))
        if not (frame.contains(int(r0), int(c0)) and frame.contains(int(r1), int(c1))):
            return False
        return math.isfinite(segment_max_cost(self.costmap.cost, r0, c0, r1, c1))

    def route(self, start_m: tuple[float, float], goal_m: tuple[float, float]) -> FloatArray:
        """[m] N x 2 route of the group's centre from ``start_m`` to ``goal_m``.

        Raises:
            GroupGoalError: the start or the goal is in a wall or off the map, or no route leads
                there (the planner's reason, named).
        """
        try:
            found = GlobalPlanner().plan(
                self.costmap, start_m, goal_m, SearchSettings(ROUTE_COST_WEIGHT, smooth=True)
            )
        except (StartBlockedError, GoalUnreachableError) as err:
            raise GroupGoalError(f"the group's centre: {err}") from err
        return found.points_m

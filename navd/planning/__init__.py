"""Planning: costmap, A* global planner, DWA local planner, velocity profile, stuck recovery.

No asyncio here: plain computation driven by the lifecycle layer.
"""

from navd.planning._astar_kernels import SQRT2, segment_max_cost
from navd.planning._distance_kernels import distance_to
from navd.planning.costmap import Costmap, CostmapSettings, GridFrame, build_costmap, static_layer
from navd.planning.dwa import LocalPlanner, Window, path_field
from navd.planning.errors import GoalUnreachableError, PlanningError, StartBlockedError
from navd.planning.global_planner import GlobalPlanner, PlannedPath, SearchSettings
from navd.planning.goal import GoalState, NavGoal
from navd.planning.guard import GUARD_REACH_M, guard_scale, warm_up_guard
from navd.planning.guard_node import CollisionGuard
from navd.planning.navigator import Navigator
from navd.planning.node import PlannerNode
from navd.planning.settings import (
    NavigatorSettings,
    costmap_settings,
    dwa_settings,
    guard_settings,
    velocity_profile,
)
from navd.planning.warmup import warm_up
from navd.planning.zones import RECHECK_S, ZoneError, ZoneMasks, load_zone_mask

__all__ = [
    "GUARD_REACH_M",
    "RECHECK_S",
    "SQRT2",
    "CollisionGuard",
    "Costmap",
    "CostmapSettings",
    "GlobalPlanner",
    "GoalState",
    "GoalUnreachableError",
    "GridFrame",
    "LocalPlanner",
    "NavGoal",
    "Navigator",
    "NavigatorSettings",
    "PlannedPath",
    "PlannerNode",
    "PlanningError",
    "SearchSettings",
    "StartBlockedError",
    "Window",
    "ZoneError",
    "ZoneMasks",
    "build_costmap",
    "costmap_settings",
    "distance_to",
    "dwa_settings",
    "guard_scale",
    "guard_settings",
    "load_zone_mask",
    "path_field",
    "segment_max_cost",
    "static_layer",
    "velocity_profile",
    "warm_up",
    "warm_up_guard",
]

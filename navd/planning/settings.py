"""The navigator's settings: every part's own, derived from one config."""

from __future__ import annotations

import math
from dataclasses import dataclass

from navd.config import NavdConfig
from navd.geometry.footprint import Footprint
from navd.geometry.mount import SensorMounts
from navd.planning.costmap import CostmapSettings
from navd.planning.dwa import DwaSettings
from navd.planning.global_planner import SearchSettings
from navd.planning.layers import LayerSettings
from navd.planning.manual import ManualSettings
from navd.planning.margins import keep_clear_m
from navd.planning.profile import VelocityProfile
from navd.planning.stuck import StuckSettings

__all__ = ["NavigatorSettings", "PlannerSettings", "goal_too_far"]


@dataclass(frozen=True, slots=True)
class NavigatorSettings:
    """Everything the navigator and its parts run on, derived from one config.

    Attributes:
        footprint: the robot's shape.
        keep_clear_m: [m] distance planned motion keeps from obstacles.
        local_radius_m: [m] map cells within this of the robot are handed to DWA: everything
            its rollouts and their clearance can reach.
        costmap, dwa, profile, stuck, layers, search: the parts' own settings.
        goal_xy_tolerance_m, goal_yaw_tolerance_rad: [m], [rad] when a goal is reached.
        approach_distance_m: [m] the goal's heading is aimed at within this distance.
        lookahead_m: [m] DWA aims at the route point this far ahead.
        replan_period_s: [s] replan on this timer (0: only on events).
        max_path_deviation_m: [m] straying farther from the route replans.
        min_linear_speed_mps: [m/s] slowest forward speed asked for (ETA floor).
        max_stuck_time_s: [s] no route for this long fails the goal.
        max_stuck_replans: [count] replans after StuckDetected before the goal fails.
        max_goal_distance_m: [m] a goal farther than this from the robot fails at once.
    """

    footprint: Footprint
    keep_clear_m: float
    local_radius_m: float
    costmap: CostmapSettings
    dwa: DwaSettings
    profile: VelocityProfile
    stuck: StuckSettings
    layers: LayerSettings
    search: SearchSettings
    goal_xy_tolerance_m: float
    goal_yaw_tolerance_rad: float
    approach_distance_m: float
    lookahead_m: float
    replan_period_s: float
    max_path_deviation_m: float
    min_linear_speed_mps: float
    max_stuck_time_s: float
    max_stuck_replans: int
    max_goal_distance_m: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> NavigatorSettings:
        """The settings the robot, safety and planning sections describe."""
        planning, robot = config.planning, config.robot
        footprint = Footprint.of(robot)
        clear_m = keep_clear_m(config.safety)
        return cls(
            footprint=footprint,
            keep_clear_m=clear_m,
            local_radius_m=(
                max(robot.max_linear_speed_mps, robot.max_reverse_speed_mps)
                * planning.prediction_horizon_s
                + footprint.circumradius_m
                + max(planning.inflation_radius_m, clear_m)
                + 0.5
            ),
            costmap=CostmapSettings.from_config(config),
            dwa=DwaSettings.from_config(config),
            profile=VelocityProfile.from_config(config),
            stuck=StuckSettings.from_config(config),
            layers=LayerSettings.from_config(config),
            search=SearchSettings.from_config(config),
            goal_xy_tolerance_m=planning.goal_xy_tolerance_m,
            goal_yaw_tolerance_rad=planning.goal_yaw_tolerance_rad,
            approach_distance_m=planning.approach_distance_m,
            lookahead_m=planning.lookahead_m,
            replan_period_s=planning.replan_period_s,
            max_path_deviation_m=planning.max_path_deviation_m,
            min_linear_speed_mps=planning.min_linear_speed_mps,
            max_stuck_time_s=planning.max_stuck_time_s,
            max_stuck_replans=planning.max_stuck_replans,
            max_goal_distance_m=planning.max_goal_distance_m,
        )


@dataclass(frozen=True, slots=True)
class PlannerSettings:
    """The planner module's settings.

    Attributes:
        navigator: what the navigator runs on.
        control_period_s: [s] period of the control tick.
        mounts: where each lidar sits, for the scan obstacles.
        obstacle_range_m: [m] farther ranges neither mark nor clear scan obstacles.
        reaction_timeout_s: [s] the chassis stops itself on a command older than this.
        manual: what operators driving by hand may do.
    """

    navigator: NavigatorSettings
    control_period_s: float
    mounts: SensorMounts
    obstacle_range_m: float
    reaction_timeout_s: float
    manual: ManualSettings

    @classmethod
    def from_config(cls, config: NavdConfig) -> PlannerSettings:
        """The settings the robot, safety, planning, lidar, mounts and teleop sections
        describe."""
        return cls(
            navigator=NavigatorSettings.from_config(config),
            control_period_s=1.0 / config.planning.control_rate_hz,
            mounts=SensorMounts.of(config),
            obstacle_range_m=config.planning.obstacle_range_m,
            reaction_timeout_s=config.safety.reaction_timeout_s,
            manual=ManualSettings.from_config(config),
        )


def goal_too_far(
    settings: NavigatorSettings, robot_xy_m: tuple[float, float], goal_xy_m: tuple[float, float]
) -> str | None:
    """Why a goal is refused for its distance from the robot [m, map frame], or None."""
    distance = math.hypot(goal_xy_m[0] - robot_xy_m[0], goal_xy_m[1] - robot_xy_m[1])
    limit = settings.max_goal_distance_m
    if distance <= limit:
        return None
    return (
        f"goal ({goal_xy_m[0]:.1f}, {goal_xy_m[1]:.1f}) m is {distance:.0f} m from the robot, "
        f"more than planning.max_goal_distance_m ({limit:g} m); give waypoints in between"
    )

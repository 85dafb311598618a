"""The planning room's settings: every part's own values, derived once from the sections
that concern it (robot, safety, planning, teleop, chassis, mounts), and the only place the
room reads the config. The robot's limits come as one ``RobotLimits``."""

from __future__ import annotations

import math
from dataclasses import dataclass

from navd.config import NavdConfig, PlanningConfig, RobotConfig, SafetyConfig, TeleopConfig
from navd.geometry import Footprint, RobotLimits, SensorMounts
from navd.planning.costmap import CostmapSettings
from navd.planning.dwa import DwaSettings
from navd.planning.global_planner import SearchSettings
from navd.planning.guard import GuardSettings
from navd.planning.layers import LayerSettings
from navd.planning.manual import ManualSettings
from navd.planning.margins import keep_clear_m
from navd.planning.profile import VelocityProfile
from navd.planning.stuck import StuckSettings

__all__ = [
    "NavigatorSettings",
    "PlannerSettings",
    "costmap_settings",
    "default_guard",
    "default_planner",
    "dwa_settings",
    "goal_too_far",
    "guard_settings",
    "layer_settings",
    "manual_settings",
    "search_settings",
    "stuck_settings",
    "velocity_profile",
]


def costmap_settings(
    planning: PlanningConfig, robot: RobotConfig, safety: SafetyConfig
) -> CostmapSettings:
    """The costmap's: inflation around the footprint's inscribed circle plus the margin."""
    return CostmapSettings(
        robot_radius_m=Footprint.of(robot).inscribed_m + keep_clear_m(safety),
        inflation_radius_m=planning.inflation_radius_m,
        cost_decay_per_m=planning.cost_decay,
        allow_unknown=planning.allow_unknown,
        unknown_cost=planning.unknown_cost,
        occupied_threshold_pct=planning.occupied_threshold_pct,
    )


def dwa_settings(planning: PlanningConfig, robot: RobotConfig, safety: SafetyConfig) -> DwaSettings:
    """The local planner's: its rollouts, samples, limits and weights."""
    limits = RobotLimits.of(robot)
    return DwaSettings(
        footprint=Footprint.of(robot),
        margin_m=keep_clear_m(safety),
        clearance_cap_m=max(planning.inflation_radius_m, 0.1),
        horizon_s=planning.prediction_horizon_s,
        step_s=planning.sim_step_s,
        period_s=1.0 / planning.control_rate_hz,
        linear_samples=planning.linear_samples,
        angular_samples=planning.angular_samples,
        max_speed_mps=limits.max_forward_mps,
        max_reverse_mps=limits.max_reverse_mps,
        max_yaw_rate_radps=limits.max_yaw_rate_radps,
        linear_accel_mps2=limits.max_linear_accel_mps2,
        angular_accel_radps2=limits.max_angular_accel_radps2,
        weights=(
            planning.goal_weight,
            planning.path_weight,
            planning.clearance_weight,
            planning.oscillation_weight,
            planning.heading_weight,
        ),
    )


def velocity_profile(planning: PlanningConfig, robot: RobotConfig) -> VelocityProfile:
    """The speed ramp, the slow approach, and the yaw rate allowed at each speed."""
    limits = RobotLimits.of(robot)
    return VelocityProfile(
        max_speed_mps=limits.max_forward_mps,
        min_speed_mps=planning.min_linear_speed_mps,
        max_accel_mps2=limits.max_linear_accel_mps2,
        acceleration_time_s=planning.acceleration_time_s,
        approach_distance_m=planning.approach_distance_m,
        table_speeds_mps=tuple(row[0] for row in planning.angular_limit_table),
        table_yaw_rates_radps=tuple(row[1] for row in planning.angular_limit_table),
        max_yaw_accel_radps2=limits.max_angular_accel_radps2,
    )


def stuck_settings(planning: PlanningConfig, robot: RobotConfig) -> StuckSettings:
    """When the robot counts as stuck, and how it tries to get free."""
    return StuckSettings(
        stuck_time_s=planning.stuck_time_s,
        backward_time_s=planning.stuck_time_force_backward_s,
        max_stuck_time_s=planning.max_stuck_time_s,
        min_progress_m=planning.stuck_min_progress_m,
        rotation_tolerance_rad=planning.stuck_rotation_tolerance_rad,
        min_speed_mps=planning.min_linear_speed_mps,
        max_speed_mps=RobotLimits.of(robot).max_forward_mps,
        backup_distance_m=planning.backup_distance_m,
    )


def layer_settings(planning: PlanningConfig) -> LayerSettings:
    """What the costmap's layers are made of."""
    return LayerSettings(
        planning.occupied_threshold_pct,
        planning.obstacle_persistence_s,
        planning.keep_out_zones,
        planning.max_plan_cells,
        planning.keep_out_mask,
        planning.speed_mask,
        planning.local_window_m,
        planning.proximity_persistence_s,
    )


def search_settings(planning: PlanningConfig) -> SearchSettings:
    """The route search's cost weight and smoothing."""
    return SearchSettings(planning.cost_weight, planning.smooth_path)


def manual_settings(teleop: TeleopConfig) -> ManualSettings:
    """What operators driving by hand may do."""
    return ManualSettings(
        enabled=teleop.enabled,
        max_linear_mps=teleop.max_linear_speed_mps,
        max_angular_radps=teleop.max_angular_speed_radps,
        resume_after_s=teleop.resume_after_s,
    )


def guard_settings(config: NavdConfig) -> GuardSettings:
    """The collision guard's: the safety, robot, chassis, lidar, mounts and planning (the
    speed mask) sections."""
    safety, limits = config.safety, RobotLimits.of(config.robot)
    return GuardSettings(
        footprint=Footprint.of(config.robot),
        stop_m=safety.stop_distance_m,
        slowdown_m=safety.slowdown_distance_m,
        slowdown_factor=safety.slowdown_factor,
        linear_decel_mps2=limits.max_linear_accel_mps2,
        angular_decel_radps2=limits.max_angular_accel_radps2,
        period_s=1.0 / config.chassis.command_rate_hz,
        enabled=safety.use_collisions,
        mounts=SensorMounts.of(config.mounts, config.lidar),
        speed_mask=config.planning.speed_mask,
        max_speed_mps=limits.max_forward_mps,
    )


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
        planning, robot, safety = config.planning, config.robot, config.safety
        footprint = Footprint.of(robot)
        clear_m = keep_clear_m(safety)
        return cls(
            footprint=footprint,
            keep_clear_m=clear_m,
            local_radius_m=(
                RobotLimits.of(robot).max_speed_mps * planning.prediction_horizon_s
                + footprint.circumradius_m
                + max(planning.inflation_radius_m, clear_m)
                + 0.5
            ),
            costmap=costmap_settings(planning, robot, safety),
            dwa=dwa_settings(planning, robot, safety),
            profile=velocity_profile(planning, robot),
            stuck=stuck_settings(planning, robot),
            layers=layer_settings(planning),
            search=search_settings(planning),
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
            mounts=SensorMounts.of(config.mounts, config.lidar),
            obstacle_range_m=config.planning.obstacle_range_m,
            reaction_timeout_s=config.safety.reaction_timeout_s,
            manual=manual_settings(config.teleop),
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


def default_planner() -> PlannerSettings:
    """The planner's settings with every key at its default (warm-ups, benchmarks)."""
    return PlannerSettings.from_config(NavdConfig())


def default_guard() -> GuardSettings:
    """The collision guard's settings with every key at its default."""
    return guard_settings(NavdConfig())

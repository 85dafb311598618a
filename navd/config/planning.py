"""How the robot gets there: global A*, local DWA, the velocity profile, stuck handling."""

from __future__ import annotations

import itertools

from pydantic import Field, model_validator

from navd.config.fields import Point2, Polygons, Section, Table

__all__ = ["PlanningConfig"]


class PlanningConfig(Section):
    """Global A*, local DWA, velocity profile and stuck handling."""

    control_rate_hz: float = Field(20.0, ge=1, le=100, description="[Hz] local planner rate")
    prediction_horizon_s: float = Field(
        2.0, gt=0, le=10, description="[s] how far ahead DWA rolls trajectories out"
    )
    linear_samples: int = Field(
        20, ge=2, le=200, description="[count] linear velocities sampled in the window"
    )
    angular_samples: int = Field(
        21, ge=3, le=401, description="[count] angular velocities sampled in the window"
    )
    goal_weight: float = Field(1.0, ge=0, le=100, description="[1] weight of goal proximity")
    path_weight: float = Field(1.0, ge=0, le=100, description="[1] weight of closeness to path")
    clearance_weight: float = Field(
        0.5, ge=0, le=100, description="[1] weight of obstacle clearance"
    )
    oscillation_weight: float = Field(
        0.2, ge=0, le=100, description="[1] weight of the oscillation penalty"
    )
    heading_weight: float = Field(
        0.5, ge=0, le=100, description="[1] weight of target-heading alignment near the goal"
    )
    goal_xy_tolerance_m: float = Field(
        0.15, gt=0, le=10, description="[m] goal reached within this distance"
    )
    goal_yaw_tolerance_rad: float = Field(
        0.2, gt=0, le=3.1416, description="[rad] goal heading reached within this angle"
    )
    inflation_radius_m: float = Field(
        0.5, ge=0, le=10, description="[m] costs decay to zero this far from obstacles"
    )
    cost_decay: float = Field(
        3.0, gt=0, le=100, description="[1/m] exponential decay rate of the inflation cost"
    )
    replan_period_s: float = Field(
        5.0, ge=0, le=600, description="[s] replan on this timer; 0 replans only on events"
    )
    max_path_deviation_m: float = Field(
        0.5, gt=0, le=10, description="[m] straying farther from the path triggers a replan"
    )
    approach_distance_m: float = Field(
        1.0, ge=0, le=20, description="[m] start slowing down this far from the goal"
    )
    angular_limit_table: Table = Field(
        ((0.0, 1.5), (0.5, 0.8)),
        description="[(m/s, rad/s)] top yaw rate as a function of speed, linearly interpolated",
    )
    stuck_time_s: float = Field(
        3.0, gt=0, le=600, description="[s] this long without progress means stuck"
    )
    stuck_min_progress_m: float = Field(
        0.1, gt=0, le=10, description="[m] progress that resets the stuck timer"
    )
    stuck_time_force_backward_s: float = Field(
        5.0, gt=0, le=600, description="[s] stuck this long forces backward motion"
    )
    max_stuck_time_s: float = Field(
        15.0, gt=0, le=3600, description="[s] stuck this long reports StuckDetected and replans"
    )
    keep_out_zones: Polygons = Field(
        (),
        description="[m] polygons in the map frame the robot must never enter",
    )
    keep_out_mask: str | None = Field(
        None,
        min_length=1,
        max_length=4096,
        description="map_server YAML of an image whose occupied cells the robot never enters "
        "(read again when the file changes; docs/planning.md)",
        examples=["/etc/navd/zones/keep_out.yaml"],
    )
    speed_mask: str | None = Field(
        None,
        min_length=1,
        max_length=4096,
        description="map_server YAML of an image whose cells 1..100 cap the speed there in % of "
        "robot.max_linear_speed_mps (0: no cap; read again when the file changes)",
        examples=["/etc/navd/zones/speed.yaml"],
    )
    min_linear_speed_mps: float = Field(
        0.05, ge=0, le=10, description="[m/s] slowest forward speed the velocity profile asks for"
    )
    acceleration_time_s: float = Field(
        1.0, ge=0, le=60, description="[s] the start ramp reaches top speed after this long"
    )
    lookahead_m: float = Field(
        1.0, gt=0, le=20, description="[m] DWA aims at the path point this far ahead"
    )
    sim_step_s: float = Field(0.1, ge=0.01, le=1, description="[s] time step of the DWA rollouts")
    occupied_threshold_pct: int = Field(
        65, ge=1, le=100, description="[%] map cells at or above this occupancy are obstacles"
    )
    allow_unknown: bool = Field(True, description="routes may cross unknown (unmapped) cells")
    unknown_cost: float = Field(
        0.5, ge=0, le=1, description="[1] cost of an unknown cell, on the inflation scale 0..1"
    )
    cost_weight: float = Field(
        3.0,
        ge=0,
        le=100,
        description="[1] a step through a cell of cost c counts (1 + cost_weight * c) times its "
        "length, so routes keep away from walls",
    )
    obstacle_persistence_s: float = Field(
        2.0, ge=0, le=600, description="[s] a scan obstacle not seen again is forgotten after this"
    )
    proximity_persistence_s: float = Field(
        20.0,
        ge=0,
        le=600,
        description="[s] what a range sensor or a depth camera saw is forgotten after this "
        "unless seen again (they look one way: a table top left behind as the robot turns "
        "must not be forgotten before the robot is past it)",
    )
    obstacle_range_m: float = Field(
        12.0,
        gt=0,
        le=100,
        description="[m] lidar ranges farther than this neither mark nor clear scan obstacles",
    )
    smooth_path: bool = Field(True, description="shortcut the A* path where the line is clear")
    stuck_rotation_tolerance_rad: float = Field(
        0.5, gt=0, le=6.3, description="[rad] turning this far also counts as progress"
    )
    backup_distance_m: float = Field(
        0.5, gt=0, le=10, description="[m] a forced backward move goes this far before replanning"
    )
    max_stuck_replans: int = Field(
        3, ge=0, le=100, description="[count] replans after StuckDetected before the goal fails"
    )
    max_goal_distance_m: float = Field(
        1000.0,
        gt=0,
        le=100_000,
        description="[m] a goal farther than this from the robot fails at once with the reason "
        "(a typo's guard: give waypoints in between)",
    )
    max_plan_cells: int = Field(
        2_000_000,
        ge=10_000,
        le=400_000_000,
        description="[cells] A* plans on the whole map (with the robot and the goal) while it "
        "holds at most this many cells, about 45 bytes each at its peak; beyond, and for a goal "
        "beyond local_window_m with no map, it plans a coarse route over the area and the "
        "fine route in a window around the robot",
    )
    local_window_m: float = Field(
        30.0,
        ge=15,
        le=200,
        description="[m] side of the square around the robot planned at full resolution when "
        "the goal is far (see max_plan_cells); re-planned as the robot nears its edge",
    )

    @model_validator(mode="after")
    def _consistent(self) -> PlanningConfig:
        weights = (
            self.goal_weight,
            self.path_weight,
            self.clearance_weight,
            self.oscillation_weight,
            self.heading_weight,
        )
        if not any(w > 0 for w in weights):
            raise ValueError("planning: at least one of the *_weight metrics must be > 0")
        if not self.stuck_time_s < self.stuck_time_force_backward_s < self.max_stuck_time_s:
            raise ValueError(
                "planning: need stuck_time_s < stuck_time_force_backward_s < max_stuck_time_s, "
                f"got {self.stuck_time_s} < {self.stuck_time_force_backward_s} < "
                f"{self.max_stuck_time_s}"
            )
        _check_table(self.angular_limit_table)
        if self.lookahead_m < self.goal_xy_tolerance_m:
            raise ValueError(
                f"planning.lookahead_m ({self.lookahead_m}) must be at least "
                f"planning.goal_xy_tolerance_m ({self.goal_xy_tolerance_m})"
            )
        if self.sim_step_s > self.prediction_horizon_s:
            raise ValueError(
                f"planning.sim_step_s ({self.sim_step_s}) is longer than "
                f"planning.prediction_horizon_s ({self.prediction_horizon_s})"
            )
        for i, zone in enumerate(self.keep_out_zones):
            if len(zone) < 3:
                raise ValueError(
                    f"planning.keep_out_zones[{i}] has {len(zone)} points; a polygon needs >= 3"
                )
        return self


def _check_table(table: tuple[Point2, ...]) -> None:
    if len(table) < 1:
        raise ValueError("planning.angular_limit_table needs at least one [speed, yaw_rate] row")
    speeds = [row[0] for row in table]
    if speeds[0] < 0 or any(b <= a for a, b in itertools.pairwise(speeds)):
        raise ValueError(
            f"planning.angular_limit_table speeds must start >= 0 and strictly increase, "
            f"got {speeds}"
        )
    if any(row[1] <= 0 for row in table):
        raise ValueError("planning.angular_limit_table yaw rates must all be > 0")

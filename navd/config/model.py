"""The configuration model: one pydantic section per subsystem, combined in ``NavdConfig``.

Every model is strict (a string is never read as a number), forbids unknown keys, and is
frozen, so the running config can only be replaced whole. Every number has bounds and a
description that starts with its unit. Fields marked ``restart`` cannot change at runtime.
The runtime-changeable fields follow the seed's ConfigProperty: updating_map,
use_collisions, reaction timeout, collision distance, and the planner, noise,
localization, matching, sensor, stuck and metrics parameters; the seed's UseDebug is
``logging.level = "debug"``.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, model_validator

from navd.config.battery import BatteryConfig
from navd.config.beacons import BeaconsConfig
from navd.config.body import ChassisConfig, LidarConfig, RobotConfig, SafetyConfig
from navd.config.fleet import FleetConfig
from navd.config.localization import EstimationConfig, SlamConfig, WorldConfig
from navd.config.mounts import MountsConfig
from navd.config.planning import PlanningConfig
from navd.config.record import RecordConfig
from navd.config.service import LifecycleConfig, LoggingConfig, TcpConfig
from navd.config.teleop import TeleopConfig
from navd.config.viz import VizConfig

__all__ = ["NavdConfig"]


class NavdConfig(BaseModel):
    """The whole configuration, one section per subsystem."""

    model_config = ConfigDict(
        strict=True, extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False
    )

    robot: RobotConfig = Field(default_factory=RobotConfig)
    lidar: LidarConfig = Field(default_factory=LidarConfig)
    mounts: MountsConfig = Field(default_factory=MountsConfig)
    chassis: ChassisConfig = Field(default_factory=ChassisConfig)
    tcp: TcpConfig = Field(default_factory=TcpConfig)
    safety: SafetyConfig = Field(default_factory=SafetyConfig)
    teleop: TeleopConfig = Field(default_factory=TeleopConfig)
    slam: SlamConfig = Field(default_factory=SlamConfig)
    estimation: EstimationConfig = Field(default_factory=EstimationConfig)
    world: WorldConfig = Field(default_factory=WorldConfig)
    beacons: BeaconsConfig = Field(default_factory=BeaconsConfig)
    planning: PlanningConfig = Field(default_factory=PlanningConfig)
    lifecycle: LifecycleConfig = Field(default_factory=LifecycleConfig)
    logging: LoggingConfig = Field(default_factory=LoggingConfig)
    viz: VizConfig = Field(default_factory=VizConfig)
    record: RecordConfig = Field(default_factory=RecordConfig)
    fleet: FleetConfig = Field(default_factory=FleetConfig)
    battery: BatteryConfig = Field(default_factory=BatteryConfig)

    @model_validator(mode="after")
    def _across_sections(self) -> NavdConfig:
        for reach, key in (
            (self.slam.max_range_m, "slam.max_range_m"),
            (self.planning.obstacle_range_m, "planning.obstacle_range_m"),
        ):
            if self.lidar.min_range_m >= reach:
                raise ValueError(
                    f"lidar.min_range_m ({self.lidar.min_range_m}) must be below {key} ({reach})"
                )
        top_yaw = max(row[1] for row in self.planning.angular_limit_table)
        if top_yaw > self.robot.max_angular_speed_radps:
            raise ValueError(
                f"planning.angular_limit_table allows {top_yaw} rad/s, above "
                f"robot.max_angular_speed_radps ({self.robot.max_angular_speed_radps})"
            )
        if self.planning.min_linear_speed_mps > self.robot.max_linear_speed_mps:
            raise ValueError(
                f"planning.min_linear_speed_mps ({self.planning.min_linear_speed_mps}) is above "
                f"robot.max_linear_speed_mps ({self.robot.max_linear_speed_mps})"
            )
        two_periods_s = 2.0 / self.planning.control_rate_hz
        if self.safety.reaction_timeout_s < two_periods_s:
            raise ValueError(
                f"safety.reaction_timeout_s ({self.safety.reaction_timeout_s}) is shorter than two "
                f"planner periods ({two_periods_s:.3g} s at planning.control_rate_hz = "
                f"{self.planning.control_rate_hz}): the robot would stop between commands"
            )
        chassis_period_s = 1.0 / self.chassis.command_rate_hz
        if chassis_period_s > self.safety.reaction_timeout_s / 2.0:
            raise ValueError(
                f"chassis.command_rate_hz ({self.chassis.command_rate_hz}) is too slow for "
                f"safety.reaction_timeout_s ({self.safety.reaction_timeout_s}): a command would be "
                f"stale before it is written; need a period of at most half the timeout"
            )
        return self

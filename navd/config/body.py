"""The robot's body and what keeps it safe: its shape and limits, the lidar's mount, the
chassis on its UART, the safety gate and collision guard."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from navd.config.fields import STANDARD_BAUD_RATES, Section, restart

__all__ = ["ChassisConfig", "LidarConfig", "RobotConfig", "SafetyConfig"]


class RobotConfig(Section):
    """The robot body: footprint and motion limits."""

    name: str = Field("navd-robot", min_length=1, max_length=64, description="robot name")
    footprint: Literal["circle", "rectangle"] = Field(
        "circle", description="footprint shape around base_link"
    )
    radius_m: float = Field(0.2, gt=0, le=5, description="[m] circle footprint radius")
    length_m: float = Field(0.4, gt=0, le=10, description="[m] rectangle footprint length (x)")
    width_m: float = Field(0.3, gt=0, le=10, description="[m] rectangle footprint width (y)")
    track_width_m: float = Field(
        0.3, gt=0, le=5, description="[m] distance between the left and right wheels"
    )
    max_linear_speed_mps: float = Field(0.5, gt=0, le=10, description="[m/s] top forward speed")
    max_reverse_speed_mps: float = Field(
        0.2, ge=0, le=10, description="[m/s] top backward speed (0 forbids reversing)"
    )
    max_angular_speed_radps: float = Field(1.5, gt=0, le=20, description="[rad/s] top yaw rate")
    max_linear_accel_mps2: float = Field(
        0.5, gt=0, le=20, description="[m/s^2] top linear acceleration"
    )
    max_angular_accel_radps2: float = Field(
        2.0, gt=0, le=50, description="[rad/s^2] top angular acceleration"
    )

    @model_validator(mode="after")
    def _reverse_within_forward(self) -> RobotConfig:
        if self.max_reverse_speed_mps > self.max_linear_speed_mps:
            raise ValueError(
                f"robot.max_reverse_speed_mps ({self.max_reverse_speed_mps}) must not exceed "
                f"robot.max_linear_speed_mps ({self.max_linear_speed_mps})"
            )
        return self


class LidarConfig(Section):
    """The 2D lidar: where it sits on the robot and its shortest trusted range (every lidar's,
    unless ``mounts.lidars`` places them one by one)."""

    x_m: float = Field(0.0, ge=-5, le=5, description="[m] lidar x in base_link (forward)")
    y_m: float = Field(0.0, ge=-5, le=5, description="[m] lidar y in base_link (left)")
    yaw_rad: float = Field(
        0.0,
        ge=-3.1416,
        le=3.1416,
        description="[rad] lidar yaw in base_link, counter-clockwise from the robot's forward",
    )
    upside_down: bool = Field(
        False, description="mounted upside down: its bearings turn clockwise in base_link"
    )
    min_range_m: float = Field(
        0.1,
        ge=0,
        le=10,
        description="[m] shorter ranges are ignored (the robot's own body, dust on the window)",
    )


class ChassisConfig(Section):
    """The STM32 on a UART that takes one "%d %d" line of wheel commands per period."""

    enabled: bool = Field(False, **restart("drive a real chassis on the serial port"))
    port: str = Field("/dev/ttyS0", min_length=1, **restart("serial device path"))
    baudrate: int = Field(115200, **restart("[baud] serial speed; a standard rate"))
    line_ending: Literal["lf", "crlf"] = Field("lf", description="line ending sent after a command")
    command_rate_hz: float = Field(
        20.0, ge=1, le=200, description="[Hz] how often a wheel command line is written"
    )
    scale_per_mps: float = Field(
        1000.0, gt=0, le=100_000, description="[units/(m/s)] wheel command per wheel speed"
    )
    deadband: int = Field(
        0, ge=0, le=100_000, description="[units] smaller wheel commands are sent as 0"
    )
    limit: int = Field(
        1000, gt=0, le=1_000_000, description="[units] wheel commands are clamped to +-limit"
    )
    invert_left: bool = Field(False, description="negate the left wheel command")
    invert_right: bool = Field(False, description="negate the right wheel command")
    reconnect_initial_s: float = Field(
        0.2, gt=0, le=60, description="[s] first wait before reopening a lost port"
    )
    reconnect_max_s: float = Field(
        5.0, gt=0, le=600, description="[s] longest wait between reopening attempts"
    )
    feedback: Literal["off", "log", "encoders"] = Field(
        "log",
        description='lines the STM32 sends back: ignore, log, or parse "%d %d" as measured '
        "wheel speeds in command units into wheel odometry",
    )

    @model_validator(mode="after")
    def _consistent(self) -> ChassisConfig:
        if self.baudrate not in STANDARD_BAUD_RATES:
            raise ValueError(
                f"chassis.baudrate {self.baudrate} is not a standard rate; "
                f"use one of {', '.join(map(str, STANDARD_BAUD_RATES))}"
            )
        if self.deadband >= self.limit:
            raise ValueError(
                f"chassis.deadband ({self.deadband}) must be below chassis.limit ({self.limit})"
            )
        if self.reconnect_initial_s > self.reconnect_max_s:
            raise ValueError(
                f"chassis.reconnect_initial_s ({self.reconnect_initial_s}) must not exceed "
                f"chassis.reconnect_max_s ({self.reconnect_max_s})"
            )
        return self


class SafetyConfig(Section):
    """When the robot must stop, whatever the planner says."""

    reaction_timeout_s: float = Field(
        0.5, gt=0, le=10, description="[s] stop when no fresh velocity command came for this long"
    )
    use_collisions: bool = Field(True, description="stop for obstacles (the seed's UseCollisions)")
    collision_distance_m: float = Field(
        0.1, ge=0, le=5, description="[m] margin around the footprint a trajectory must keep"
    )
    stop_distance_m: float = Field(
        0.1,
        ge=0,
        le=5,
        description="[m] scan points this close ahead of the footprint stop it (planned motion "
        "keeps at least this far: a larger value closes narrow doors)",
    )
    slowdown_distance_m: float = Field(
        0.5, ge=0, le=10, description="[m] scan points this close ahead slow the robot down"
    )
    slowdown_factor: float = Field(
        0.4, gt=0, le=1, description="[ratio] speed scale inside the slow-down zone"
    )

    @model_validator(mode="after")
    def _zones_nested(self) -> SafetyConfig:
        if self.slowdown_distance_m < self.stop_distance_m:
            raise ValueError(
                f"safety.slowdown_distance_m ({self.slowdown_distance_m}) must be at least "
                f"safety.stop_distance_m ({self.stop_distance_m})"
            )
        return self

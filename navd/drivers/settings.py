"""The drivers room's settings for the chassis: the serial line, the calibration, the
timeouts and ramps, derived once from the chassis, robot and safety sections (the TCP
server's are ``tcp.settings``); with those, the only places the room reads the config."""

from __future__ import annotations

from dataclasses import dataclass

from navd.config import NavdConfig
from navd.drivers.kinematics import WheelCalibration
from navd.geometry import RobotLimits

__all__ = ["LINE_ENDINGS", "ChassisSettings"]

LINE_ENDINGS = {"lf": "\n", "crlf": "\r\n"}


@dataclass(frozen=True, slots=True)
class ChassisSettings:
    """The chassis driver's settings.

    Attributes:
        port, baudrate: the serial device and its speed (they need a restart).
        line_ending: what ends each command line ("\\n" or "\\r\\n").
        period_s: [s] one command line is written per period.
        calibration: wheel speeds to the STM32's integers and back.
        track_width_m: [m] between the wheels.
        reaction_timeout_s: [s] no fresh command for this long writes "0 0".
        max_linear_accel_mps2, max_angular_accel_radps2: [m/s², rad/s²] the fastest the
            written command speeds up.
        reconnect_initial_s, reconnect_max_s: [s] the backoff reopening a lost port.
        feedback: "off", "log" or "encoders" (what the lines the STM32 sends are).
    """

    port: str
    baudrate: int
    line_ending: str
    period_s: float
    calibration: WheelCalibration
    track_width_m: float
    reaction_timeout_s: float
    max_linear_accel_mps2: float
    max_angular_accel_radps2: float
    reconnect_initial_s: float
    reconnect_max_s: float
    feedback: str

    @classmethod
    def from_config(cls, config: NavdConfig) -> ChassisSettings:
        """The settings the chassis, robot and safety sections describe."""
        chassis, limits = config.chassis, RobotLimits.of(config.robot)
        return cls(
            port=chassis.port,
            baudrate=chassis.baudrate,
            line_ending=LINE_ENDINGS[chassis.line_ending],
            period_s=1.0 / chassis.command_rate_hz,
            calibration=WheelCalibration.of(chassis),
            track_width_m=config.robot.track_width_m,
            reaction_timeout_s=config.safety.reaction_timeout_s,
            max_linear_accel_mps2=limits.max_linear_accel_mps2,
            max_angular_accel_radps2=limits.max_angular_accel_radps2,
            reconnect_initial_s=chassis.reconnect_initial_s,
            reconnect_max_s=chassis.reconnect_max_s,
            feedback=chassis.feedback,
        )

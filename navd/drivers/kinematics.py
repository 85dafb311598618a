"""Differential-drive kinematics and the STM32's integer wheel commands.

Body velocity (v forward [m/s], w yaw rate [rad/s]) to wheel speeds, with track width b:
    v_left = v - w * b / 2,   v_right = v + w * b / 2
and back: v = (v_left + v_right) / 2, w = (v_right - v_left) / b.
Wheel speeds become integers through a per-robot calibration: scale, then (if a wheel is
over the limit) both wheels scaled down together so the arc's curvature is kept, rounded,
zeroed inside the deadband, and negated for an inverted side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from navd.config import ChassisConfig

__all__ = [
    "WheelCalibration",
    "body_velocity",
    "format_command",
    "ramp",
    "wheel_command",
    "wheel_speeds",
]


@dataclass(frozen=True, slots=True)
class WheelCalibration:
    """How wheel speeds map to the integers the STM32 takes.

    Attributes:
        scale_per_mps: [units/(m/s)] command per wheel speed.
        deadband: [units] smaller magnitudes are sent as 0.
        limit: [units] largest magnitude sent.
        invert_left, invert_right: negate that side (a motor wired backwards).
    """

    scale_per_mps: float
    deadband: int
    limit: int
    invert_left: bool = False
    invert_right: bool = False

    @classmethod
    def of(cls, chassis: ChassisConfig) -> WheelCalibration:
        """The calibration the chassis section gives."""
        return cls(
            chassis.scale_per_mps,
            chassis.deadband,
            chassis.limit,
            chassis.invert_left,
            chassis.invert_right,
        )


def wheel_speeds(
    linear_mps: float, angular_radps: float, track_width_m: float
) -> tuple[float, float]:
    """[m/s] (left, right) wheel ground speeds for a body velocity."""
    half = angular_radps * track_width_m / 2.0
    return linear_mps - half, linear_mps + half


def body_velocity(left_mps: float, right_mps: float, track_width_m: float) -> tuple[float, float]:
    """([m/s], [rad/s]) body velocity from wheel ground speeds."""
    return (left_mps + right_mps) / 2.0, (right_mps - left_mps) / track_width_m


def ramp(current: float, target: float, max_step: float) -> float:
    """One period's move from ``current`` toward ``target`` (a speed): slowing down, to zero
    or through it, happens at once; speeding up by at most ``max_step``."""
    if target * current < 0.0:
        current = 0.0  # reversing: the braking part is immediate
    if abs(target) <= abs(current):
        return target
    return current + math.copysign(min(abs(target - current), max_step), target)


def _round_half_away(value: float) -> int:
    return int(math.copysign(math.floor(abs(value) + 0.5), value))


def wheel_command(left_mps: float, right_mps: float, cal: WheelCalibration) -> tuple[int, int]:
    """Integer (left, right) commands for wheel speeds [m/s] under a calibration."""
    left, right = left_mps * cal.scale_per_mps, right_mps * cal.scale_per_mps
    biggest = max(abs(left), abs(right))
    if biggest > cal.limit:
        shrink = cal.limit / biggest
        left, right = left * shrink, right * shrink
    out = []
    for value, invert in ((left, cal.invert_left), (right, cal.invert_right)):
        units = _round_half_away(value)
        if abs(units) < cal.deadband:
            units = 0
        out.append(-units if invert else units)
    return out[0], out[1]


def format_command(left: int, right: int, line_ending: str = "\n") -> bytes:
    """The line the STM32 reads: "%d %d" and the line ending."""
    return b"%d %d" % (left, right) + line_ending.encode()

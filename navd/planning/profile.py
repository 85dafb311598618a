"""The velocity profile (seed 001 §4.5): a smooth start, a gentle approach, yaw rate by speed."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["VelocityProfile"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class VelocityProfile:
    """Speed caps along a drive to a goal.

    Attributes:
        max_speed_mps: [m/s] top forward speed.
        min_speed_mps: [m/s] the profile never asks for less while driving (it would stall).
        max_accel_mps2: [m/s^2] braking used for the approach.
        acceleration_time_s: [s] the start ramp lasts this long.
        approach_distance_m: [m] the cap falls linearly to min_speed over this last stretch.
        table_speeds_mps, table_yaw_rates_radps: the yaw-rate-by-speed table.
        max_yaw_accel_radps2: [rad/s^2] the robot's angular acceleration limit.
    """

    max_speed_mps: float
    min_speed_mps: float
    max_accel_mps2: float
    acceleration_time_s: float
    approach_distance_m: float
    table_speeds_mps: tuple[float, ...]
    table_yaw_rates_radps: tuple[float, ...]
    max_yaw_accel_radps2: float

    def speed_cap(self, remaining_m: float, moving_s: float) -> float:
        """[m/s] top forward speed with ``remaining_m`` to go after ``moving_s`` of driving.

        The smallest of: the top speed; a cubic start ramp (t / T)^3 of it; the speed from
        which the robot can still brake to rest within the remaining distance, sqrt(2 a d);
        and a linear taper over the approach distance. Never below ``min_speed_mps``.
        """
        cap = self.max_speed_mps
        if self.acceleration_time_s > 0.0 and moving_s < self.acceleration_time_s:
            cap = min(cap, (max(moving_s, 0.0) / self.acceleration_time_s) ** 3 * cap)
        remaining = max(remaining_m, 0.0)
        cap = min(cap, math.sqrt(2.0 * self.max_accel_mps2 * remaining))
        if self.approach_distance_m > 0.0 and remaining < self.approach_distance_m:
            cap = min(cap, self.max_speed_mps * remaining / self.approach_distance_m)
        return max(cap, self.min_speed_mps)

    def yaw_rate_cap(self, speed_mps: float) -> float:
        """[rad/s] top yaw rate at ``speed_mps`` (either direction), from the table."""
        return float(np.interp(abs(speed_mps), self.table_speeds_mps, self.table_yaw_rates_radps))

    def turn_rate(self, error_rad: float) -> float:
        """[rad/s] the yaw rate for a turn on the spot with ``error_rad`` still to turn (signed
        like it): the table's rate at standstill, or the rate from which half the robot's
        angular acceleration a still stops it there, sqrt(a |e|), if that is less.

        A rate that only shrinks with the error (the local planner's choice when asked to end
        its horizon facing the goal's heading) slows exponentially near the end of the turn.
        """
        brake = math.sqrt(self.max_yaw_accel_radps2 * abs(error_rad))
        return math.copysign(min(self.yaw_rate_cap(0.0), brake), error_rad)

    @property
    def yaw_rate_table(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """([m/s] speeds, [rad/s] top yaw rates) of the table, as the local planner takes it."""
        return self.table_speeds_mps, self.table_yaw_rates_radps

"""What the robot's body can do: its top speeds and accelerations, one value every part that
limits motion shares (the safety gate, the local planner, the velocity profile, the collision
guard, the chassis' ramp, stuck recovery, the fleet's factsheet, the simulator)."""

from __future__ import annotations

from dataclasses import dataclass

from navd.config import RobotConfig

__all__ = ["RobotLimits"]


@dataclass(frozen=True, slots=True)
class RobotLimits:
    """The robot's motion limits.

    Attributes:
        max_forward_mps: [m/s] top forward speed.
        max_reverse_mps: [m/s] top backward speed (>= 0, at most the forward one).
        max_yaw_rate_radps: [rad/s] top yaw rate either way.
        max_linear_accel_mps2: [m/s²] top forward acceleration (and braking).
        max_angular_accel_radps2: [rad/s²] top yaw acceleration.
    """

    max_forward_mps: float
    max_reverse_mps: float
    max_yaw_rate_radps: float
    max_linear_accel_mps2: float
    max_angular_accel_radps2: float

    @classmethod
    def of(cls, robot: RobotConfig) -> RobotLimits:
        """The limits the robot section gives."""
        return cls(
            max_forward_mps=robot.max_linear_speed_mps,
            max_reverse_mps=robot.max_reverse_speed_mps,
            max_yaw_rate_radps=robot.max_angular_speed_radps,
            max_linear_accel_mps2=robot.max_linear_accel_mps2,
            max_angular_accel_radps2=robot.max_angular_accel_radps2,
        )

    @property
    def max_speed_mps(self) -> float:
        """[m/s] the top speed either way."""
        return max(self.max_forward_mps, self.max_reverse_mps)

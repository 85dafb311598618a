"""Where a sensor sits on the robot, and which of its readings are trusted."""

from __future__ import annotations

from dataclasses import dataclass

from navd.config import LidarConfig
from navd.geometry.pose import Pose2

__all__ = ["LidarMount"]


@dataclass(frozen=True, slots=True)
class LidarMount:
    """A 2D lidar on the robot.

    Attributes:
        pose: the lidar's pose in base_link (x forward, y left, yaw counter-clockwise).
        min_range_m: [m] shorter ranges are dropped: the robot's own body, dust on the window.
    """

    pose: Pose2
    min_range_m: float

    @classmethod
    def of(cls, lidar: LidarConfig) -> LidarMount:
        """The mount the lidar section describes."""
        return cls(Pose2(lidar.x_m, lidar.y_m, lidar.yaw_rad), lidar.min_range_m)

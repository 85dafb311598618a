"""2D rigid poses (x, y, yaw) and their composition: a ⊕ b, a⁻¹, a ⊖ b."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from navd.geometry.angles import wrap_angle

__all__ = ["IDENTITY", "Pose2"]


class Pose2(NamedTuple):
    """A pose in the plane: position [m] and yaw [rad] counter-clockwise from +x.

    Poses cross every module boundary as Pose2 (a robot in the map, a sensor on the robot,
    a relative motion); ``pose.x`` rather than ``pose[0]``.
    """

    x: float
    y: float
    yaw: float

    def compose(self, other: Pose2) -> Pose2:
        """self ⊕ other: ``other`` (given in this pose's frame) in the outer frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            wrap_angle(self.yaw + other.yaw),
        )

    def inverse(self) -> Pose2:
        """The pose whose composition with this one is the identity."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2(-c * self.x - s * self.y, s * self.x - c * self.y, wrap_angle(-self.yaw))

    def between(self, other: Pose2) -> Pose2:
        """self⁻¹ ⊕ other: ``other`` seen from this pose (a relative motion)."""
        return self.inverse().compose(other)

    def distance_to(self, other: Pose2) -> float:
        """[m] straight-line distance between the two positions."""
        return math.hypot(other.x - self.x, other.y - self.y)

    def transform(self, points: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Points (N x 2) given in this pose's frame, in the outer frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        rotation = np.array([[c, -s], [s, c]])
        moved: npt.NDArray[np.float64] = points.reshape(-1, 2) @ rotation.T + (self.x, self.y)
        return moved


IDENTITY = Pose2(0.0, 0.0, 0.0)

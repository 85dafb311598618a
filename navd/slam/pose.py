"""2D rigid poses (x, y, yaw) and their composition: a ⊕ b, a⁻¹, a ⊖ b."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

__all__ = ["Pose2"]


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class Pose2(NamedTuple):
    """A pose in the plane: position [m] and yaw [rad] counter-clockwise from +x."""

    x: float
    y: float
    yaw: float

    def compose(self, other: Pose2) -> Pose2:
        """self ⊕ other: ``other`` (given in this pose's frame) in the outer frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            _wrap(self.yaw + other.yaw),
        )

    def inverse(self) -> Pose2:
        """The pose whose composition with this one is the identity."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2(-c * self.x - s * self.y, s * self.x - c * self.y, _wrap(-self.yaw))

    def between(self, other: Pose2) -> Pose2:
        """self⁻¹ ⊕ other: ``other`` seen from this pose (a relative motion)."""
        return self.inverse().compose(other)

    def transform(self, points: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Points (N x 2) given in this pose's frame, in the outer frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        rotation = np.array([[c, -s], [s, c]])
        moved: npt.NDArray[np.float64] = points @ rotation.T + (self.x, self.y)
        return moved

"""The robot's footprint: a circle or a rectangle centred on base_link."""

from __future__ import annotations

import math
from dataclasses import dataclass

from navd.config import RobotConfig

__all__ = ["CIRCLE", "RECTANGLE", "Footprint"]

# The footprint's shape, as the integer code the numba kernels take.
CIRCLE = 0
RECTANGLE = 1


@dataclass(frozen=True, slots=True)
class Footprint:
    """A footprint in the robot frame (x forward, y left).

    Attributes:
        kind: CIRCLE or RECTANGLE.
        half_length_m: [m] rectangle half extent along x; the radius for a circle.
        half_width_m: [m] rectangle half extent along y; the radius for a circle.
    """

    kind: int
    half_length_m: float
    half_width_m: float

    @classmethod
    def circle(cls, radius_m: float) -> Footprint:
        """A disc of ``radius_m`` [m]."""
        return cls(CIRCLE, radius_m, radius_m)

    @classmethod
    def rectangle(cls, length_m: float, width_m: float) -> Footprint:
        """A ``length_m`` x ``width_m`` [m] rectangle, long side along x."""
        return cls(RECTANGLE, length_m / 2.0, width_m / 2.0)

    @classmethod
    def of(cls, robot: RobotConfig) -> Footprint:
        """The footprint the robot section describes."""
        if robot.footprint == "circle":
            return cls.circle(robot.radius_m)
        return cls.rectangle(robot.length_m, robot.width_m)

    @property
    def inscribed_m(self) -> float:
        """[m] radius of the largest circle around base_link inside the footprint."""
        return min(self.half_length_m, self.half_width_m)

    @property
    def circumradius_m(self) -> float:
        """[m] radius of the smallest circle around base_link holding the footprint."""
        if self.kind == CIRCLE:
            return self.half_length_m
        return math.hypot(self.half_length_m, self.half_width_m)

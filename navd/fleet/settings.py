"""The fleet room's settings: the fleet section, and what the factsheet says of the robot,
derived once from the fleet, robot and slam sections; the only place the room reads the
config."""

from __future__ import annotations

import math
from dataclasses import dataclass

from navd.config import FleetConfig, NavdConfig
from navd.geometry import Footprint, RobotLimits

__all__ = ["FleetSettings"]


@dataclass(frozen=True, slots=True)
class FleetSettings:
    """The vehicle's settings.

    Attributes:
        fleet: broker, names and publishing rates (the broker and names need a restart).
        limits: the robot's speeds and accelerations (the factsheet).
        footprint: the robot's outline (the factsheet's size).
        map_id: the map the positions are on (``slam.map_name``).
        radius_m: [m] the robot's circumscribed radius (another vehicle's when its
            factsheet has not come).
    """

    fleet: FleetConfig
    limits: RobotLimits
    footprint: Footprint
    map_id: str
    radius_m: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> FleetSettings:
        """The settings the fleet, robot and slam sections describe."""
        footprint = Footprint.of(config.robot)
        radius = math.hypot(footprint.half_length_m, footprint.half_width_m)
        return cls(
            fleet=config.fleet,
            limits=RobotLimits.of(config.robot),
            footprint=footprint,
            map_id=config.slam.map_name,
            radius_m=radius,
        )

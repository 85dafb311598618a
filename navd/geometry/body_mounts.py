"""Where the robot's other sensors sit: range sensors, bumpers and cliff sensors, depth
cameras, by the name each sensor's frames give (``body_points`` turns their readings into
obstacle points)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.config import MountsConfig
from navd.geometry.errors import UnknownMountError
from navd.geometry.pose import Pose2
from navd.geometry.rotation import rotation_rpy

__all__ = ["BodyMounts", "ContactMount", "DepthMount"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class ContactMount:
    """A bumper or cliff sensor: its point on the robot's outline [m] and the direction it
    faces [rad], in base_link."""

    x_m: float
    y_m: float
    facing_rad: float


@dataclass(frozen=True, slots=True)
class DepthMount:
    """A depth camera: its pose (rotation and position in base_link) and the band of heights
    [m] and reach [m] in which its points are obstacles."""

    rotation: FloatArray
    position_m: tuple[float, float, float]
    min_height_m: float
    max_height_m: float
    max_range_m: float


@dataclass(frozen=True, slots=True)
class BodyMounts:
    """The range, contact and depth mounts, by sensor name."""

    ranges: Mapping[str, Pose2]
    contacts: Mapping[str, ContactMount]
    depth: Mapping[str, DepthMount]

    @classmethod
    def of(cls, m: MountsConfig) -> BodyMounts:
        """The mounts the ``mounts`` section describes."""
        contacts = {
            name: ContactMount(
                c.x_m,
                c.y_m,
                c.facing_rad if c.facing_rad is not None else math.atan2(c.y_m, c.x_m),
            )
            for name, c in m.contacts.items()
        }
        depth = {
            name: DepthMount(
                rotation_rpy(d.roll_rad, d.pitch_rad, d.yaw_rad),
                (d.x_m, d.y_m, d.z_m),
                d.min_height_m,
                d.max_height_m,
                d.max_range_m,
            )
            for name, d in m.depth.items()
        }
        ranges = {name: Pose2(r.x_m, r.y_m, r.yaw_rad) for name, r in m.ranges.items()}
        return cls(ranges, contacts, depth)

    def range_sensor(self, name: str) -> Pose2:
        """The pose of range sensor ``name``.

        Raises:
            UnknownMountError: it has no mount (a cone pointing nowhere cannot be placed).
        """
        try:
            return self.ranges[name]
        except KeyError:
            raise UnknownMountError(
                f"range sensor {name!r} has no mount: add [mounts.ranges.{name}]"
            ) from None

    def depth_camera(self, name: str) -> DepthMount:
        """The mount of depth camera ``name``.

        Raises:
            UnknownMountError: it has no mount.
        """
        try:
            return self.depth[name]
        except KeyError:
            raise UnknownMountError(
                f"depth camera {name!r} has no mount: add [mounts.depth.{name}]"
            ) from None

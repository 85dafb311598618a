"""Where each sensor sits on the robot, and which of its readings are trusted."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from navd.config import LidarConfig, LidarMountConfig, MountsConfig
from navd.geometry.body_mounts import BodyMounts
from navd.geometry.errors import UnknownMountError
from navd.geometry.pose import Pose2
from navd.geometry.rotation import rotation_rpy

__all__ = ["LidarMount", "SensorMounts", "rotation_rpy"]

FloatArray = np.ndarray[tuple[int, ...], np.dtype[np.float64]]

# What each sensor role's mounts are called in the config (``mounts.<table>.<device id>``).
MOUNT_TABLES = {"lidar": "lidars", "imu": "imus", "gps": "gps", "compass": "compasses"}


@dataclass(frozen=True, slots=True)
class LidarMount:
    """A 2D lidar on the robot.

    Attributes:
        pose: the lidar's pose in base_link (x forward, y left, yaw counter-clockwise).
        min_range_m: [m] shorter ranges are dropped: the robot's own body, dust on the window.
        upside_down: the lidar hangs upside down, so its bearings run clockwise in base_link.
    """

    pose: Pose2
    min_range_m: float
    upside_down: bool = False

    @classmethod
    def of(cls, lidar: LidarConfig | LidarMountConfig) -> LidarMount:
        """The mount the lidar section (or one lidar's mount table) describes."""
        return cls(Pose2(lidar.x_m, lidar.y_m, lidar.yaw_rad), lidar.min_range_m, lidar.upside_down)


@dataclass(frozen=True, slots=True)
class SensorMounts:
    """Every sensor's mount, by device id, as the config gives them.

    A kind with no mounts configured has one implicit mount for any device: the ``lidar``
    section for lidars, base_link itself for the others. A kind with mounts takes only the
    devices it names.

    Attributes:
        lidars: lidar mounts by device id; default_lidar: the ``lidar`` section's.
        imus: [rad] each IMU's (roll, pitch, yaw) to base_link.
        gps: [m] each GNSS antenna's (x, y) in base_link.
        compasses: [rad] each compass's forward-axis yaw in base_link (a dual-antenna GNSS
            receiver's baseline yaw under its gps id).
        frame_ids: the ROS frame_id each mounted device's frames may carry.
        body: the range sensors', bumpers', cliff sensors' and depth cameras' mounts.
    """

    default_lidar: LidarMount
    lidars: Mapping[str, LidarMount] = field(default_factory=dict)
    imus: Mapping[str, tuple[float, float, float]] = field(default_factory=dict)
    gps: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    compasses: Mapping[str, float] = field(default_factory=dict)
    frame_ids: Mapping[str, str] = field(default_factory=dict)
    body: BodyMounts = field(default_factory=lambda: BodyMounts({}, {}, {}))

    @classmethod
    def of(cls, m: MountsConfig, lidar: LidarConfig) -> SensorMounts:
        """The mounts the ``mounts`` and ``lidar`` sections describe."""
        frame_ids: dict[str, str] = {}
        for table in (m.lidars, m.imus, m.gps, m.compasses):
            for device_id, mount in table.items():
                frame_ids[device_id] = mount.frame_id or device_id
        return cls(
            default_lidar=LidarMount.of(lidar),
            lidars={k: LidarMount.of(v) for k, v in m.lidars.items()},
            imus={k: (v.roll_rad, v.pitch_rad, v.yaw_rad) for k, v in m.imus.items()},
            gps={k: (v.x_m, v.y_m) for k, v in m.gps.items()},
            # a dual-antenna receiver's heading comes from its gps id, through its baseline
            compasses={k: v.heading_yaw_rad for k, v in m.gps.items()}
            | {k: v.yaw_rad for k, v in m.compasses.items()},
            frame_ids=frame_ids,
            body=BodyMounts.of(m),
        )

    def lidar(self, device_id: str) -> LidarMount:
        """The mount of lidar ``device_id`` (the ``lidar`` section's when none are listed).

        Raises:
            UnknownMountError: lidars are listed and this one is not (its hello was refused).
        """
        if not self.lidars:
            return self.default_lidar
        try:
            return self.lidars[device_id]
        except KeyError:
            raise UnknownMountError(
                f"lidar {device_id!r} has no mount: add [mounts.lidars.{device_id}]"
            ) from None

    def imu_rotation(self, device_id: str) -> FloatArray | None:
        """The IMU's rotation to base_link, or None when it is aligned with it."""
        rpy = self.imus.get(device_id)
        if rpy is None or rpy == (0.0, 0.0, 0.0):
            return None
        return rotation_rpy(*rpy)

    def gps_offset_m(self, device_id: str) -> tuple[float, float]:
        """[m] the antenna's (x, y) in base_link ((0, 0) when not listed)."""
        return self.gps.get(device_id, (0.0, 0.0))

    def compass_yaw_rad(self, device_id: str) -> float:
        """[rad] the compass's forward axis in base_link (0 when not listed)."""
        return self.compasses.get(device_id, 0.0)

    def refusal(self, role: str, device_id: str) -> str | None:
        """Why a device of ``role`` may not connect as ``device_id``, or None: once a kind
        has mounts, a device of that kind needs its own."""
        table = MOUNT_TABLES.get(role)
        if table is None:
            return None
        listed: Mapping[str, object] = getattr(self, table)  # the fields are named as the tables
        if not listed or device_id in listed:
            return None
        return (
            f"{device_id!r} has no mount: add [mounts.{table}.{device_id}] to the config "
            f"(the {role} mounts there: {', '.join(sorted(listed))})"
        )

    def frame_refusal(self, device_id: str, frame_id: str) -> str | None:
        """Why a frame of ``device_id`` whose header names ``frame_id`` is refused, or None.
        A device without a mount takes any frame_id (there is nothing to check it with)."""
        expected = self.frame_ids.get(device_id)
        if expected is None or frame_id == expected:
            return None
        return (
            f"frame_id {frame_id!r} is not {device_id}'s frame ({expected!r}); set the mount's "
            "frame_id or send the device's own frame"
        )

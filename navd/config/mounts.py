"""Where each sensor sits on the robot, keyed by the device id it says in its hello.

A robot with one lidar needs none of this: the ``lidar`` section places it, and the IMU,
GNSS antenna and compass are taken as aligned with base_link at its centre. Once a kind has
a mount here, every device of that kind must have one (a device without is refused by name
when it connects), so two lidars can never be read through one mount by mistake.
"""

from __future__ import annotations

import re

from pydantic import Field, model_validator

from navd.config.fields import Matrix2, Section, Vector2, restart

__all__ = [
    "CompassMountConfig",
    "ContactMountConfig",
    "DepthMountConfig",
    "GpsMountConfig",
    "ImuMountConfig",
    "LidarMountConfig",
    "MountsConfig",
    "RangeMountConfig",
]

# The device ids a hello may give (the protocol's pattern, repeated here: config sits below
# the protocol).
_DEVICE_ID = re.compile(r"^[A-Za-z0-9_.:\-]{1,64}$")
_PI = 3.1416

_FRAME_ID = Field(
    None,
    min_length=1,
    max_length=128,
    description=(
        "the ROS frame_id this device's frames carry in their header (default: the device "
        "id); a header naming another frame is refused"
    ),
)


def _yaw(what: str) -> object:
    return Field(
        0.0,
        ge=-_PI,
        le=_PI,
        description=f"[rad] {what} yaw in base_link, counter-clockwise from the robot's forward",
    )


class LidarMountConfig(Section):
    """A 2D lidar's pose on the robot."""

    x_m: float = Field(0.0, ge=-5, le=5, description="[m] lidar x in base_link (forward)")
    y_m: float = Field(0.0, ge=-5, le=5, description="[m] lidar y in base_link (left)")
    yaw_rad: float = _yaw("lidar")  # type: ignore[assignment]
    upside_down: bool = Field(
        False, description="mounted upside down: its bearings turn clockwise in base_link"
    )
    min_range_m: float = Field(
        0.1,
        ge=0,
        le=10,
        description="[m] shorter ranges are ignored (the robot's own body, dust on the window)",
    )
    frame_id: str | None = _FRAME_ID


class ImuMountConfig(Section):
    """An IMU's rotation to base_link (roll, then pitch, then yaw: the sensor's axes as
    seen from base_link)."""

    roll_rad: float = Field(0.0, ge=-_PI, le=_PI, description="[rad] rotation about x")
    pitch_rad: float = Field(0.0, ge=-_PI, le=_PI, description="[rad] rotation about y")
    yaw_rad: float = Field(0.0, ge=-_PI, le=_PI, description="[rad] rotation about z")
    frame_id: str | None = _FRAME_ID


class GpsMountConfig(Section):
    """A GNSS antenna's place on the robot: a fix is where the antenna is, not the centre;
    and, for a dual-antenna receiver, which way its baseline points: the true heading it
    reports (HDT) is the heading of the line from its primary to its secondary antenna."""

    x_m: float = Field(0.0, ge=-5, le=5, description="[m] antenna x in base_link (forward)")
    y_m: float = Field(0.0, ge=-5, le=5, description="[m] antenna y in base_link (left)")
    heading_yaw_rad: float = _yaw(  # type: ignore[assignment]
        "dual-antenna baseline (primary to secondary antenna; 0: the secondary straight ahead)"
    )
    frame_id: str | None = _FRAME_ID


class CompassMountConfig(Section):
    """A compass's heading offset (the yaw of its forward axis in base_link) and, for a bare
    magnetometer, its calibration (read by its sensor program; written by ``navd sensor
    calibrate-compass``)."""

    yaw_rad: float = _yaw("compass forward axis")  # type: ignore[assignment]
    hard_iron_ut: Vector2 = Field(
        (0.0, 0.0), description="[µT] the field's offset from the robot's own magnetism (x, y)"
    )
    soft_iron: Matrix2 = Field(
        ((1.0, 0.0), (0.0, 1.0)),
        description="2 x 2 matrix (rows) that turns the offset field's ellipse into a circle",
    )
    frame_id: str | None = _FRAME_ID

    @model_validator(mode="after")
    def _soft_iron_invertible(self) -> CompassMountConfig:
        (a, b), (c, d) = self.soft_iron
        if abs(a * d - b * c) < 1e-6:
            raise ValueError("soft_iron: the matrix is singular; calibrate the compass again")
        return self


class RangeMountConfig(Section):
    """A range sensor (ultrasonic, time of flight) on the robot: where it is and which way
    its cone points."""

    x_m: float = Field(0.0, ge=-5, le=5, description="[m] sensor x in base_link (forward)")
    y_m: float = Field(0.0, ge=-5, le=5, description="[m] sensor y in base_link (left)")
    yaw_rad: float = _yaw("the cone's axis")  # type: ignore[assignment]
    frame_id: str | None = _FRAME_ID


class ContactMountConfig(Section):
    """A bumper or a cliff sensor: the point of the robot's outline it watches, and which
    way it faces (moving the other way is backing away from what it felt)."""

    x_m: float = Field(0.0, ge=-5, le=5, description="[m] the point's x in base_link (forward)")
    y_m: float = Field(0.0, ge=-5, le=5, description="[m] the point's y in base_link (left)")
    facing_rad: float | None = Field(
        None,
        ge=-_PI,
        le=_PI,
        description="[rad] the direction it faces in base_link (default: from the robot's "
        "centre out through the point)",
    )


class DepthMountConfig(Section):
    """A depth camera's pose on the robot (roll, then pitch, then yaw of its body axes: x
    forward, y left, z up) and the band of heights its points are obstacles in."""

    x_m: float = Field(0.0, ge=-5, le=5, description="[m] camera x in base_link (forward)")
    y_m: float = Field(0.0, ge=-5, le=5, description="[m] camera y in base_link (left)")
    z_m: float = Field(0.3, ge=-5, le=5, description="[m] camera height above the floor")
    roll_rad: float = Field(0.0, ge=-_PI, le=_PI, description="[rad] rotation about x")
    pitch_rad: float = Field(0.0, ge=-_PI, le=_PI, description="[rad] rotation about y (down +)")
    yaw_rad: float = Field(0.0, ge=-_PI, le=_PI, description="[rad] rotation about z")
    min_height_m: float = Field(
        0.05, ge=0, le=5, description="[m] lower points are the floor, not obstacles"
    )
    max_height_m: float = Field(
        1.2, gt=0, le=10, description="[m] higher points are above the robot, not obstacles"
    )
    max_range_m: float = Field(
        4.0, gt=0, le=50, description="[m] farther points are too noisy to mark"
    )
    frame_id: str | None = _FRAME_ID

    @model_validator(mode="after")
    def _band(self) -> DepthMountConfig:
        if self.max_height_m <= self.min_height_m:
            raise ValueError(
                f"max_height_m {self.max_height_m} must be above min_height_m {self.min_height_m}"
            )
        return self


class MountsConfig(Section):
    """Sensor mounts by device id: ``[mounts.lidars.front]``, ``[mounts.gps.gnss0]``..."""

    lidars: dict[str, LidarMountConfig] = Field(
        default_factory=dict,
        examples=[
            {
                "front": {"x_m": 0.15, "yaw_rad": 0.0},
                "rear": {"x_m": -0.15, "yaw_rad": 3.1416, "upside_down": True},
            }
        ],
        **restart("lidar mounts by device id (none: the lidar section places the one lidar)"),
    )
    imus: dict[str, ImuMountConfig] = Field(
        default_factory=dict,
        examples=[{"imu0": {"roll_rad": 0.0, "pitch_rad": 0.0, "yaw_rad": 1.5708}}],
        **restart("IMU mounts by device id (none: any IMU is aligned with base_link)"),
    )
    gps: dict[str, GpsMountConfig] = Field(
        default_factory=dict,
        examples=[{"gnss0": {"x_m": 0.3, "y_m": 0.0}}],
        **restart("GNSS antenna mounts by device id (none: at the robot's centre)"),
    )
    compasses: dict[str, CompassMountConfig] = Field(
        default_factory=dict,
        examples=[{"compass0": {"yaw_rad": 0.0}}],
        **restart("compass mounts by device id (none: aligned with base_link)"),
    )

    ranges: dict[str, RangeMountConfig] = Field(
        default_factory=dict,
        examples=[{"sonar_front": {"x_m": 0.2, "yaw_rad": 0.0}}],
        **restart("range sensor mounts by sensor name (a reading without one is refused)"),
    )
    contacts: dict[str, ContactMountConfig] = Field(
        default_factory=dict,
        examples=[{"bumper_left": {"x_m": 0.18, "y_m": 0.1}, "cliff_front": {"x_m": 0.22}}],
        **restart(
            "bumper and cliff sensor mounts by sensor name (without one, a triggered sensor "
            "holds every motion until it is released)"
        ),
    )
    depth: dict[str, DepthMountConfig] = Field(
        default_factory=dict,
        examples=[{"camera": {"x_m": 0.15, "z_m": 0.35, "pitch_rad": 0.3}}],
        **restart("depth camera mounts by sensor name (points without one are refused)"),
    )

    @model_validator(mode="after")
    def _ids(self) -> MountsConfig:
        seen: dict[str, str] = {}
        for kind in ("lidars", "imus", "gps", "compasses", "ranges", "contacts", "depth"):
            for device_id in getattr(self, kind):
                if not _DEVICE_ID.match(device_id):
                    raise ValueError(
                        f"mounts.{kind}.{device_id}: a device id is 1-64 letters, digits "
                        "and _ . : -"
                    )
                if device_id in seen:
                    raise ValueError(
                        f"mounts.{kind}.{device_id}: the id is also under mounts.{seen[device_id]}"
                        "; each device has one kind"
                    )
                seen[device_id] = kind
        return self

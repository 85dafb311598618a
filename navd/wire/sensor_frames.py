"""What sensor programs send: a lidar sweep, an IMU sample, a GNSS fix, a compass bearing,
wheel odometry and a beacon sighting, in ROS's field names and units (sensor_msgs/LaserScan,
Imu in rad/s, m/s² and tesla, NavSatFix in degrees and metres)."""

from __future__ import annotations

import base64
import binascii
import math
from typing import Any, Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from navd.wire.base import DEVICE_ID_PATTERN, MAX_RAYS, Covariance, Frame, Stamp, Vec3
from navd.wire.body_frames import BatteryFrame, ContactFrame, PointsFrame, RangeFrame
from navd.wire.errors import WireError

__all__ = [
    "ALSO_SENT",
    "SENSOR_FRAMES",
    "BeaconFrame",
    "FixFrame",
    "HeadingFrame",
    "ImuFrame",
    "OdomFrame",
    "ScanFrame",
    "SensorFrame",
]


class ScanFrame(Frame):
    """A lidar sweep (sensor_msgs/LaserScan); ``ranges`` or ``ranges_f32``, not both.

    ``stamp`` is the time of the first ray; ``time_increment`` [s] the time from one ray to
    the next (a turning lidar's rays are measured one after the other, so a robot that moves
    meanwhile sees each from a slightly different place); ``intensities`` one per ray, in the
    device's own units (reflectivity or signal strength), empty or absent when it has none.
    """

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True, allow_inf_nan=True)

    type: Literal["scan"] = "scan"
    stamp: Stamp
    angle_min: float = Field(allow_inf_nan=False)
    angle_increment: float = Field(allow_inf_nan=False)
    range_min: float = Field(ge=0, allow_inf_nan=False)
    range_max: float = Field(gt=0, allow_inf_nan=False)
    time_increment: float = Field(0.0, ge=0, allow_inf_nan=False)
    ranges: list[float | None] | None = Field(None, max_length=MAX_RAYS)
    ranges_f32: str | None = Field(None, max_length=(MAX_RAYS * 4 * 4) // 3 + 4)
    intensities: list[float | None] | None = Field(None, max_length=MAX_RAYS)

    @model_validator(mode="after")
    def _consistent(self) -> ScanFrame:
        if (self.ranges is None) == (self.ranges_f32 is None):
            raise ValueError(
                "ranges: give exactly one of ranges (JSON numbers) and ranges_f32 (base64)"
            )
        if self.angle_increment == 0.0:
            raise ValueError("angle_increment: must be non-zero")
        if self.intensities and len(self.intensities) != self._rays():
            raise ValueError(
                f"intensities: {len(self.intensities)} values for {self._rays()} ranges "
                "(give one per ray, or none)"
            )
        if self.range_max <= self.range_min:
            raise ValueError(
                f"range_max: must exceed range_min ({self.range_min}), got {self.range_max}"
            )
        return self

    def _rays(self) -> int:
        """How many rays the ranges hold (for ``ranges_f32``, from its base64 length)."""
        if self.ranges is not None:
            return len(self.ranges)
        text = (self.ranges_f32 or "").rstrip("=")
        return (len(text) * 3 // 4) // 4

    def ranges_array(self) -> np.ndarray[Any, np.dtype[np.float32]]:
        """[m] the ranges as float32; null becomes NaN (an invalid ray).

        Raises:
            WireError: ``ranges_f32`` is not base64 of whole float32 values.
        """
        if self.ranges is not None:
            return np.array(self.ranges, dtype=np.float32)  # numpy turns None into NaN
        assert self.ranges_f32 is not None
        try:
            raw = base64.b64decode(self.ranges_f32, validate=True)
        except binascii.Error as err:
            raise WireError("ranges_f32", f"not valid base64: {err}") from err
        if len(raw) % 4:
            raise WireError("ranges_f32", f"{len(raw)} bytes is not a whole number of float32")
        return np.frombuffer(raw, dtype="<f4").astype(np.float32)

    def intensities_array(self) -> np.ndarray[Any, np.dtype[np.float32]] | None:
        """The intensities as float32 (null becomes NaN), None when the frame has none."""
        if not self.intensities:
            return None
        return np.array(self.intensities, dtype=np.float32)


class ImuFrame(Frame):
    """An IMU sample (sensor_msgs/Imu): rad/s, m/s², and tesla for the magnetometer. An Imu
    message's ``header``, ``{x, y, z}`` vectors, ``orientation`` and covariances are taken
    too (navd fuses its own orientation; the covariances are not used)."""

    type: Literal["imu"] = "imu"
    stamp: Stamp
    angular_velocity: Vec3
    linear_acceleration: Vec3
    magnetic_field: Vec3 | None = None
    orientation: dict[str, float] | None = None
    orientation_covariance: Covariance | None = None
    angular_velocity_covariance: Covariance | None = None
    linear_acceleration_covariance: Covariance | None = None


class FixFrame(Frame):
    """A GNSS fix (sensor_msgs/NavSatFix); ``status`` -1 means no fix (ignored, not an error).
    A NavSatFix's ``header``, ``status`` object and ``position_covariance`` are taken too:
    without ``horizontal_accuracy``, a known covariance gives it (the larger of the east and
    north standard deviations)."""

    type: Literal["fix"] = "fix"
    stamp: Stamp
    latitude: float = Field(ge=-90, le=90)
    longitude: float = Field(ge=-180, le=180)
    altitude: float = 0.0
    horizontal_accuracy: float = Field(gt=0)
    status: int = Field(0, ge=-1, le=2)
    position_covariance: Covariance | None = None
    position_covariance_type: int = Field(0, ge=0, le=3)


class HeadingFrame(Frame):
    """A compass bearing: degrees clockwise from north, as compasses report it."""

    type: Literal["heading"] = "heading"
    stamp: Stamp
    bearing_deg: float = Field(ge=0, lt=360)
    accuracy_deg: float = Field(gt=0, le=180)
    true_north: bool = False


class BeaconFrame(Frame):
    """A range and/or a bearing to one beacon (a UWB anchor, an AprilTag, a BLE tag), from
    the robot's centre: ``range_m`` [m] and ``bearing_rad`` [rad, counter-clockwise from the
    robot's forward axis], each with its 1-sigma noise."""

    type: Literal["beacon"] = "beacon"
    stamp: Stamp
    beacon: str = Field(pattern=DEVICE_ID_PATTERN)
    range_m: float | None = Field(None, ge=0, le=10_000)
    range_std_m: float = Field(0.1, gt=0, le=1000)
    bearing_rad: float | None = Field(None, ge=-2 * math.pi, le=2 * math.pi)
    bearing_std_rad: float = Field(0.05, gt=0, le=math.pi)

    @model_validator(mode="after")
    def _something_measured(self) -> BeaconFrame:
        if self.range_m is None and self.bearing_rad is None:
            raise ValueError("a beacon frame needs range_m, bearing_rad or both")
        return self


class OdomFrame(Frame):
    """Wheel odometry: body velocity (geometry_msgs/Twist linear.x and angular.z)."""

    type: Literal["odom"] = "odom"
    stamp: Stamp
    linear_x: float
    angular_z: float


SensorFrame = (
    ScanFrame
    | ImuFrame
    | FixFrame
    | HeadingFrame
    | OdomFrame
    | BeaconFrame
    | RangeFrame
    | ContactFrame
    | PointsFrame
    | BatteryFrame
)

# The data frame of each sensor role; ``ALSO_SENT`` the others a role may send (a
# dual-antenna GNSS receiver is one device: its true heading comes on its gps connection).
ALSO_SENT: dict[str, tuple[type[SensorFrame], ...]] = {"gps": (HeadingFrame,)}
SENSOR_FRAMES: dict[str, type[SensorFrame]] = {
    "lidar": ScanFrame,
    "imu": ImuFrame,
    "gps": FixFrame,
    "compass": HeadingFrame,
    "wheel_odometry": OdomFrame,
    "beacon": BeaconFrame,
    "range": RangeFrame,
    "contact": ContactFrame,
    "points": PointsFrame,
    "battery": BatteryFrame,
}

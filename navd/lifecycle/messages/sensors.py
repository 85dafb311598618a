"""What sensors measured, and devices coming, going, falling silent."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.lifecycle.errors import MessageError
from navd.lifecycle.messages.base import (
    DeviceKind,
    FloatArray,
    Message,
    Vector3,
    read_only,
    require_finite,
)

# --- sensors ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class LaserScan(Message):
    """One sweep of a 2D lidar, with the meaning of sensor_msgs/LaserScan.

    ``stamp`` is the time of the first ray. Ranges outside [range_min, range_max], NaN and
    inf are invalid and are discarded by consumers, never here.

    Attributes:
        device_id: the lidar that produced the scan.
        angle_min: [rad] angle of the first ray, counter-clockwise from the sensor's +x.
        angle_increment: [rad] angle between consecutive rays (negative for clockwise).
        ranges: [m] one range per ray (read-only float32 array).
        range_min: [m] smallest valid range.
        range_max: [m] largest valid range.
        time_increment: [s] time between consecutive rays (0 if unknown).
        intensities: one per ray in the device's units (read-only float32), or None.
    """

    device_id: str
    angle_min: float
    angle_increment: float
    ranges: npt.NDArray[np.float32]
    range_min: float
    range_max: float
    time_increment: float = 0.0
    intensities: npt.NDArray[np.float32] | None = None

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        for name in ("angle_min", "angle_increment", "range_min", "range_max"):
            require_finite(name, getattr(self, name))
        if self.angle_increment == 0.0:
            raise MessageError("angle_increment must be non-zero")
        if self.range_min < 0.0 or self.range_max <= self.range_min:
            raise MessageError(
                f"need 0 <= range_min < range_max, got range_min={self.range_min} "
                f"range_max={self.range_max}"
            )
        if self.time_increment < 0.0:
            raise MessageError(f"time_increment must be >= 0, got {self.time_increment}")
        object.__setattr__(self, "ranges", read_only("ranges", self.ranges, np.float32, 1))
        if self.intensities is not None:
            values = read_only("intensities", self.intensities, np.float32, 1)
            if values.size != self.ranges.size:
                raise MessageError(
                    f"intensities: {values.size} values for {self.ranges.size} ranges"
                )
            object.__setattr__(self, "intensities", values)

    @property
    def angles(self) -> FloatArray:
        """[rad] the angle of every ray, in the sensor frame."""
        return self.angle_min + self.angle_increment * np.arange(self.ranges.size, dtype=np.float64)


@dataclass(frozen=True, slots=True, kw_only=True)
class Imu(Message):
    """One IMU sample in the sensor frame.

    Attributes:
        device_id: the IMU that produced the sample.
        gyro_radps: [rad/s] angular velocity.
        accel_mps2: [m/s²] specific force (gravity included, +z up when level).
        mag_ut: [µT] magnetic field, or None when the IMU has no magnetometer.
    """

    device_id: str
    gyro_radps: Vector3
    accel_mps2: Vector3
    mag_ut: Vector3 | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class GpsFix(Message):
    """A GNSS fix, with the meaning of sensor_msgs/NavSatFix.

    Attributes:
        device_id: the receiver.
        latitude_deg: [deg] WGS84 latitude, north positive.
        longitude_deg: [deg] WGS84 longitude, east positive.
        altitude_m: [m] height above the WGS84 ellipsoid.
        horizontal_accuracy_m: [m] 1-sigma horizontal position accuracy.
    """

    device_id: str
    latitude_deg: float
    longitude_deg: float
    altitude_m: float
    horizontal_accuracy_m: float

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        if not -90.0 <= self.latitude_deg <= 90.0:
            raise MessageError(f"latitude_deg must be in [-90, 90], got {self.latitude_deg}")
        if not -180.0 <= self.longitude_deg <= 180.0:
            raise MessageError(f"longitude_deg must be in [-180, 180], got {self.longitude_deg}")
        if not self.horizontal_accuracy_m > 0.0:
            raise MessageError(
                f"horizontal_accuracy_m must be > 0, got {self.horizontal_accuracy_m}"
            )


@dataclass(frozen=True, slots=True, kw_only=True)
class BeaconObservation(Message):
    """A range and/or a bearing from the robot's centre to one beacon.

    Attributes:
        device_id: the sensor that measured it (a UWB tag, a tag detector).
        beacon_id: which beacon.
        range_m, range_std_m: [m] the distance and its 1-sigma noise; NaN range: none.
        bearing_rad, bearing_std_rad: [rad] the direction, counter-clockwise from the robot's
            forward axis, and its 1-sigma noise; NaN bearing: none.
    """

    device_id: str
    beacon_id: str
    range_m: float = math.nan
    range_std_m: float = 0.1
    bearing_rad: float = math.nan
    bearing_std_rad: float = 0.05

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        if math.isnan(self.range_m) and math.isnan(self.bearing_rad):
            raise MessageError("a beacon observation needs a range_m, a bearing_rad or both")
        if not (math.isnan(self.range_m) or 0.0 <= self.range_m < math.inf):
            raise MessageError(f"range_m must be finite and >= 0, got {self.range_m}")
        if not (self.range_std_m > 0.0 and self.bearing_std_rad > 0.0):
            raise MessageError(
                f"range_std_m and bearing_std_rad must be > 0, got {self.range_std_m} and "
                f"{self.bearing_std_rad}"
            )

    @property
    def has_range(self) -> bool:
        return not math.isnan(self.range_m)

    @property
    def has_bearing(self) -> bool:
        return not math.isnan(self.bearing_rad)


@dataclass(frozen=True, slots=True, kw_only=True)
class NearbyRobots(Message):
    """Other robots of the fleet on this robot's map, as they last said where they are.

    Attributes:
        robots: each robot's (name, x [m], y [m], yaw [rad], forward speed [m/s], radius [m]),
            fresh ones only (an empty tuple: none, or all gone quiet).
    """

    robots: tuple[tuple[str, float, float, float, float, float], ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class CompassHeading(Message):
    """A compass reading as the device reports it: a bearing, never a map yaw.

    Attributes:
        device_id: the compass.
        bearing_deg: [deg] heading clockwise from north, in [0, 360).
        accuracy_deg: [deg] 1-sigma accuracy.
        true_north: True if the bearing is from true north, False if from magnetic north.
    """

    device_id: str
    bearing_deg: float
    accuracy_deg: float
    true_north: bool = False

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        if not 0.0 <= self.bearing_deg < 360.0:
            raise MessageError(f"bearing_deg must be in [0, 360), got {self.bearing_deg}")
        if not self.accuracy_deg > 0.0:
            raise MessageError(f"accuracy_deg must be > 0, got {self.accuracy_deg}")


@dataclass(frozen=True, slots=True, kw_only=True)
class WheelOdometry(Message):
    """Body velocity measured by wheel encoders.

    Attributes:
        device_id: the encoder source.
        linear_mps: [m/s] forward velocity.
        angular_radps: [rad/s] yaw rate, counter-clockwise positive.
    """

    device_id: str
    linear_mps: float
    angular_radps: float


@dataclass(frozen=True, slots=True, kw_only=True)
class DeviceConnected(Message):
    """A peripheral completed its handshake."""

    device_id: str
    kind: DeviceKind


@dataclass(frozen=True, slots=True, kw_only=True)
class DeviceLost(Message):
    """A peripheral disconnected; ``reason`` says why; ``spoke``: it had sent data (False:
    it left without a word since its hello)."""

    device_id: str
    kind: DeviceKind
    reason: str
    spoke: bool = True


@dataclass(frozen=True, slots=True, kw_only=True)
class DeviceStale(Message):
    """A connected peripheral sent nothing for ``silent_s`` [s], longer than its timeout;
    ``spoke``: it had sent data before (False: none since its hello)."""

    device_id: str
    kind: DeviceKind
    silent_s: float
    spoke: bool = True


@dataclass(frozen=True, slots=True, kw_only=True)
class DeviceResumed(Message):
    """A stale peripheral is sending again."""

    device_id: str
    kind: DeviceKind

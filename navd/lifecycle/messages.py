"""Typed messages: the only way modules talk to each other.

Every message is a small frozen value. ``stamp`` is the time of measurement (or of the
decision, for messages a module publishes) and ``received`` the time it reached the daemon,
both in seconds on the daemon's clock (see ``navd.lifecycle.clock``). Conventions follow
ROS: SI units, right-handed frames, x forward, y left, z up, yaw counter-clockwise from +x.

Arrays inside messages are copied and made read-only, so a message cannot change after it
was published. Construction checks only what is cheap and always wrong (a negative range
limit, a NaN stamp); wire-level validation lives in the drivers.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum, StrEnum
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from navd.config import NavdConfig
from navd.lifecycle.errors import MessageError

__all__ = [
    "CancelGoal",
    "CompassHeading",
    "ConfigApplied",
    "ConfigChange",
    "ConfigRejected",
    "DaemonStatus",
    "DeviceConnected",
    "DeviceKind",
    "DeviceLost",
    "DeviceResumed",
    "DeviceStale",
    "DriveCommand",
    "GeoGoal",
    "Goal",
    "GoalStatus",
    "GpsFix",
    "Imu",
    "InitialPose",
    "LaserScan",
    "LocalizationState",
    "MapUpdate",
    "Message",
    "ModuleHealth",
    "Orientation",
    "Path",
    "PoseEstimate",
    "PoseMeasurement",
    "SafeStop",
    "SafeStopCleared",
    "SafetyState",
    "SaveMapRequest",
    "StuckDetected",
    "Vector3",
    "VelocityCommand",
    "WheelOdometry",
    "WorkerStats",
    "describe",
]

FloatArray = npt.NDArray[np.float64]


def _require_finite(name: str, value: float) -> None:
    if not math.isfinite(value):
        raise MessageError(f"{name} must be a finite number, got {value!r}")


def _read_only(
    name: str, values: npt.ArrayLike, dtype: type[np.generic], ndim: int
) -> npt.NDArray[Any]:
    array = np.array(values, dtype=dtype, copy=True)
    if array.ndim != ndim:
        raise MessageError(f"{name} must be a {ndim}-D array, got shape {array.shape}")
    array.flags.writeable = False
    return array


class Vector3(NamedTuple):
    """A 3-vector in the sensor frame; the unit is given by the field holding it."""

    x: float
    y: float
    z: float


class DeviceKind(StrEnum):
    """What a connected peripheral is."""

    LIDAR = "lidar"
    IMU = "imu"
    GPS = "gps"
    COMPASS = "compass"
    WHEEL_ODOMETRY = "wheel_odometry"
    CONTROL = "control"
    CHASSIS = "chassis"
    CLOCK = "clock"


@dataclass(frozen=True, slots=True, kw_only=True)
class Message:
    """Base of every message.

    Attributes:
        stamp: [s] time of measurement on the daemon clock.
        received: [s] time the message reached the daemon, on the same clock.
    """

    stamp: float
    received: float

    def __post_init__(self) -> None:
        # one test on the hot path (a thousand IMU samples a second); the named check after
        if not (math.isfinite(self.stamp) and math.isfinite(self.received)):
            _require_finite("stamp", self.stamp)
            _require_finite("received", self.received)


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
    """

    device_id: str
    angle_min: float
    angle_increment: float
    ranges: npt.NDArray[np.float32]
    range_min: float
    range_max: float
    time_increment: float = 0.0

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        for name in ("angle_min", "angle_increment", "range_min", "range_max"):
            _require_finite(name, getattr(self, name))
        if self.angle_increment == 0.0:
            raise MessageError("angle_increment must be non-zero")
        if self.range_min < 0.0 or self.range_max <= self.range_min:
            raise MessageError(
                f"need 0 <= range_min < range_max, got range_min={self.range_min} "
                f"range_max={self.range_max}"
            )
        if self.time_increment < 0.0:
            raise MessageError(f"time_increment must be >= 0, got {self.time_increment}")
        object.__setattr__(self, "ranges", _read_only("ranges", self.ranges, np.float32, 1))

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
    """A peripheral disconnected; ``reason`` says why."""

    device_id: str
    kind: DeviceKind
    reason: str


@dataclass(frozen=True, slots=True, kw_only=True)
class DeviceStale(Message):
    """A connected peripheral sent nothing for ``silent_s`` [s], longer than its timeout."""

    device_id: str
    kind: DeviceKind
    silent_s: float


@dataclass(frozen=True, slots=True, kw_only=True)
class DeviceResumed(Message):
    """A stale peripheral is sending again."""

    device_id: str
    kind: DeviceKind


# --- control ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class Goal(Message):
    """Drive to a pose in the map frame.

    Attributes:
        goal_id: the client's name for this goal.
        x_m: [m] map x.
        y_m: [m] map y.
        yaw_rad: [rad] final yaw, or None when any heading will do.
    """

    goal_id: str
    x_m: float
    y_m: float
    yaw_rad: float | None = None

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        _require_finite("x_m", self.x_m)
        _require_finite("y_m", self.y_m)
        if self.yaw_rad is not None:
            _require_finite("yaw_rad", self.yaw_rad)


@dataclass(frozen=True, slots=True, kw_only=True)
class GeoGoal(Message):
    """Drive to a WGS84 position; estimation converts it to a map-frame Goal."""

    goal_id: str
    latitude_deg: float
    longitude_deg: float
    yaw_rad: float | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class InitialPose(Message):
    """Where the robot is, told by a person: re-seeds localization.

    Attributes:
        x_m, y_m: [m] map position.
        yaw_rad: [rad] heading, counter-clockwise from +x.
        std_xy_m: [m] 1-sigma position uncertainty.
        std_yaw_rad: [rad] 1-sigma heading uncertainty.
    """

    x_m: float
    y_m: float
    yaw_rad: float
    std_xy_m: float = 0.5
    std_yaw_rad: float = 0.3


@dataclass(frozen=True, slots=True, kw_only=True)
class SaveMapRequest(Message):
    """Save the map now under ``name`` (the configured name when empty)."""

    name: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class GoalStatus(Message):
    """Progress towards a goal, published by the planner.

    Attributes:
        goal_id: the goal.
        state: "active", "reached", "canceled" or "failed".
        distance_remaining_m: [m] along the path, NaN when unknown.
        eta_s: [s] estimated time to arrival, NaN when unknown.
        reason: why it failed or was canceled; empty otherwise.
    """

    goal_id: str
    state: str
    distance_remaining_m: float = math.nan
    eta_s: float = math.nan
    reason: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class CancelGoal(Message):
    """Stop pursuing a goal: the one named, or whichever is active when None."""

    goal_id: str | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class ConfigChange(Message):
    """A request to change the running config.

    Attributes:
        request_id: echoed in the ConfigApplied / ConfigRejected answer.
        changes: dotted key path (``"safety.reaction_timeout_s"``) to new value. Applied whole
            or rejected whole.
        source: who asked (a client id, ``"sighup"``...).
    """

    request_id: str
    changes: Mapping[str, object]
    source: str = ""

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        object.__setattr__(self, "changes", MappingProxyType(dict(self.changes)))


@dataclass(frozen=True, slots=True, kw_only=True)
class ConfigApplied(Message):
    """A ConfigChange took effect.

    Attributes:
        request_id: the request's id.
        changed_keys: the dotted keys whose value changed.
        config: the whole config now in force.
    """

    request_id: str
    changed_keys: tuple[str, ...]
    config: NavdConfig


@dataclass(frozen=True, slots=True, kw_only=True)
class ConfigRejected(Message):
    """A ConfigChange was refused whole; ``reason`` names every bad key."""

    request_id: str
    reason: str


@dataclass(frozen=True, slots=True, kw_only=True)
class VelocityCommand(Message):
    """A body velocity for the chassis.

    Attributes:
        linear_mps: [m/s] forward velocity.
        angular_radps: [rad/s] yaw rate, counter-clockwise positive.
        source: the module that decided it (``"planner"``, ``"safety"``...).
    """

    linear_mps: float
    angular_radps: float
    source: str

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        _require_finite("linear_mps", self.linear_mps)
        _require_finite("angular_radps", self.angular_radps)

    @property
    def is_stop(self) -> bool:
        """True for the zero command."""
        return self.linear_mps == 0.0 and self.angular_radps == 0.0


@dataclass(frozen=True, slots=True, kw_only=True)
class DriveCommand(Message):
    """The body velocity the chassis must execute: the safety gate's output, nothing else's.

    Attributes:
        linear_mps: [m/s] forward velocity.
        angular_radps: [rad/s] yaw rate, counter-clockwise positive.
        reason: why the gate changed the requested command ("" when passed through).
    """

    linear_mps: float
    angular_radps: float
    reason: str = ""

    @property
    def is_stop(self) -> bool:
        """True for the zero command."""
        return self.linear_mps == 0.0 and self.angular_radps == 0.0


@dataclass(frozen=True, slots=True, kw_only=True)
class SafetyState(Message):
    """Why the safety gate holds the robot still; empty ``reasons`` means it may move."""

    reasons: tuple[str, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class SafeStop(Message):
    """The robot must stand still until a SafeStopCleared with the same ``key``.

    Attributes:
        reason: why, for people.
        source: who decided ("supervisor", "collision_guard"...).
        key: names this hold ("fault:planner"); a SafeStopCleared with it releases it.
    """

    reason: str
    source: str
    key: str


@dataclass(frozen=True, slots=True, kw_only=True)
class SafeStopCleared(Message):
    """The hold named ``key`` no longer applies."""

    key: str
    source: str


# --- results ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class PoseEstimate(Message):
    """The fused pose of base_link in the map frame.

    Attributes:
        x_m, y_m: [m] position.
        yaw_rad: [rad] heading, counter-clockwise from +x, in (-pi, pi].
        covariance: 3x3 covariance of (x [m], y [m], yaw [rad]) (read-only).
        linear_mps: [m/s] forward velocity.
        angular_radps: [rad/s] yaw rate.
    """

    x_m: float
    y_m: float
    yaw_rad: float
    covariance: FloatArray
    linear_mps: float = 0.0
    angular_radps: float = 0.0

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        cov = _read_only("covariance", self.covariance, np.float64, 2)
        if cov.shape != (3, 3):
            raise MessageError(f"covariance must be 3x3, got shape {cov.shape}")
        object.__setattr__(self, "covariance", cov)


@dataclass(frozen=True, slots=True, kw_only=True)
class PoseMeasurement(Message):
    """A measured pose of base_link in the map frame (scan matching), for the estimator.

    Attributes:
        source: what measured it ("lidar").
        x_m, y_m: [m] position.
        yaw_rad: [rad] heading, counter-clockwise from +x.
        covariance: 3x3 covariance of (x [m], y [m], yaw [rad]) (read-only).
    """

    source: str
    x_m: float
    y_m: float
    yaw_rad: float
    covariance: FloatArray

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        for name in ("x_m", "y_m", "yaw_rad"):
            _require_finite(name, getattr(self, name))
        cov = _read_only("covariance", self.covariance, np.float64, 2)
        if cov.shape != (3, 3):
            raise MessageError(f"covariance must be 3x3, got shape {cov.shape}")
        if not (np.all(np.isfinite(cov)) and np.all(np.diag(cov) > 0.0)):
            raise MessageError("covariance must be finite with positive variances")
        object.__setattr__(self, "covariance", cov)


@dataclass(frozen=True, slots=True, kw_only=True)
class LocalizationState(Message):
    """How well the robot knows where it is: on every change, and once a second.

    Attributes:
        state: "uninitialized" (no position source yet), "ok", "degraded" or "lost".
        position_std_m: [m] standard deviation of the position along its worst axis.
        yaw_std_rad: [rad] standard deviation of the yaw.
        counters: the estimator's counts (late, rejected, ignored events, resets...).
    """

    state: str
    position_std_m: float
    yaw_std_rad: float
    counters: Mapping[str, object] = field(default_factory=dict)


@dataclass(frozen=True, slots=True, kw_only=True)
class Orientation(Message):
    """The IMU's orientation from Madgwick's filter, for scan deskewing and levelling.

    Attributes:
        device_id: the IMU.
        quaternion_wxyz: rotation of the IMU frame into the earth frame (z up; x magnetic
            north with a magnetometer, else the heading at start-up).
        gyro_bias_radps: [rad/s] the gyro bias learned so far.
    """

    device_id: str
    quaternion_wxyz: tuple[float, float, float, float]
    gyro_bias_radps: Vector3


@dataclass(frozen=True, slots=True, kw_only=True)
class MapUpdate(Message):
    """A snapshot of the occupancy grid.

    Attributes:
        revision: increases with every update.
        resolution_m: [m] cell size.
        origin_x_m, origin_y_m: [m] map-frame position of cell (0, 0)'s corner.
        occupancy: int8 grid, row = y index; -1 unknown, 0..100 occupied probability (%).
    """

    revision: int
    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    occupancy: npt.NDArray[np.int8]

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        if not self.resolution_m > 0.0:
            raise MessageError(f"resolution_m must be > 0, got {self.resolution_m}")
        object.__setattr__(self, "occupancy", _read_only("occupancy", self.occupancy, np.int8, 2))


@dataclass(frozen=True, slots=True, kw_only=True)
class Path(Message):
    """A planned route in the map frame: ``points_m`` is an (N, 2) read-only array of [m]."""

    goal_id: str
    points_m: FloatArray

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        points = _read_only("points_m", self.points_m, np.float64, 2)
        if points.shape[1] != 2:
            raise MessageError(f"points_m must have shape (N, 2), got {points.shape}")
        object.__setattr__(self, "points_m", points)


@dataclass(frozen=True, slots=True, kw_only=True)
class StuckDetected(Message):
    """The robot made no progress for planning.max_stuck_time_s (seed 001 §4.5).

    Attributes:
        goal_id: the goal being pursued.
        x_m, y_m: [m] where the robot is stuck (map frame).
        replans: how many times it has been stuck on this goal.
        giving_up: True when the goal fails because of it.
    """

    goal_id: str
    x_m: float
    y_m: float
    replans: int
    giving_up: bool


class ModuleHealth(NamedTuple):
    """How one module is doing, as reported in DaemonStatus."""

    name: str
    state: str
    handler_failures: int
    slow_handlers: int
    faulted: bool


class WorkerStats(NamedTuple):
    """Counters of one latest-wins worker slot."""

    slot: str
    submitted: int
    completed: int
    dropped: int
    failed: int


@dataclass(frozen=True, slots=True, kw_only=True)
class DaemonStatus(Message):
    """The daemon's own health, published at ``lifecycle.status_rate_hz``.

    Attributes:
        uptime_s: [s] since start.
        loop_lag_p50_ms, loop_lag_p99_ms, loop_lag_max_ms: [ms] event-loop lag over the
            recent window (how late a timer fires).
        modules: health of every module, in start order.
        workers: counters of every worker slot.
        safe_stop_reasons: why the robot is held still; empty when it may move.
        messages_dispatched: messages delivered since start.
    """

    uptime_s: float
    loop_lag_p50_ms: float
    loop_lag_p99_ms: float
    loop_lag_max_ms: float
    modules: tuple[ModuleHealth, ...]
    workers: tuple[WorkerStats, ...]
    safe_stop_reasons: tuple[str, ...]
    messages_dispatched: int
    extra: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        object.__setattr__(self, "extra", MappingProxyType(dict(self.extra)))


def describe(message: Message) -> dict[str, object]:
    """A short, loggable summary of a message: scalars as they are, arrays by shape."""
    summary: dict[str, object] = {"type": type(message).__name__}
    for cls in type(message).__mro__:
        for name in getattr(cls, "__slots__", ()):
            if name in summary:
                continue
            value = getattr(message, name, None)
            if isinstance(value, np.ndarray):
                summary[name] = f"array{value.shape}"
            elif isinstance(value, str | int | float | bool | type(None) | Enum):
                summary[name] = value
            else:
                text = repr(value)
                summary[name] = text if len(text) <= 120 else text[:117] + "..."
    return summary

"""What clients send: newline-delimited JSON frames, validated by pydantic.

Every frame has a ``type`` (its tag) and refuses unknown fields, so a typo never silently
loses data. Field names and units follow ROS: sensor_msgs/LaserScan, Imu (rad/s, m/s²,
magnetic field in tesla) and NavSatFix (degrees, metres). A frame is built in Python with
its fields (``ScanFrame(stamp=..., ...)``: the tag is filled in) and read from a line by
``codec``, where the tag is required.
"""

from __future__ import annotations

import base64
import binascii
import math
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationInfo,
    model_validator,
)

from navd.drivers.errors import WireError

__all__ = [
    "DEVICE_ID_PATTERN",
    "PROTOCOL_VERSION",
    "ROS_SENSOR_FRAMES",
    "SENSOR_FRAMES",
    "BeaconFrame",
    "CancelFrame",
    "ClockFrame",
    "ClockRequest",
    "ConfigFrame",
    "ConfigGetFrame",
    "ControlRequest",
    "FindPoseFrame",
    "FixFrame",
    "Frame",
    "GoalFrame",
    "HeadingFrame",
    "Hello",
    "ImuFrame",
    "InitialPoseFrame",
    "LoadMapFrame",
    "MissionControlFrame",
    "MissionFrame",
    "MissionStepSpec",
    "OdomFrame",
    "PingFrame",
    "RecordFrame",
    "Role",
    "RosFixFrame",
    "RosImuFrame",
    "RosScanFrame",
    "SaveMapFrame",
    "ScanFrame",
    "SensorFrame",
    "SubscribeFrame",
    "TeleopFrame",
    "UnsubscribeFrame",
]

PROTOCOL_VERSION = 1
MAX_RAYS = 16_384
DEVICE_ID_PATTERN = r"^[A-Za-z0-9_.:\-]{1,64}$"
# Bounds of every map coordinate and heading a client sends: far beyond any robot's reach
# (a goal is then judged by planning.max_goal_distance_m), near enough that no arithmetic
# on them overflows.
MAX_COORDINATE_M = 1e6
MAX_YAW_RAD = 4 * math.pi
MAX_STD_XY_M = 1e3
MAX_STD_YAW_RAD = 10.0
# Bounds of an operator's command: beyond any small robot; teleop's and the robot's limits
# cap what is driven.
MAX_TELEOP_MPS = 10.0
MAX_TELEOP_RADPS = 20.0
Coordinate = Annotated[float, Field(ge=-MAX_COORDINATE_M, le=MAX_COORDINATE_M)]
Yaw = Annotated[float, Field(ge=-MAX_YAW_RAD, le=MAX_YAW_RAD)]
Role = Literal["lidar", "imu", "gps", "compass", "wheel_odometry", "beacon", "control", "clock"]


class Frame(BaseModel):
    """Common settings of every client frame: strict types, no unknown fields, frozen, no
    NaN or infinity (lidar ranges excepted)."""

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True, allow_inf_nan=False)
    # Optional fields left unset are not sent (the daemon fills in the same defaults).
    OMIT_NONE: ClassVar[bool] = True

    type: str  # each frame's tag, a Literal in every subclass


class Hello(Frame):
    """The first line of every connection."""

    type: Literal["hello"] = "hello"
    protocol: int = PROTOCOL_VERSION
    role: Role
    device_id: str = Field(pattern=DEVICE_ID_PATTERN)
    token: str | None = Field(None, max_length=1024)

    @model_validator(mode="before")
    @classmethod
    def _tag_on_the_wire(cls, data: Any, info: ValidationInfo) -> Any:
        # Built in Python the tag and version are filled in; a line must say them.
        if info.context and info.context.get("wire") and isinstance(data, dict):
            if "type" not in data:
                raise ValueError("type: missing; every frame has a 'type'")
            if "protocol" not in data:
                raise ValueError("protocol: Field required")
        return data

    @model_validator(mode="after")
    def _supported(self) -> Hello:
        if self.protocol != PROTOCOL_VERSION:
            raise ValueError(
                f"protocol: version {self.protocol} is not supported; this daemon speaks "
                f"{PROTOCOL_VERSION}"
            )
        return self


Stamp = Annotated[float | None, Field(None, ge=0)]


def _xyz(value: Any) -> Any:
    """A ROS vector ``{"x", "y", "z"}`` as the [x, y, z] navd takes; a JSON array as the
    tuple the strict model wants (anything else as is, for the model to refuse)."""
    if isinstance(value, dict) and set(value) == {"x", "y", "z"}:
        return (value["x"], value["y"], value["z"])
    if isinstance(value, list):
        return tuple(value)
    return value


Vec3 = tuple[float, float, float]
RosVec3 = Annotated[tuple[float, float, float], BeforeValidator(_xyz)]
Covariance = Annotated[list[float], Field(min_length=9, max_length=9)]
Covariance6 = Annotated[list[float], Field(min_length=36, max_length=36)]
FrameId = Annotated[str | None, Field(None, min_length=1, max_length=128)]


def _ros_header(data: Any) -> Any:
    """A ROS message's ``header`` as navd's ``stamp`` and ``frame_id``: ``{"stamp": {"sec",
    "nanosec"}}`` (``secs`` and ``nsecs`` in ROS 1) becomes seconds, unless the frame gives
    ``stamp`` itself; the ``frame_id`` is checked against the device's mount."""
    if not isinstance(data, dict) or "header" not in data:
        return data
    data = dict(data)
    header = data.pop("header")
    if not isinstance(header, dict):
        raise ValueError("header: a ROS header is an object with stamp and frame_id")
    frame_id = header.get("frame_id")
    if frame_id not in (None, "") and "frame_id" not in data:
        data["frame_id"] = frame_id
    when = header.get("stamp")
    if "stamp" not in data and isinstance(when, dict):
        nanos = when.get("nanosec", when.get("nsecs", 0))
        sec = when.get("sec", when.get("secs"))
        if not isinstance(sec, int) or not isinstance(nanos, int):
            raise ValueError("header.stamp: sec and nanosec must be integers")
        data["stamp"] = sec + nanos * 1e-9
    return data


class ScanFrame(Frame):
    """A lidar sweep (sensor_msgs/LaserScan); ``ranges`` or ``ranges_f32``, not both."""

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

    @model_validator(mode="after")
    def _consistent(self) -> ScanFrame:
        if (self.ranges is None) == (self.ranges_f32 is None):
            raise ValueError(
                "ranges: give exactly one of ranges (JSON numbers) and ranges_f32 (base64)"
            )
        if self.angle_increment == 0.0:
            raise ValueError("angle_increment: must be non-zero")
        if self.range_max <= self.range_min:
            raise ValueError(
                f"range_max: must exceed range_min ({self.range_min}), got {self.range_max}"
            )
        return self

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


def _navsat_status(value: Any) -> Any:
    """NavSatFix's ``status`` object ``{"status", "service"}`` as its status number."""
    if isinstance(value, dict) and "status" in value:
        return value["status"]
    return value


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


# --- the same frames from ROS messages dumped as JSON, field for field ------------------
# Read only for lines that carry a ROS ``header`` or ``{x, y, z}`` vectors (``codec``): their
# validators run Python for every line, which the plain frames, at 1 kHz, do without.


class RosScanFrame(ScanFrame):
    """A sensor_msgs/LaserScan: its header gives the stamp; ``angle_max`` is checked against
    the rest, ``scan_time`` and ``intensities`` are taken and not used."""

    frame_id: FrameId = None
    angle_max: float | None = Field(None, allow_inf_nan=False)
    scan_time: float | None = Field(None, ge=0, allow_inf_nan=False)
    intensities: list[float | None] | None = Field(None, max_length=MAX_RAYS)

    @model_validator(mode="before")
    @classmethod
    def _from_ros(cls, data: Any) -> Any:
        return _ros_header(data)

    @model_validator(mode="after")
    def _ros_consistent(self) -> RosScanFrame:
        if (
            self.intensities
            and self.ranges is not None
            and len(self.intensities) != len(self.ranges)
        ):
            raise ValueError(
                f"intensities: {len(self.intensities)} values for {len(self.ranges)} ranges "
                f"(give one per ray, or none)"
            )
        if self.angle_max is not None and self.ranges is not None and self.ranges:
            last = self.angle_min + self.angle_increment * (len(self.ranges) - 1)
            if abs(last - self.angle_max) > abs(self.angle_increment):
                raise ValueError(
                    f"angle_max: {self.angle_max} does not match angle_min + angle_increment "
                    f"x (rays - 1) = {last:.6f}"
                )
        return self


class RosImuFrame(ImuFrame):
    """A sensor_msgs/Imu: its header gives the stamp; ``{x, y, z}`` vectors; ``orientation``
    and the covariances are taken and not used (navd fuses its own orientation)."""

    frame_id: FrameId = None
    angular_velocity: RosVec3
    linear_acceleration: RosVec3
    magnetic_field: RosVec3 | None = None
    orientation: dict[str, float] | None = None
    orientation_covariance: Covariance | None = None
    angular_velocity_covariance: Covariance | None = None
    linear_acceleration_covariance: Covariance | None = None

    @model_validator(mode="before")
    @classmethod
    def _from_ros(cls, data: Any) -> Any:
        return _ros_header(data)


class RosFixFrame(FixFrame):
    """A sensor_msgs/NavSatFix: its header gives the stamp, its status object the status,
    and a known covariance the accuracy when none is given."""

    frame_id: FrameId = None
    status: Annotated[int, BeforeValidator(_navsat_status)] = Field(0, ge=-1, le=2)
    position_covariance: Covariance | None = None
    position_covariance_type: int = Field(0, ge=0, le=3)

    @model_validator(mode="before")
    @classmethod
    def _from_ros(cls, data: Any) -> Any:
        return _accuracy_from_covariance(_ros_header(data))


def _accuracy_from_covariance(data: Any) -> Any:
    if not isinstance(data, dict) or "horizontal_accuracy" in data:
        return data
    covariance = data.get("position_covariance")
    known = isinstance(data.get("position_covariance_type"), int) and (
        data["position_covariance_type"] > 0
    )
    if known and isinstance(covariance, list) and len(covariance) == 9:
        east, north = covariance[0], covariance[4]
        numbers = isinstance(east, int | float) and isinstance(north, int | float)
        if numbers and max(east, north) > 0:
            return {**data, "horizontal_accuracy": math.sqrt(max(east, north))}
    return data


class OdomFrame(Frame):
    """Wheel odometry: body velocity (geometry_msgs/Twist linear.x and angular.z)."""

    type: Literal["odom"] = "odom"
    stamp: Stamp
    linear_x: float
    angular_z: float


class RosOdomFrame(OdomFrame):
    """A nav_msgs/Odometry: its header gives the stamp, its twist (in ``child_frame_id``,
    the robot's body) the velocity: ``twist.twist.linear.x`` and ``twist.twist.angular.z``.
    Its pose (the odometry's own dead reckoning) and covariances are read and not used."""

    frame_id: FrameId = None
    child_frame_id: str | None = Field(None, max_length=128)

    @model_validator(mode="before")
    @classmethod
    def _from_ros(cls, data: Any) -> Any:
        data = _ros_header(data)
        if not isinstance(data, dict) or "twist" not in data:
            return data
        data = dict(data)
        twist = data.pop("twist")
        data.pop("pose", None)
        inner = twist.get("twist") if isinstance(twist, dict) else None
        linear = inner.get("linear") if isinstance(inner, dict) else None
        angular = inner.get("angular") if isinstance(inner, dict) else None
        if not isinstance(linear, dict) or not isinstance(angular, dict):
            raise ValueError(
                "twist: an Odometry's twist is {twist: {linear: {x, y, z}, angular: {x, y, z}}, "
                "covariance}"
            )
        data.setdefault("linear_x", linear.get("x"))
        data.setdefault("angular_z", angular.get("z"))
        return data


class GoalFrame(Frame):
    """Drive to map (x, y) or to WGS84 (latitude, longitude), with an optional final yaw."""

    type: Literal["goal"] = "goal"
    goal_id: str | None = Field(None, pattern=DEVICE_ID_PATTERN)
    x: Coordinate | None = None
    y: Coordinate | None = None
    latitude: float | None = Field(None, ge=-90, le=90)
    longitude: float | None = Field(None, ge=-180, le=180)
    yaw: Yaw | None = None

    @model_validator(mode="after")
    def _one_position(self) -> GoalFrame:
        local = (self.x is not None, self.y is not None)
        geo = (self.latitude is not None, self.longitude is not None)
        if local == (True, True) and geo == (False, False):
            return self
        if geo == (True, True) and local == (False, False):
            return self
        raise ValueError("x: give either x and y (map frame, m) or latitude and longitude (deg)")


class CancelFrame(Frame):
    """Stop pursuing a goal: the active one, or only ``goal_id``."""

    type: Literal["cancel"] = "cancel"
    goal_id: str | None = None


class ConfigFrame(Frame):
    """Change config keys at runtime: applied whole or rejected whole."""

    type: Literal["config"] = "config"
    request_id: str | None = Field(None, max_length=64)
    changes: dict[str, Any] = Field(min_length=1)


class ConfigGetFrame(Frame):
    """Read a key of the running config (a dotted key, or a whole section); secrets come back
    redacted."""

    type: Literal["config_get"] = "config_get"
    key: str = Field(pattern=r"^[a-z][a-z0-9_]*(\.[a-z][a-z0-9_]*)?$", max_length=128)


class InitialPoseFrame(Frame):
    """Where the robot is, by a person: [m, m, rad] in the map, with 1-sigma errors."""

    type: Literal["initial_pose"] = "initial_pose"
    x: Coordinate
    y: Coordinate
    yaw: Yaw
    std_xy: float = Field(0.5, gt=0, le=MAX_STD_XY_M)
    std_yaw: float = Field(0.3, gt=0, le=MAX_STD_YAW_RAD)


class SaveMapFrame(Frame):
    """Save the map (under ``name``, or ``slam.map_name``; in ``folder``, or
    ``slam.map_dir``)."""

    type: Literal["save_map"] = "save_map"
    name: str = Field("", pattern=r"^([A-Za-z0-9_][A-Za-z0-9_.\-]{0,63})?$")
    folder: str | None = Field(
        None,
        min_length=1,
        max_length=4096,
        pattern=r"^/",
        description="an absolute folder instead of slam.map_dir (privileged, as slam.map_dir "
        "is: taken only with tcp.allow_privileged_changes)",
    )


class TeleopFrame(Frame):
    """Drive by hand (geometry_msgs/Twist's linear.x and angular.z): sent again at least
    every ``safety.reaction_timeout_s`` while the operator drives (10 Hz is usual); the
    robot stops when they stop coming. Not acknowledged (errors are answered)."""

    type: Literal["teleop"] = "teleop"
    linear_x: float = Field(ge=-MAX_TELEOP_MPS, le=MAX_TELEOP_MPS)
    angular_z: float = Field(ge=-MAX_TELEOP_RADPS, le=MAX_TELEOP_RADPS)


class RecordFrame(Frame):
    """Start or stop recording the session to MCAP files in ``record.dir``."""

    type: Literal["record"] = "record"
    action: Literal["start", "stop"]


class FindPoseFrame(Frame):
    """Search the whole map for the robot at the next scan; answered with ``pose_found``."""

    type: Literal["find_pose"] = "find_pose"


class LoadMapFrame(Frame):
    """Replace the map with ``name``.yaml from ``folder`` (or ``slam.map_dir``); the robot is
    then searched for on it."""

    type: Literal["load_map"] = "load_map"
    name: str = Field(pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.\-]{0,63}$")
    folder: str | None = Field(
        None,
        min_length=1,
        max_length=4096,
        pattern=r"^/",
        description="an absolute folder instead of slam.map_dir (privileged, as slam.map_dir "
        "is: taken only with tcp.allow_privileged_changes)",
    )


class SubscribeFrame(Frame):
    """Receive status frames at ``rate_hz``."""

    type: Literal["subscribe"] = "subscribe"
    rate_hz: float = Field(1.0, gt=0, le=50)


class UnsubscribeFrame(Frame):
    """Stop the status frames."""

    type: Literal["unsubscribe"] = "unsubscribe"


class ClockFrame(Frame):
    """From the clock client: take in ``frames`` lines per device, then move time to ``time``."""

    type: Literal["clock"] = "clock"
    time: float = Field(ge=0)
    frames: dict[Annotated[str, Field(pattern=DEVICE_ID_PATTERN)], Annotated[int, Field(ge=0)]] = (
        Field(default_factory=dict, max_length=64)
    )


class PingFrame(Frame):
    """Any client: answered with a pong carrying ``id`` (after every line sent before it)."""

    type: Literal["ping"] = "ping"
    id: int | str | None = None


SensorFrame = ScanFrame | ImuFrame | FixFrame | HeadingFrame | OdomFrame | BeaconFrame
# --- missions -----------------------------------------------------------------------

MAX_MISSION_STEPS = 1000
MissionPolicy = Literal["skip", "retry", "abort"]


class MissionStepSpec(BaseModel):
    """One step: ``kind`` and its fields (see docs/missions.md)."""

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True, allow_inf_nan=False)

    kind: Literal[
        "goto", "goto_gps", "wait", "pause", "approach", "beacon", "gate", "visit_beacons"
    ]
    x: Coordinate | None = None
    y: Coordinate | None = None
    yaw: float | None = Field(None, ge=-10.0, le=10.0)
    latitude: float | None = Field(None, ge=-90, le=90)
    longitude: float | None = Field(None, ge=-180, le=180)
    seconds: float | None = Field(None, ge=0, le=86400)
    message: str = Field("", max_length=500)
    stop_distance: float = Field(0.3, ge=0, le=10)
    speed: float | None = Field(None, gt=0, le=10)
    on_failure: MissionPolicy | None = None
    retries: int | None = Field(None, ge=0, le=100)
    beacon: str | None = Field(None, pattern=DEVICE_ID_PATTERN)
    beacons: list[Annotated[str, Field(pattern=DEVICE_ID_PATTERN)]] | None = Field(
        None, max_length=MAX_MISSION_STEPS
    )

    @model_validator(mode="after")
    def _fields_of_the_kind(self) -> MissionStepSpec:
        needs = {
            "goto": ("x", "y"),
            "approach": ("x", "y"),
            "goto_gps": ("latitude", "longitude"),
            "wait": ("seconds",),
            "pause": (),
            "beacon": ("beacon",),
            "gate": ("beacons",),
            "visit_beacons": (),
        }[self.kind]
        missing = [name for name in needs if getattr(self, name) is None]
        if missing:
            raise ValueError(f"a {self.kind} step needs {' and '.join(missing)}")
        if self.kind == "gate" and (self.beacons is None or len(set(self.beacons)) != 2):
            raise ValueError(f"a gate step needs two different beacons, got {self.beacons}")
        return self


class MissionFrame(Frame):
    """Run a mission: ``steps`` in order, ``rounds`` times (``"forever"`` or 0 for a patrol
    that runs until cancelled); a failed step does ``on_failure`` (skip, retry ``retries``
    times, or abort) unless the step says otherwise."""

    type: Literal["mission"] = "mission"
    mission_id: str | None = Field(None, pattern=DEVICE_ID_PATTERN)
    name: str = Field("mission", min_length=1, max_length=100)
    rounds: Annotated[int, Field(ge=0, le=100000)] = 1
    on_failure: MissionPolicy = "abort"
    retries: int = Field(2, ge=0, le=100)
    steps: list[MissionStepSpec] = Field(min_length=1, max_length=MAX_MISSION_STEPS)

    @model_validator(mode="before")
    @classmethod
    def _rounds_forever(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("rounds") == "forever":
            return {**data, "rounds": 0}
        return data


class MissionControlFrame(Frame):
    """Pause, resume or cancel the running mission, or say "continue" to a pause step."""

    type: Literal["mission_control"] = "mission_control"
    action: Literal["pause", "resume", "cancel", "continue"]


ControlRequest = (
    GoalFrame
    | CancelFrame
    | ConfigFrame
    | ConfigGetFrame
    | InitialPoseFrame
    | SaveMapFrame
    | LoadMapFrame
    | FindPoseFrame
    | TeleopFrame
    | RecordFrame
    | MissionFrame
    | MissionControlFrame
    | SubscribeFrame
    | UnsubscribeFrame
    | PingFrame
)
ClockRequest = ClockFrame | PingFrame

# The ROS-shaped frame of each sensor role that has one.
ROS_SENSOR_FRAMES: dict[str, type[SensorFrame]] = {
    "lidar": RosScanFrame,
    "imu": RosImuFrame,
    "gps": RosFixFrame,
    "wheel_odometry": RosOdomFrame,
}

# The data frame of each sensor role.
SENSOR_FRAMES: dict[str, type[SensorFrame]] = {
    "lidar": ScanFrame,
    "imu": ImuFrame,
    "gps": FixFrame,
    "compass": HeadingFrame,
    "wheel_odometry": OdomFrame,
    "beacon": BeaconFrame,
}

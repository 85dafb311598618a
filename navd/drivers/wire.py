"""The wire protocol (version 1): newline-delimited JSON frames, validated by pydantic.

See docs/protocol.md for the specification a client author reads. This module decodes one
line into a validated frame (or a ``WireError`` that names the field and the reason) and
turns sensor frames into typed messages. Field names and units follow ROS: sensor_msgs/
LaserScan, Imu (rad/s, m/s², magnetic field in tesla) and NavSatFix (degrees, metres).
No asyncio here.
"""

from __future__ import annotations

import base64
import binascii
import json
import math
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    TypeAdapter,
    ValidationError,
    model_validator,
)

from navd.drivers.errors import WireError
from navd.lifecycle.messages import (
    CancelGoal,
    CompassHeading,
    ConfigChange,
    DeviceKind,
    GeoGoal,
    Goal,
    GpsFix,
    Imu,
    InitialPose,
    LaserScan,
    Message,
    SaveMapRequest,
    Vector3,
    WheelOdometry,
)

__all__ = [
    "PROTOCOL_VERSION",
    "SENSOR_ROLES",
    "CancelFrame",
    "ClockFrame",
    "ConfigFrame",
    "GoalFrame",
    "Hello",
    "InitialPoseFrame",
    "PingFrame",
    "SaveMapFrame",
    "SubscribeFrame",
    "UnsubscribeFrame",
    "control_message",
    "decode_clock",
    "decode_control",
    "decode_hello",
    "decode_sensor",
    "encode",
    "sensor_message",
]

PROTOCOL_VERSION = 1
MAX_RAYS = 16_384
DEVICE_ID_PATTERN = r"^[A-Za-z0-9_.:\-]{1,64}$"
TESLA_TO_MICROTESLA = 1e6


class _Frame(BaseModel):
    model_config = ConfigDict(strict=True, extra="forbid", frozen=True, allow_inf_nan=False)


class Hello(_Frame):
    """The first line of every connection."""

    type: Literal["hello"]
    protocol: int
    role: Literal["lidar", "imu", "gps", "compass", "wheel_odometry", "control", "clock"]
    device_id: str = Field(pattern=DEVICE_ID_PATTERN)
    token: str | None = Field(None, max_length=1024)

    @model_validator(mode="after")
    def _supported(self) -> Hello:
        if self.protocol != PROTOCOL_VERSION:
            raise ValueError(
                f"protocol: version {self.protocol} is not supported; this daemon speaks "
                f"{PROTOCOL_VERSION}"
            )
        return self

    @property
    def kind(self) -> DeviceKind:
        """The role as a DeviceKind."""
        return DeviceKind(self.role)


Stamp = Annotated[float | None, Field(None, ge=0)]
Vec3 = tuple[float, float, float]


class ScanFrame(_Frame):
    """A lidar sweep (sensor_msgs/LaserScan); ``ranges`` or ``ranges_f32``, not both."""

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True, allow_inf_nan=True)

    type: Literal["scan"]
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
        """[m] the ranges as float32; null becomes NaN (an invalid ray)."""
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


class ImuFrame(_Frame):
    """An IMU sample (sensor_msgs/Imu): rad/s, m/s², and tesla for the magnetometer."""

    type: Literal["imu"]
    stamp: Stamp
    angular_velocity: Vec3
    linear_acceleration: Vec3
    magnetic_field: Vec3 | None = None


class FixFrame(_Frame):
    """A GNSS fix (sensor_msgs/NavSatFix); ``status`` -1 means no fix (ignored, not an error)."""

    type: Literal["fix"]
    stamp: Stamp
    latitude: float = Field(ge=-90, le=90)
    longitude: float = Field(ge=-180, le=180)
    altitude: float = 0.0
    horizontal_accuracy: float = Field(gt=0)
    status: int = Field(0, ge=-1, le=2)


class HeadingFrame(_Frame):
    """A compass bearing: degrees clockwise from north, as compasses report it."""

    type: Literal["heading"]
    stamp: Stamp
    bearing_deg: float = Field(ge=0, lt=360)
    accuracy_deg: float = Field(gt=0, le=180)
    true_north: bool = False


class OdomFrame(_Frame):
    """Wheel odometry: body velocity (geometry_msgs/Twist linear.x and angular.z)."""

    type: Literal["odom"]
    stamp: Stamp
    linear_x: float
    angular_z: float


class GoalFrame(_Frame):
    """Drive to map (x, y) or to WGS84 (latitude, longitude), with an optional final yaw."""

    type: Literal["goal"]
    goal_id: str | None = Field(None, pattern=DEVICE_ID_PATTERN)
    x: float | None = None
    y: float | None = None
    latitude: float | None = Field(None, ge=-90, le=90)
    longitude: float | None = Field(None, ge=-180, le=180)
    yaw: float | None = None

    @model_validator(mode="after")
    def _one_position(self) -> GoalFrame:
        local = (self.x is not None, self.y is not None)
        geo = (self.latitude is not None, self.longitude is not None)
        if local == (True, True) and geo == (False, False):
            return self
        if geo == (True, True) and local == (False, False):
            return self
        raise ValueError("x: give either x and y (map frame, m) or latitude and longitude (deg)")


class CancelFrame(_Frame):
    type: Literal["cancel"]
    goal_id: str | None = None


class ConfigFrame(_Frame):
    type: Literal["config"]
    request_id: str | None = Field(None, max_length=64)
    changes: dict[str, Any] = Field(min_length=1)


class InitialPoseFrame(_Frame):
    type: Literal["initial_pose"]
    x: float
    y: float
    yaw: float
    std_xy: float = Field(0.5, gt=0)
    std_yaw: float = Field(0.3, gt=0)


class SaveMapFrame(_Frame):
    type: Literal["save_map"]
    name: str = Field("", pattern=r"^[A-Za-z0-9_.\-]{0,64}$")


class SubscribeFrame(_Frame):
    type: Literal["subscribe"]
    rate_hz: float = Field(1.0, gt=0, le=50)


class UnsubscribeFrame(_Frame):
    type: Literal["unsubscribe"]


class ClockFrame(_Frame):
    """From the clock client: take in ``frames`` lines per device, then move time to ``time``."""

    type: Literal["clock"]
    time: float = Field(ge=0)
    frames: dict[Annotated[str, Field(pattern=DEVICE_ID_PATTERN)], Annotated[int, Field(ge=0)]] = (
        Field(default_factory=dict, max_length=64)
    )


class PingFrame(_Frame):
    type: Literal["ping"]
    id: int | str | None = None


_SENSOR_FRAMES: dict[DeviceKind, type[_Frame]] = {
    DeviceKind.LIDAR: ScanFrame,
    DeviceKind.IMU: ImuFrame,
    DeviceKind.GPS: FixFrame,
    DeviceKind.COMPASS: HeadingFrame,
    DeviceKind.WHEEL_ODOMETRY: OdomFrame,
}
SENSOR_ROLES = frozenset(_SENSOR_FRAMES)

ControlFrame = Annotated[
    GoalFrame
    | CancelFrame
    | ConfigFrame
    | InitialPoseFrame
    | SaveMapFrame
    | SubscribeFrame
    | UnsubscribeFrame
    | PingFrame,
    Field(discriminator="type"),
]
_CONTROL: TypeAdapter[Any] = TypeAdapter(ControlFrame)
_CLOCK: TypeAdapter[Any] = TypeAdapter(
    Annotated[ClockFrame | PingFrame, Field(discriminator="type")]
)
_SENSOR: dict[DeviceKind, TypeAdapter[Any]] = {
    kind: TypeAdapter(
        Annotated[frame | PingFrame, Field(discriminator="type")]  # type: ignore[arg-type]
    )
    for kind, frame in _SENSOR_FRAMES.items()
}
_HELLO: TypeAdapter[Hello] = TypeAdapter(Hello)


def decode_hello(line: bytes) -> Hello:
    """Decode the first line of a connection.

    Raises:
        WireError: naming the bad field.
    """
    hello: Hello = _decode(_HELLO, line, "hello")
    return hello


def decode_sensor(role: DeviceKind, line: bytes) -> Any:
    """Decode a line from a sensor of ``role``: its data frame or a ping.

    Raises:
        WireError: naming the bad field.
    """
    return _decode(_SENSOR[role], line, role.value)


def decode_control(line: bytes) -> Any:
    """Decode a line from a control client.

    Raises:
        WireError: naming the bad field.
    """
    return _decode(_CONTROL, line, "control")


def decode_clock(line: bytes) -> ClockFrame | PingFrame:
    """Decode a line from the clock client.

    Raises:
        WireError: naming the bad field.
    """
    frame: ClockFrame | PingFrame = _decode(_CLOCK, line, "clock")
    return frame


def _decode(adapter: TypeAdapter[Any], line: bytes, role: str) -> Any:
    try:
        return adapter.validate_json(line)
    except ValidationError as err:
        raise _wire_error(err, role) from err


def _wire_error(err: ValidationError, role: str) -> WireError:
    first = err.errors(include_url=False)[0]
    kind = first["type"]
    field = ".".join(str(p) for p in first["loc"])
    if kind == "json_invalid":
        return WireError("", f"not valid JSON: {first['msg'].removeprefix('Invalid JSON: ')}")
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return WireError("", "a frame must be a JSON object")
    if kind == "union_tag_not_found":
        return WireError("type", "missing; every frame has a 'type'")
    if kind == "union_tag_invalid":
        expected = first.get("ctx", {}).get("expected_tags", "")
        got = first.get("input", {})
        tag = got.get("type") if isinstance(got, dict) else None
        return WireError(
            "type", f"{tag!r} is not a frame a {role} client sends; expected {expected}"
        )
    # drop the union branch name pydantic puts first ("scan.ranges.3" -> "ranges.3")
    parts = [str(p) for p in first["loc"]]
    if len(parts) > 1 and parts[0] in _TAGS:
        parts = parts[1:]
    elif len(parts) == 1 and parts[0] in _TAGS:
        parts = []
    field = ".".join(parts)
    message = str(first["msg"]).removeprefix("Value error, ")
    if kind == "extra_forbidden":
        message = "unknown field"
    if kind == "value_error" and not field:
        # cross-field rules name their field as "field: reason"
        named, sep, rest = message.partition(": ")
        if sep and named.isidentifier():
            field, message = named, rest
    return WireError(field, message)


_TAGS = {
    "hello",
    "scan",
    "imu",
    "fix",
    "heading",
    "odom",
    "goal",
    "cancel",
    "config",
    "initial_pose",
    "save_map",
    "subscribe",
    "unsubscribe",
    "clock",
    "ping",
}


def _scan(frame: ScanFrame, device_id: str, stamp: float, received: float) -> Message:
    return LaserScan(
        stamp=stamp,
        received=received,
        device_id=device_id,
        angle_min=frame.angle_min,
        angle_increment=frame.angle_increment,
        ranges=frame.ranges_array(),
        range_min=frame.range_min,
        range_max=frame.range_max,
        time_increment=frame.time_increment,
    )


def _imu(frame: ImuFrame, device_id: str, stamp: float, received: float) -> Message:
    mag = frame.magnetic_field
    return Imu(
        stamp=stamp,
        received=received,
        device_id=device_id,
        gyro_radps=Vector3(*frame.angular_velocity),
        accel_mps2=Vector3(*frame.linear_acceleration),
        mag_ut=None if mag is None else Vector3(*(c * TESLA_TO_MICROTESLA for c in mag)),
    )


def _fix(frame: FixFrame, device_id: str, stamp: float, received: float) -> Message | None:
    if frame.status < 0:
        return None  # the receiver says it has no fix: nothing to use, nothing wrong
    return GpsFix(
        stamp=stamp,
        received=received,
        device_id=device_id,
        latitude_deg=frame.latitude,
        longitude_deg=frame.longitude,
        altitude_m=frame.altitude,
        horizontal_accuracy_m=frame.horizontal_accuracy,
    )


def _heading(frame: HeadingFrame, device_id: str, stamp: float, received: float) -> Message:
    return CompassHeading(
        stamp=stamp,
        received=received,
        device_id=device_id,
        bearing_deg=frame.bearing_deg,
        accuracy_deg=frame.accuracy_deg,
        true_north=frame.true_north,
    )


def _odom(frame: OdomFrame, device_id: str, stamp: float, received: float) -> Message:
    return WheelOdometry(
        stamp=stamp,
        received=received,
        device_id=device_id,
        linear_mps=frame.linear_x,
        angular_radps=frame.angular_z,
    )


_CONVERTERS: dict[type[_Frame], Any] = {
    ScanFrame: _scan,
    ImuFrame: _imu,
    FixFrame: _fix,
    HeadingFrame: _heading,
    OdomFrame: _odom,
}


def sensor_message(frame: Any, device_id: str, stamp: float, received: float) -> Message | None:
    """Turn a validated sensor frame into its typed message; None for frames that carry none.

    Raises:
        WireError: a field that only the conversion can check (bad base64 ranges).
    """
    convert = _CONVERTERS.get(type(frame))
    return None if convert is None else convert(frame, device_id, stamp, received)


def control_message(frame: Any, client_id: str, now: float, serial: int) -> Message | None:
    """Turn a control frame that maps to a bus message into it; None for session-level frames.

    Args:
        frame: a validated control frame.
        client_id: the control client's device id (names its goals and requests).
        now: [s] daemon time.
        serial: a per-client counter for ids the client did not give.
    """
    if isinstance(frame, GoalFrame):
        goal_id = frame.goal_id or f"{client_id}-{serial}"
        if frame.x is not None and frame.y is not None:
            return Goal(
                stamp=now,
                received=now,
                goal_id=goal_id,
                x_m=frame.x,
                y_m=frame.y,
                yaw_rad=frame.yaw,
            )
        assert frame.latitude is not None and frame.longitude is not None
        return GeoGoal(
            stamp=now,
            received=now,
            goal_id=goal_id,
            latitude_deg=frame.latitude,
            longitude_deg=frame.longitude,
            yaw_rad=frame.yaw,
        )
    if isinstance(frame, CancelFrame):
        return CancelGoal(stamp=now, received=now, goal_id=frame.goal_id)
    if isinstance(frame, ConfigFrame):
        return ConfigChange(
            stamp=now,
            received=now,
            request_id=frame.request_id or f"{client_id}-{serial}",
            changes=frame.changes,
            source=client_id,
        )
    if isinstance(frame, InitialPoseFrame):
        return InitialPose(
            stamp=now,
            received=now,
            x_m=frame.x,
            y_m=frame.y,
            yaw_rad=frame.yaw,
            std_xy_m=frame.std_xy,
            std_yaw_rad=frame.std_yaw,
        )
    if isinstance(frame, SaveMapFrame):
        return SaveMapRequest(stamp=now, received=now, name=frame.name)
    return None


def encode(frame: dict[str, Any]) -> bytes:
    """One outgoing frame as a JSON line; NaN and inf become null."""
    return json.dumps(_finite(frame), separators=(",", ":"), allow_nan=False).encode() + b"\n"


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value

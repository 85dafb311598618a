"""The sensor frames as ROS messages dumped to JSON field for field (rosbridge's shape):
a ``header`` for the stamp and frame, ``{x, y, z}`` vectors, NavSatFix's status object and
covariance, Odometry's twist.

``codec`` reads a line with these only when it carries a ROS ``header`` or ``{x, y, z}``
vectors: their validators run Python for every line, which the plain frames, at 1 kHz, do
without.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import BeforeValidator, Field, model_validator

from navd.wire.base import Covariance, FrameId
from navd.wire.sensor_frames import FixFrame, ImuFrame, OdomFrame, ScanFrame, SensorFrame

__all__ = [
    "ROS_SENSOR_FRAMES",
    "RosFixFrame",
    "RosImuFrame",
    "RosOdomFrame",
    "RosScanFrame",
]


def _xyz(value: Any) -> Any:
    """A ROS vector ``{"x", "y", "z"}`` as the [x, y, z] navd takes; a JSON array as the
    tuple the strict model wants (anything else as is, for the model to refuse)."""
    if isinstance(value, dict) and set(value) == {"x", "y", "z"}:
        return (value["x"], value["y"], value["z"])
    if isinstance(value, list):
        return tuple(value)
    return value


RosVec3 = Annotated[tuple[float, float, float], BeforeValidator(_xyz)]


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


def _navsat_status(value: Any) -> Any:
    """NavSatFix's ``status`` object ``{"status", "service"}`` as its status number."""
    if isinstance(value, dict) and "status" in value:
        return value["status"]
    return value


class RosScanFrame(ScanFrame):
    """A sensor_msgs/LaserScan: its header gives the stamp; ``angle_max`` is checked against
    the rest; ``scan_time`` is taken and not used."""

    frame_id: FrameId = None
    angle_max: float | None = Field(None, allow_inf_nan=False)
    scan_time: float | None = Field(None, ge=0, allow_inf_nan=False)

    @model_validator(mode="before")
    @classmethod
    def _from_ros(cls, data: Any) -> Any:
        return _ros_header(data)

    @model_validator(mode="after")
    def _ros_consistent(self) -> RosScanFrame:
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


# The ROS-shaped frame of each sensor role that has one.
ROS_SENSOR_FRAMES: dict[str, type[SensorFrame]] = {
    "lidar": RosScanFrame,
    "imu": RosImuFrame,
    "gps": RosFixFrame,
    "wheel_odometry": RosOdomFrame,
}

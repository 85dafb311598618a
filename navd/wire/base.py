"""What every frame a client sends is made of: the strict, frozen ``Frame``; the ``hello``
that opens a connection and the ``ping`` any client may send; the protocol's bounds and the
value types the frames share.

Every frame has a ``type`` (its tag) and refuses unknown fields, so a typo never silently
loses data. Field names and units follow ROS. A frame is built in Python with its fields
(``ScanFrame(stamp=..., ...)``: the tag is filled in) and read from a line by ``codec``,
where the tag is required.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, model_validator

__all__ = [
    "DEVICE_ID_PATTERN",
    "MAX_COORDINATE_M",
    "MAX_RAYS",
    "MAX_STD_XY_M",
    "MAX_STD_YAW_RAD",
    "MAX_TELEOP_MPS",
    "MAX_TELEOP_RADPS",
    "MAX_YAW_RAD",
    "PROTOCOL_VERSION",
    "SENSOR_NAME_PATTERN",
    "Coordinate",
    "Covariance",
    "Covariance6",
    "Frame",
    "FrameId",
    "Hello",
    "PingFrame",
    "Role",
    "Stamp",
    "Vec3",
    "Yaw",
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
Role = Literal[
    "lidar",
    "imu",
    "gps",
    "compass",
    "wheel_odometry",
    "beacon",
    "range",
    "contact",
    "points",
    "battery",
    "control",
    "clock",
]
SENSOR_NAME_PATTERN = DEVICE_ID_PATTERN  # a sensor's name within its device, as an id


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


Vec3 = tuple[float, float, float]
Covariance = Annotated[list[float], Field(min_length=9, max_length=9)]
Covariance6 = Annotated[list[float], Field(min_length=36, max_length=36)]
FrameId = Annotated[str | None, Field(None, min_length=1, max_length=128)]


class PingFrame(Frame):
    """Any client: answered with a pong carrying ``id`` (after every line sent before it)."""

    type: Literal["ping"] = "ping"
    id: int | str | None = None

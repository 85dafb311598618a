"""What control clients and the clock client send: goals, cancels, config changes and reads,
the initial pose, map saves and loads, pose searches, driving by hand, recording, status
subscriptions, and the simulated clock's steps."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, model_validator

from navd.wire.base import (
    DEVICE_ID_PATTERN,
    MAX_STD_XY_M,
    MAX_STD_YAW_RAD,
    MAX_TELEOP_MPS,
    MAX_TELEOP_RADPS,
    Coordinate,
    Frame,
    PingFrame,
    Yaw,
)
from navd.wire.mission_frames import MissionControlFrame, MissionFrame

__all__ = [
    "CancelFrame",
    "ClockFrame",
    "ClockRequest",
    "ConfigFrame",
    "ConfigGetFrame",
    "ControlRequest",
    "EmergencyStopFrame",
    "FindPoseFrame",
    "GoalFrame",
    "InitialPoseFrame",
    "LoadMapFrame",
    "RecordFrame",
    "SaveMapFrame",
    "SubscribeFrame",
    "TeleopFrame",
    "UnsubscribeFrame",
]


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


class EmergencyStopFrame(Frame):
    """Stop the robot at once and keep it still until a control client or viewer releases it
    (``engaged`` false): every motion is refused meanwhile, by hand too; the goal is
    cancelled and a mission pauses. Acknowledged; allowed on every control connection."""

    type: Literal["estop"] = "estop"
    engaged: bool = True


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


ControlRequest = (
    GoalFrame
    | CancelFrame
    | EmergencyStopFrame
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

"""What navd sends: typed reply frames, one JSON object per line.

A client decodes them with ``codec.decode_reply``; fields navd adds in later versions are
ignored by older clients (replies, unlike requests, tolerate unknown fields). NaN and
infinity go out as null.
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict

__all__ = [
    "Ack",
    "AppliedInfo",
    "BatteryInfo",
    "BeaconInfo",
    "ClockAck",
    "ConfigAppliedFrame",
    "ConfigNews",
    "ConfigRejectedFrame",
    "DeviceInfo",
    "Diagnostics",
    "ErrorFrame",
    "GoalStatusFrame",
    "LocalizationInfo",
    "MapLoadedFrame",
    "MapSavedFrame",
    "MissionInfo",
    "MissionStatusFrame",
    "ModuleInfo",
    "PathFrame",
    "Pong",
    "PoseFoundFrame",
    "PoseInfo",
    "RejectedInfo",
    "Reply",
    "StatusFrame",
    "VelocityInfo",
    "Welcome",
    "WorkerInfo",
]


class ReplyPart(BaseModel):
    """Common settings of every reply and its parts: frozen, tolerant of newer fields, NaN
    and infinity sent as null."""

    model_config = ConfigDict(frozen=True, extra="ignore", ser_json_inf_nan="null")
    # Unknown values go out as null; a reply with fields that only some requests have
    # leaves the others out.
    OMIT_NONE: ClassVar[bool] = False


class Welcome(ReplyPart):
    """The answer to a good hello."""

    type: Literal["welcome"] = "welcome"
    protocol: int
    daemon: str
    device_id: str
    role: str
    max_line_bytes: int


class ErrorFrame(ReplyPart):
    """A line that could not be used: ``field`` is a dotted path into it ("" for the whole
    frame); after a ``fatal`` one navd closes the connection."""

    type: Literal["error"] = "error"
    field: str
    reason: str
    fatal: bool = False

    def describe(self) -> str:
        """``field: reason``, or the reason alone."""
        return f"{self.field}: {self.reason}" if self.field else self.reason


class Ack(ReplyPart):
    """A control request was accepted (``goal_id``, ``request_id``, ``rate_hz`` when they
    apply to it; ``key`` and ``value`` answer a ``config_get``, the value left out when it is
    null)."""

    OMIT_NONE: ClassVar[bool] = True

    type: Literal["ack"] = "ack"
    request: str
    goal_id: str | None = None
    mission_id: str | None = None
    request_id: str | None = None
    rate_hz: float | None = None
    key: str | None = None
    value: Any = None


class Pong(ReplyPart):
    """The answer to a ping, after every line sent before it."""

    type: Literal["pong"] = "pong"
    id: int | str | None = None


class ClockAck(ReplyPart):
    """A clock step done: the time now, lines navd wrote per device, lines it missed."""

    OMIT_NONE: ClassVar[bool] = True

    type: Literal["clock_ack"] = "clock_ack"
    time: float
    sent: dict[str, int]
    missing: dict[str, int] | None = None


class ConfigAppliedFrame(ReplyPart):
    """A config change from this client was applied."""

    type: Literal["config_applied"] = "config_applied"
    request_id: str
    changed: list[str]


class ConfigRejectedFrame(ReplyPart):
    """A config change from this client was rejected whole."""

    type: Literal["config_rejected"] = "config_rejected"
    request_id: str
    reason: str


class PoseFoundFrame(ReplyPart):
    """Where a search of the map put the robot: [m, m, rad], and the share of the scan's
    points on mapped obstacles there (``score``, 0..1)."""

    type: Literal["pose_found"] = "pose_found"
    x: float
    y: float
    yaw: float
    score: float
    whole_map: bool


class MapLoadedFrame(ReplyPart):
    """What became of a map load: the YAML read, or why the map in use was kept."""

    type: Literal["map_loaded"] = "map_loaded"
    name: str
    path: str = ""
    reason: str = ""


class MapSavedFrame(ReplyPart):
    """What became of a map save: the YAML written, or why nothing was."""

    type: Literal["map_saved"] = "map_saved"
    name: str
    path: str = ""
    reason: str = ""
    files: list[str] = []


class GoalInfo(ReplyPart):
    """A goal's progress (unknown numbers are null)."""

    goal_id: str
    state: str
    distance_remaining: float | None = None
    eta_s: float | None = None
    reason: str = ""


class GoalStatusFrame(GoalInfo):
    """Sent to every control client when a goal's progress changes."""

    type: Literal["goal_status"] = "goal_status"

    @classmethod
    def of(cls, info: GoalInfo) -> GoalStatusFrame:
        """The frame that sends ``info``."""
        return cls(**info.model_dump())


class MissionInfo(ReplyPart):
    """Where a mission is (unknown numbers are null): its state, step ``step`` of ``steps``
    (from 1), round ``round`` of ``rounds`` (0: until cancelled), the step's kind, what just
    happened, the distance and time to the step's goal, a pause's words to the person, why
    it stopped, and how many steps are done and failed."""

    mission_id: str
    name: str
    state: str
    step: int
    steps: int
    round: int
    rounds: int
    kind: str = ""
    event: str = ""
    distance_m: float | None = None
    eta_s: float | None = None
    message: str = ""
    reason: str = ""
    done: int = 0
    failed: int = 0


class MissionStatusFrame(MissionInfo):
    """Sent to every control client on each event of a mission (and as it drives)."""

    type: Literal["mission_status"] = "mission_status"

    @classmethod
    def of(cls, info: MissionInfo) -> MissionStatusFrame:
        """The frame that sends ``info``."""
        return cls(**info.model_dump())


class PathFrame(ReplyPart):
    """A new route, [m] map points from the robot to the goal."""

    type: Literal["path"] = "path"
    goal_id: str
    points: list[tuple[float, float]]


class PoseInfo(ReplyPart):
    """[m, m, rad] the fused pose, and its larger position std [m]."""

    x: float
    y: float
    yaw: float
    std_xy: float


class VelocityInfo(ReplyPart):
    """[m/s, rad/s] the command the wheels were given."""

    linear: float
    angular: float


class DeviceInfo(ReplyPart):
    """A connected client: how long connected and silent [s], lines accepted and rejected."""

    device_id: str
    kind: str
    connected_s: float
    silent_s: float
    stale: bool
    accepted: int
    rejected: int


class LocalizationInfo(ReplyPart):
    """The estimator's verdict, uncertainties [m, rad] and counters; why it is lost when
    the uncertainty does not say (scan matching lost the robot on its map)."""

    state: str
    position_std_m: float | None
    yaw_std_rad: float | None
    counters: dict[str, Any]
    reason: str = ""


class ModuleInfo(ReplyPart):
    """One module's health."""

    name: str
    state: str
    handler_failures: int
    slow_handlers: int
    faulted: bool


class WorkerInfo(ReplyPart):
    """One worker slot's job counts."""

    slot: str
    submitted: int
    completed: int
    dropped: int
    failed: int


class AppliedInfo(ReplyPart):
    """The last config change applied."""

    request_id: str
    stamp: float
    changed: list[str]


class RejectedInfo(ReplyPart):
    """The last config change rejected."""

    request_id: str
    stamp: float
    reason: str


class ConfigNews(ReplyPart):
    """Config changes since start."""

    revision: int
    last_applied: AppliedInfo | None = None
    last_rejected: RejectedInfo | None = None


class Diagnostics(ReplyPart):
    """Why the robot is held, localization, loop lag [ms], modules, workers, config, and
    how scan matching goes."""

    safety: list[str]
    localization: LocalizationInfo | None
    loop_lag_p50_ms: float | None
    loop_lag_p99_ms: float | None
    loop_lag_max_ms: float | None
    uptime_s: float | None
    messages: int | None
    modules: list[ModuleInfo]
    workers: list[WorkerInfo]
    config: ConfigNews
    slam: dict[str, Any] | None = None  # scan matching's counts (SlamTracking)


class BeaconInfo(ReplyPart):
    """[m] a beacon's place in the map frame, its 1-sigma (0 for a place the config gives),
    and whether it was learnt from bearings."""

    id: str
    x: float
    y: float
    std: float
    learnt: bool


class BatteryInfo(ReplyPart):
    """The battery as its sensor last said: [V], [A] (negative discharging), charge in
    [0, 1] (null: not known), whether it charges (null: not known), and its alarm ("ok",
    "low", "critical": ``battery.low_percent`` and ``battery.critical_percent``)."""

    voltage: float
    current: float | None
    percentage: float | None
    charging: bool | None
    alarm: Literal["ok", "low", "critical"]


class StatusFrame(ReplyPart):
    """The daemon as a subscribed control client sees it."""

    type: Literal["status"] = "status"
    stamp: float
    robot: str
    mode: Literal["idle", "navigating", "manual", "stopped"]
    operator: str | None = None  # who drives by hand, in manual mode
    recording: str | None = None  # the MCAP file being written, while recording
    pose: PoseInfo | None
    velocity: VelocityInfo | None
    goal: GoalInfo | None
    mission: MissionInfo | None = None
    beacons: list[BeaconInfo] = []
    battery: BatteryInfo | None = None
    devices: list[DeviceInfo]
    diagnostics: Diagnostics


Reply = (
    Welcome
    | ErrorFrame
    | Ack
    | Pong
    | ClockAck
    | ConfigAppliedFrame
    | ConfigRejectedFrame
    | GoalStatusFrame
    | MissionStatusFrame
    | PathFrame
    | MapSavedFrame
    | MapLoadedFrame
    | PoseFoundFrame
    | StatusFrame
)

"""Requests (goals, cancels, initial poses, map saves, config changes), goal progress, and
the commands that move the robot; the holds that keep it still are in ``safety``."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from navd.config import NavdConfig
from navd.geometry import Pose2
from navd.lifecycle.errors import MessageError
from navd.lifecycle.messages.base import (
    Message,
    require_finite,
)

# --- control ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class Goal(Message):
    """Drive to a pose in the map frame.

    Attributes:
        goal_id: the client's name for this goal.
        x_m: [m] map x.
        y_m: [m] map y.
        yaw_rad: [rad] final yaw, or None when any heading will do.
        max_speed_mps: [m/s] top forward speed on the way (a mission's slow approach), or
            None for the robot's own.
        via: [m] map points to pass on the way, in order (an order's nodes driven through):
            the route goes through each and the robot does not stop at them.
        pass_within_m: [m] a via point is passed once the robot is this close to it.
    """

    goal_id: str
    x_m: float
    y_m: float
    yaw_rad: float | None = None
    max_speed_mps: float | None = None
    via: tuple[tuple[float, float], ...] = ()
    pass_within_m: float = 0.5

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        require_finite("x_m", self.x_m)
        require_finite("y_m", self.y_m)
        for x, y in self.via:
            require_finite("via", x)
            require_finite("via", y)
        if not self.pass_within_m > 0.0:
            raise MessageError(f"pass_within_m must be > 0, got {self.pass_within_m}")
        if self.yaw_rad is not None:
            require_finite("yaw_rad", self.yaw_rad)
        if self.max_speed_mps is not None and not self.max_speed_mps > 0.0:
            raise MessageError(f"max_speed_mps must be > 0, got {self.max_speed_mps}")


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

    @property
    def pose(self) -> Pose2:
        """The pose as a Pose2."""
        return Pose2(self.x_m, self.y_m, self.yaw_rad)


@dataclass(frozen=True, slots=True, kw_only=True)
class SaveMapRequest(Message):
    """Save the map now under ``name`` (the configured name when empty), in ``folder`` (the
    configured ``slam.map_dir`` when empty)."""

    name: str = ""
    folder: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class MapSaved(Message):
    """What became of a map save: written to ``path``, or not, and why.

    Attributes:
        name: the map's name.
        path: the YAML written ("" when nothing was).
        reason: why nothing was written ("" when it was).
        files: every file written (the YAML, its image, navd's state).
    """

    name: str
    path: str = ""
    reason: str = ""
    files: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """True if the map was written."""
        return not self.reason


@dataclass(frozen=True, slots=True, kw_only=True)
class FindPoseRequest(Message):
    """Search the whole map for the robot at the next scan (the robot is lost, or was moved
    by hand)."""

    source: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class PoseFound(Message):
    """Where a search of the map put the robot.

    Attributes:
        x_m, y_m, yaw_rad: [m, m, rad] the pose found.
        score: [ratio] the share of the scan's points on mapped obstacles there (0..1).
        whole_map: the whole map was searched (else around a given pose).
    """

    x_m: float
    y_m: float
    yaw_rad: float
    score: float
    whole_map: bool


@dataclass(frozen=True, slots=True, kw_only=True)
class LoadMapRequest(Message):
    """Replace the map with ``name``.yaml from ``folder`` (``slam.map_dir`` when empty); the
    robot is then searched for on it."""

    name: str
    folder: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class MapLoaded(Message):
    """What became of a map load: the YAML read, or why the map was kept.

    Attributes:
        name: the map's name.
        path: the YAML read ("" when none was).
        reason: why the map in use was kept ("" when it was replaced).
    """

    name: str
    path: str = ""
    reason: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class GoalStatus(Message):
    """Progress towards a goal, published by the planner.

    Attributes:
        goal_id: the goal.
        state: "active", "reached", "canceled" or "failed".
        distance_remaining_m: [m] along the path, NaN when unknown.
        eta_s: [s] estimated time to arrival, NaN when unknown.
        reason: why it failed or was canceled; empty otherwise.
        via_passed: how many of the goal's via points the robot has passed.
    """

    goal_id: str
    state: str
    distance_remaining_m: float = math.nan
    eta_s: float = math.nan
    reason: str = ""
    via_passed: int = 0


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
        privileged: the source may change privileged keys (the config file, or a control
            client where ``tcp.allow_privileged_changes`` says so).
    """

    request_id: str
    changes: Mapping[str, object]
    source: str = ""
    privileged: bool = False

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
        require_finite("linear_mps", self.linear_mps)
        require_finite("angular_radps", self.angular_radps)

    @property
    def is_stop(self) -> bool:
        """True for the zero command."""
        return self.linear_mps == 0.0 and self.angular_radps == 0.0


@dataclass(frozen=True, slots=True, kw_only=True)
class ManualCommand(Message):
    """A body velocity an operator asks for by hand (teleoperation). The planner forwards it
    to the safety gate as a VelocityCommand and pauses its goal meanwhile; the operator must
    keep sending (the deadman): the chassis stops ``safety.reaction_timeout_s`` after the
    last one.

    Attributes:
        linear_mps: [m/s] forward velocity.
        angular_radps: [rad/s] yaw rate, counter-clockwise positive.
        operator: who drives (a control client's id, ``"viewer-3"``...).
    """

    linear_mps: float
    angular_radps: float
    operator: str

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        require_finite("linear_mps", self.linear_mps)
        require_finite("angular_radps", self.angular_radps)


@dataclass(frozen=True, slots=True, kw_only=True)
class DriveMode(Message):
    """Who drives: the navigator ("auto") or an operator by hand ("manual").

    Attributes:
        mode: "auto" or "manual".
        operator: the operator driving ("" in auto).
        paused_goal: the goal paused while the operator drives ("" when none).
    """

    mode: str
    operator: str = ""
    paused_goal: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class ViewInterest(Message):
    """What a viewer watches that costs its maker work to produce: the planner makes the
    costmap and the local trajectory only while someone watches them.

    Attributes:
        costmap: someone watches the costmap.
        trajectory: someone watches the local planner's trajectory.
    """

    costmap: bool
    trajectory: bool


@dataclass(frozen=True, slots=True, kw_only=True)
class RecordRequest(Message):
    """Start or stop recording the session (to ``record.dir``).

    Attributes:
        start: True to start, False to stop.
        source: who asked.
    """

    start: bool
    source: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class RecordingState(Message):
    """Whether the session is being recorded, where, and why it stopped if it did.

    Attributes:
        active: recording now.
        file: the MCAP file being written ("" when not recording).
        reason: why recording stopped or did not start ("" otherwise).
    """

    active: bool
    file: str = ""
    reason: str = ""


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

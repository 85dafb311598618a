"""The robot as the world outside sees it: one view, kept by ``StateView``, that the status
frame, the live view and the VDA 5050 state are all written from."""

from __future__ import annotations

from dataclasses import dataclass

from navd.lifecycle.messages.base import Message
from navd.lifecycle.messages.body import BatteryState
from navd.lifecycle.messages.control import (
    ConfigApplied,
    ConfigRejected,
    DriveCommand,
    DriveMode,
    GoalStatus,
)
from navd.lifecycle.messages.mission import MissionStatus
from navd.lifecycle.messages.results import (
    BeaconPlace,
    DaemonStatus,
    LocalizationState,
    PoseEstimate,
    SlamTracking,
)
from navd.lifecycle.messages.safety import SafetyState

__all__ = ["PARTS", "ConfigHistory", "RobotState"]

# The parts of the view, as ``RobotState.changed`` names them.
PARTS = frozenset(
    {
        "pose",
        "localization",
        "slam",
        "drive",
        "mode",
        "safety",
        "goal",
        "mission",
        "daemon",
        "recording",
        "config",
        "beacons",
        "battery",
    }
)


@dataclass(frozen=True, slots=True)
class ConfigHistory:
    """The config's changes since start: how many were applied, the last applied, the last
    refused."""

    revision: int = 0
    last_applied: ConfigApplied | None = None
    last_rejected: ConfigRejected | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class RobotState(Message):
    """The latest of everything the outside is told, published whenever a part changes.

    Attributes:
        changed: the parts this publication changed (names in ``PARTS``).
        pose: the fused pose (with its velocity), None before the first.
        localization: how well the robot knows where it is.
        slam: how scan matching goes.
        drive: the latest wheel command decided (its body velocity).
        mode: who drives: the navigator, or an operator by hand.
        safety: the safety gate's state: why the robot is held (empty reasons: free).
        goal: the latest goal's progress; ``state == "pending"`` for a goal accepted and not
            yet pursued.
        mission: the mission's latest status (a refused command is not one).
        daemon: the daemon's own health.
        recording: the MCAP file being written ("" when not recording).
        config: the config's changes since start.
        beacons: every beacon with a known or learnt place.
        battery: the battery's latest state, None before its sensor spoke.
        battery_alarm: "ok", "low" or "critical" (``BatteryAlarm``).
    """

    changed: frozenset[str]
    pose: PoseEstimate | None = None
    localization: LocalizationState | None = None
    slam: SlamTracking | None = None
    drive: DriveCommand | None = None
    mode: DriveMode | None = None
    safety: SafetyState | None = None
    goal: GoalStatus | None = None
    mission: MissionStatus | None = None
    daemon: DaemonStatus | None = None
    recording: str = ""
    config: ConfigHistory = ConfigHistory()
    beacons: tuple[BeaconPlace, ...] = ()
    battery: BatteryState | None = None
    battery_alarm: str = "ok"

    @property
    def manual(self) -> bool:
        """Whether an operator drives by hand."""
        return self.mode is not None and self.mode.mode == "manual"

    @property
    def operator(self) -> str:
        """Who drives by hand ("" while the navigator does)."""
        return self.mode.operator if self.mode is not None and self.manual else ""

    @property
    def held(self) -> tuple[str, ...]:
        """Why the safety gate holds the robot (empty: it may move)."""
        return () if self.safety is None else self.safety.reasons

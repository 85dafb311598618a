"""The robot's state as the outside sees it, kept in one place.

``StateView`` hears the messages that make up what a person or a fleet is told (the pose,
localization, scan matching, the wheel command, who drives, the safety gate, the goal, the
mission, the daemon's health, recording, config changes, beacons, the battery) and publishes a
``RobotState`` with the latest of each whenever one changes. The three encoders of that
state (the TCP status frame, the live view, the VDA 5050 state) read it from there, each in
its own format, and none assembles it again. The daemon keeps it, as it keeps the config
service: every daemon has it, whichever modules it runs.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import Clock
from navd.lifecycle.messages import (
    BatteryAlarm,
    BatteryState,
    BeaconPlaces,
    ConfigApplied,
    ConfigRejected,
    DaemonStatus,
    DriveCommand,
    DriveMode,
    Goal,
    GoalStatus,
    LocalizationState,
    Message,
    MissionStatus,
    PoseEstimate,
    RecordingState,
    SafetyState,
    SlamTracking,
)
from navd.lifecycle.messages.state import ConfigHistory, RobotState

__all__ = ["StateView"]


class StateView:
    """Keeps ``RobotState`` and publishes it on every change (see the module docstring).

    Args:
        bus: where it hears the parts and publishes the state (its handlers counted as
            ``MODULE``'s).
        clock: the daemon's.
    """

    MODULE = "state_view"

    def __init__(self, bus: Bus, clock: Clock) -> None:
        self._bus = bus
        self._clock = clock
        self.state = RobotState(stamp=0.0, received=0.0, changed=frozenset())
        hear = functools.partial(bus.subscribe, module=self.MODULE)
        hear(PoseEstimate, self._pose)
        hear(LocalizationState, self._localization)
        hear(SlamTracking, self._slam)
        hear(DriveCommand, self._drive)
        hear(DriveMode, self._mode)
        hear(SafetyState, self._safety)
        hear(Goal, self._goal)
        hear(GoalStatus, self._goal_status)
        hear(MissionStatus, self._mission)
        hear(DaemonStatus, self._daemon)
        hear(RecordingState, self._recording)
        hear(ConfigApplied, self._config_applied)
        hear(ConfigRejected, self._config_rejected)
        hear(BeaconPlaces, self._beacons)
        hear(BatteryState, self._battery)
        hear(BatteryAlarm, self._battery_alarm)

    def _change(self, source: Message, part: str, **values: Any) -> None:
        """Take ``values`` for ``part`` (heard in ``source``) and publish the state."""
        now = self._clock.now()
        self.state = dataclasses.replace(
            self.state, stamp=source.stamp, received=now, changed=frozenset((part,)), **values
        )
        self._bus.publish(self.state)

    def _pose(self, pose: PoseEstimate) -> None:
        self._change(pose, "pose", pose=pose)

    def _localization(self, state: LocalizationState) -> None:
        self._change(state, "localization", localization=state)

    def _slam(self, tracking: SlamTracking) -> None:
        self._change(tracking, "slam", slam=tracking)

    def _drive(self, drive: DriveCommand) -> None:
        self._change(drive, "drive", drive=drive)

    def _mode(self, mode: DriveMode) -> None:
        self._change(mode, "mode", mode=mode)

    def _safety(self, state: SafetyState) -> None:
        self._change(state, "safety", safety=state)

    def _goal(self, goal: Goal) -> None:
        """A new goal shows as pending until the planner says how it goes."""
        known = self.state.goal
        if known is None or known.goal_id != goal.goal_id:
            pending = GoalStatus(
                stamp=goal.stamp, received=goal.received, goal_id=goal.goal_id, state="pending"
            )
            self._change(goal, "goal", goal=pending)

    def _goal_status(self, status: GoalStatus) -> None:
        self._change(status, "goal", goal=status)

    def _mission(self, status: MissionStatus) -> None:
        if status.info.event != "refused":  # a refused command changes nothing
            self._change(status, "mission", mission=status)

    def _daemon(self, status: DaemonStatus) -> None:
        self._change(status, "daemon", daemon=status)

    def _recording(self, state: RecordingState) -> None:
        self._change(state, "recording", recording=state.file if state.active else "")

    def _config_applied(self, applied: ConfigApplied) -> None:
        config = self.state.config
        history = ConfigHistory(config.revision + 1, applied, config.last_rejected)
        self._change(applied, "config", config=history)

    def _config_rejected(self, rejected: ConfigRejected) -> None:
        config = self.state.config
        history = ConfigHistory(config.revision, config.last_applied, rejected)
        self._change(rejected, "config", config=history)

    def _beacons(self, places: BeaconPlaces) -> None:
        self._change(places, "beacons", beacons=places.places)

    def _battery(self, battery: BatteryState) -> None:
        self._change(battery, "battery", battery=battery)

    def _battery_alarm(self, alarm: BatteryAlarm) -> None:
        self._change(alarm, "battery", battery_alarm=alarm.level)

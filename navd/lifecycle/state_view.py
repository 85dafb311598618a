"""The robot's state as the outside sees it, kept in one place.

``StateView`` hears the messages that make up what a person or a fleet is told (the pose,
localization, scan matching, the wheel command, who drives, the safety gate, the goal, the
mission, the daemon's health, recording, config changes, beacons) and publishes a
``RobotState`` with the latest of each whenever one changes. The three encoders of that
state (the TCP status frame, the live view, the VDA 5050 state) read it from there, each in
its own format, and none assembles it again.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from navd.lifecycle.messages import (
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
from navd.lifecycle.module import Module, ModuleContext

__all__ = ["StateView"]


class StateView(Module):
    """Keeps ``RobotState`` and publishes it on every change (see the module docstring)."""

    def __init__(self) -> None:
        super().__init__("state")
        self.state = RobotState(stamp=0.0, received=0.0, changed=frozenset())

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        ctx.subscribe(PoseEstimate, self._pose)
        ctx.subscribe(LocalizationState, self._localization)
        ctx.subscribe(SlamTracking, self._slam)
        ctx.subscribe(DriveCommand, self._drive)
        ctx.subscribe(DriveMode, self._mode)
        ctx.subscribe(SafetyState, self._safety)
        ctx.subscribe(Goal, self._goal)
        ctx.subscribe(GoalStatus, self._goal_status)
        ctx.subscribe(MissionStatus, self._mission)
        ctx.subscribe(DaemonStatus, self._daemon)
        ctx.subscribe(RecordingState, self._recording)
        ctx.subscribe(ConfigApplied, self._config_applied)
        ctx.subscribe(ConfigRejected, self._config_rejected)
        ctx.subscribe(BeaconPlaces, self._beacons)

    def _change(self, source: Message, part: str, **values: Any) -> None:
        """Take ``values`` for ``part`` (heard in ``source``) and publish the state."""
        now = self.ctx.clock.now()
        self.state = dataclasses.replace(
            self.state, stamp=source.stamp, received=now, changed=frozenset((part,)), **values
        )
        self.ctx.publish(self.state)

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

"""What a control client sees in a ``status`` frame: the latest of everything, kept cheaply.

The board subscribes to the messages that make up the status (pose, wheel command, goal
progress, who drives, recording, daemon health, safety holds, config changes), keeps only
the latest of each, and builds the frame on demand at the subscriber's rate.
"""

from __future__ import annotations

import math

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
    MissionStatus,
    PoseEstimate,
    RecordingState,
    SafetyState,
    SlamTracking,
)
from navd.lifecycle.module import ModuleContext
from navd.wire import (
    AppliedInfo,
    BeaconInfo,
    ConfigNews,
    DeviceInfo,
    Diagnostics,
    GoalInfo,
    LocalizationInfo,
    ModuleInfo,
    PoseInfo,
    RejectedInfo,
    StatusFrame,
    VelocityInfo,
    WorkerInfo,
)

__all__ = ["MAX_LISTED_BEACONS", "StatusBoard", "goal_info"]

MAX_LISTED_BEACONS = 64  # beacons shown in a status frame (a bounded frame)


class StatusBoard:
    """The latest pose, command, goal, health, safety and config news."""

    def __init__(self) -> None:
        self.pose: PoseEstimate | None = None
        self.localization: LocalizationState | None = None
        self.slam: SlamTracking | None = None
        self.drive: DriveCommand | None = None
        self.goal: GoalStatus | None = None
        self.mission: MissionStatus | None = None
        self.daemon: DaemonStatus | None = None
        self.safety: tuple[str, ...] = ()
        self.operator = ""  # who drives by hand ("" while the navigator does)
        self.recording = ""  # the file being recorded ("" when not recording)
        self.config = ConfigNews(revision=0)
        self.beacons: list[BeaconInfo] = []

    def subscribe(self, ctx: ModuleContext) -> None:
        """Keep up to date from the bus (handlers attributed to ``ctx``'s module)."""
        ctx.subscribe(PoseEstimate, self._pose)
        ctx.subscribe(LocalizationState, self._localization)
        ctx.subscribe(SlamTracking, self._slam)
        ctx.subscribe(DriveCommand, self._drive)
        ctx.subscribe(DaemonStatus, self._daemon)
        ctx.subscribe(SafetyState, self._safety)
        ctx.subscribe(DriveMode, self._drive_mode)
        ctx.subscribe(RecordingState, self._recording)
        ctx.subscribe(Goal, self._goal)
        ctx.subscribe(GoalStatus, self._goal_status)
        ctx.subscribe(MissionStatus, self._mission_status)
        ctx.subscribe(ConfigApplied, self._config_applied)
        ctx.subscribe(ConfigRejected, self._config_rejected)
        ctx.subscribe(BeaconPlaces, self._beacons)

    def frame(self, now: float, robot: str, devices: list[DeviceInfo]) -> StatusFrame:
        """The status frame at ``now`` [s] of the robot named ``robot``, with the server's
        device list."""
        # navigating only while the planner reports the goal active: an accepted goal that
        # nothing pursues yet is shown under "goal" as pending, not as motion
        goal_active = self.goal is not None and self.goal.state == "active"
        mode = (
            "stopped"
            if self.safety
            else "manual"
            if self.operator
            else "navigating"
            if goal_active
            else "idle"
        )
        pose, drive, daemon = self.pose, self.drive, self.daemon
        return StatusFrame(
            stamp=now,
            robot=robot,
            mode=mode,
            operator=self.operator or None,
            recording=self.recording or None,
            pose=None
            if pose is None
            else PoseInfo(
                x=pose.x_m,
                y=pose.y_m,
                yaw=pose.yaw_rad,
                std_xy=math.sqrt(max(pose.covariance[0, 0], pose.covariance[1, 1])),
            ),
            velocity=None
            if drive is None
            else VelocityInfo(linear=drive.linear_mps, angular=drive.angular_radps),
            goal=None if self.goal is None else goal_info(self.goal),
            mission=None if self.mission is None else self.mission.info,
            beacons=self.beacons,
            devices=devices,
            diagnostics=Diagnostics(
                safety=list(self.safety),
                localization=_localization_info(self.localization),
                loop_lag_p50_ms=None if daemon is None else round(daemon.loop_lag_p50_ms, 3),
                loop_lag_p99_ms=None if daemon is None else round(daemon.loop_lag_p99_ms, 3),
                loop_lag_max_ms=None if daemon is None else round(daemon.loop_lag_max_ms, 3),
                uptime_s=None if daemon is None else round(daemon.uptime_s, 3),
                messages=None if daemon is None else daemon.messages_dispatched,
                modules=[]
                if daemon is None
                else [ModuleInfo(**m._asdict()) for m in daemon.modules],
                workers=[]
                if daemon is None
                else [WorkerInfo(**w._asdict()) for w in daemon.workers],
                config=self.config,
                slam=None if self.slam is None else dict(self.slam.counts),
            ),
        )

    def _beacons(self, places: BeaconPlaces) -> None:
        self.beacons = [
            BeaconInfo(id=p.beacon_id, x=p.x_m, y=p.y_m, std=p.std_m, learnt=p.learnt)
            for p in places.places[:MAX_LISTED_BEACONS]
        ]

    def _pose(self, pose: PoseEstimate) -> None:
        self.pose = pose

    def _localization(self, state: LocalizationState) -> None:
        self.localization = state

    def _slam(self, tracking: SlamTracking) -> None:
        self.slam = tracking

    def _drive(self, drive: DriveCommand) -> None:
        self.drive = drive

    def _drive_mode(self, mode: DriveMode) -> None:
        self.operator = mode.operator if mode.mode == "manual" else ""

    def _recording(self, state: RecordingState) -> None:
        self.recording = state.file if state.active else ""

    def _daemon(self, status: DaemonStatus) -> None:
        self.daemon = status

    def _safety(self, state: SafetyState) -> None:
        self.safety = state.reasons

    def _goal(self, goal: Goal) -> None:
        if self.goal is None or self.goal.goal_id != goal.goal_id:
            self.goal = GoalStatus(
                stamp=goal.stamp, received=goal.received, goal_id=goal.goal_id, state="pending"
            )

    def _goal_status(self, status: GoalStatus) -> None:
        self.goal = status

    def _mission_status(self, status: MissionStatus) -> None:
        if status.info.event != "refused":  # a refused command changes nothing
            self.mission = status

    def _config_applied(self, applied: ConfigApplied) -> None:
        news = AppliedInfo(
            request_id=applied.request_id, stamp=applied.stamp, changed=list(applied.changed_keys)
        )
        self.config = self.config.model_copy(
            update={"revision": self.config.revision + 1, "last_applied": news}
        )

    def _config_rejected(self, rejected: ConfigRejected) -> None:
        news = RejectedInfo(
            request_id=rejected.request_id, stamp=rejected.stamp, reason=rejected.reason
        )
        self.config = self.config.model_copy(update={"last_rejected": news})


def goal_info(status: GoalStatus) -> GoalInfo:
    """A goal's progress as sent to clients (unknown numbers become null on the wire)."""
    return GoalInfo(
        goal_id=status.goal_id,
        state=status.state,
        distance_remaining=status.distance_remaining_m,
        eta_s=status.eta_s,
        reason=status.reason,
    )


def _localization_info(state: LocalizationState | None) -> LocalizationInfo | None:
    if state is None:
        return None
    finite = math.isfinite(state.position_std_m)
    return LocalizationInfo(
        state=state.state,
        position_std_m=round(state.position_std_m, 4) if finite else None,
        yaw_std_rad=round(state.yaw_std_rad, 4) if finite else None,
        counters=dict(state.counters),
        reason=state.reason,
    )

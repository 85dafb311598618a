"""What a control client sees in a ``status`` frame: the robot's state (``RobotState``,
kept by the lifecycle's ``StateView``) written as the wire's status frame, on demand at the
subscriber's rate.
"""

from __future__ import annotations

import math

from navd.lifecycle import ModuleContext
from navd.lifecycle.messages import GoalStatus, LocalizationState, RobotState
from navd.wire import (
    AppliedInfo,
    BatteryInfo,
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
    """The robot's latest state, written as a status frame when one is due."""

    def __init__(self) -> None:
        self.state = RobotState(stamp=0.0, received=0.0, changed=frozenset())

    def subscribe(self, ctx: ModuleContext) -> None:
        """Keep up to date from the bus (handlers attributed to ``ctx``'s module)."""
        ctx.subscribe(RobotState, self._state)

    def _state(self, state: RobotState) -> None:
        self.state = state

    def frame(self, now: float, robot: str, devices: list[DeviceInfo]) -> StatusFrame:
        """The status frame at ``now`` [s] of the robot named ``robot``, with the server's
        device list."""
        state = self.state
        held, operator = state.held, state.operator
        # navigating only while the planner reports the goal active: an accepted goal that
        # nothing pursues yet is shown under "goal" as pending, not as motion
        goal_active = state.goal is not None and state.goal.state == "active"
        mode = (
            "stopped" if held else "manual" if operator else "navigating" if goal_active else "idle"
        )
        pose, drive, daemon = state.pose, state.drive, state.daemon
        return StatusFrame(
            stamp=now,
            robot=robot,
            mode=mode,
            operator=operator or None,
            recording=state.recording or None,
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
            goal=None if state.goal is None else goal_info(state.goal),
            mission=None if state.mission is None else state.mission.info,
            beacons=[
                BeaconInfo(id=p.beacon_id, x=p.x_m, y=p.y_m, std=p.std_m, learnt=p.learnt)
                for p in state.beacons[:MAX_LISTED_BEACONS]
            ],
            battery=battery_info(state),
            devices=devices,
            diagnostics=Diagnostics(
                safety=list(held),
                localization=_localization_info(state.localization),
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
                config=_config_news(state),
                slam=None if state.slam is None else dict(state.slam.counts),
            ),
        )


def _config_news(state: RobotState) -> ConfigNews:
    history = state.config
    applied, rejected = history.last_applied, history.last_rejected
    return ConfigNews(
        revision=history.revision,
        last_applied=None
        if applied is None
        else AppliedInfo(
            request_id=applied.request_id, stamp=applied.stamp, changed=list(applied.changed_keys)
        ),
        last_rejected=None
        if rejected is None
        else RejectedInfo(
            request_id=rejected.request_id, stamp=rejected.stamp, reason=rejected.reason
        ),
    )


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


def battery_info(state: RobotState) -> BatteryInfo | None:
    """The battery as sent to clients (unknown numbers become null on the wire)."""
    battery = state.battery
    if battery is None:
        return None
    alarm = state.battery_alarm if state.battery_alarm in ("low", "critical") else "ok"
    return BatteryInfo(
        voltage=round(battery.voltage_v, 3),
        current=None if math.isnan(battery.current_a) else round(battery.current_a, 3),
        percentage=None if math.isnan(battery.percentage) else round(battery.percentage, 4),
        charging=battery.charging,
        alarm=alarm,
    )

"""Control requests as bus messages: a goal, a cancel, a config change, an initial pose, a map
save or load, a pose search, driving by hand, recording, a mission and its commands, each
named after the client that sent it. The TCP server's control clients and the live view's
viewers both send them, and both turn them into the same messages here."""

from __future__ import annotations

import math

from navd.lifecycle.messages import (
    CancelGoal,
    ConfigChange,
    EmergencyStop,
    FindPoseRequest,
    GeoGoal,
    Goal,
    InitialPose,
    LoadMapRequest,
    ManualCommand,
    Message,
    MissionCommand,
    MissionRequest,
    MissionStep,
    RecordRequest,
    SaveMapRequest,
)
from navd.wire import (
    CancelFrame,
    ConfigFrame,
    ControlRequest,
    EmergencyStopFrame,
    FindPoseFrame,
    GoalFrame,
    InitialPoseFrame,
    LoadMapFrame,
    MissionControlFrame,
    MissionFrame,
    MissionStepSpec,
    RecordFrame,
    SaveMapFrame,
    TeleopFrame,
)

__all__ = ["control_message"]


def control_message(
    frame: ControlRequest, client_id: str, now: float, serial: int, *, privileged: bool = False
) -> Message:
    """A control request that becomes a bus message.

    Args:
        frame: a goal, cancel, config, initial pose, save-map, teleop or record request
            (the session's own requests, subscribe, unsubscribe and ping, are not messages).
        client_id: the control client's device id (names its goals and requests).
        now: [s] daemon time.
        serial: a per-client counter for ids the client did not give.
        privileged: the client may change privileged config keys.

    Raises:
        TypeError: ``frame`` is a session request.
    """
    if isinstance(frame, GoalFrame):
        goal_id = frame.goal_id or f"{client_id}-{serial}"
        if frame.x is not None and frame.y is not None:
            return Goal(
                stamp=now,
                received=now,
                goal_id=goal_id,
                x_m=frame.x,
                y_m=frame.y,
                yaw_rad=frame.yaw,
            )
        assert frame.latitude is not None and frame.longitude is not None
        return GeoGoal(
            stamp=now,
            received=now,
            goal_id=goal_id,
            latitude_deg=frame.latitude,
            longitude_deg=frame.longitude,
            yaw_rad=frame.yaw,
        )
    if isinstance(frame, MissionFrame):
        return MissionRequest(
            stamp=now,
            received=now,
            mission_id=frame.mission_id or f"{client_id}-{serial}",
            name=frame.name,
            steps=tuple(_mission_step(step, frame) for step in frame.steps),
            rounds=frame.rounds,
            client_id=client_id,
        )
    if isinstance(frame, MissionControlFrame):
        return MissionCommand(stamp=now, received=now, action=frame.action, client_id=client_id)
    if isinstance(frame, CancelFrame):
        return CancelGoal(stamp=now, received=now, goal_id=frame.goal_id)
    if isinstance(frame, EmergencyStopFrame):
        return EmergencyStop(stamp=now, received=now, engaged=frame.engaged, source=client_id)
    if isinstance(frame, ConfigFrame):
        return ConfigChange(
            stamp=now,
            received=now,
            request_id=frame.request_id or f"{client_id}-{serial}",
            changes=frame.changes,
            source=client_id,
            privileged=privileged,
        )
    if isinstance(frame, InitialPoseFrame):
        return InitialPose(
            stamp=now,
            received=now,
            x_m=frame.x,
            y_m=frame.y,
            yaw_rad=frame.yaw,
            std_xy_m=frame.std_xy,
            std_yaw_rad=frame.std_yaw,
        )
    if isinstance(frame, SaveMapFrame):
        return SaveMapRequest(stamp=now, received=now, name=frame.name, folder=frame.folder or "")
    if isinstance(frame, FindPoseFrame):
        return FindPoseRequest(stamp=now, received=now, source=client_id)
    if isinstance(frame, LoadMapFrame):
        return LoadMapRequest(
            stamp=now,
            received=now,
            name=frame.name.removesuffix(".yaml"),
            folder=frame.folder or "",
        )
    if isinstance(frame, RecordFrame):
        return RecordRequest(
            stamp=now, received=now, start=frame.action == "start", source=client_id
        )
    if isinstance(frame, TeleopFrame):
        return ManualCommand(
            stamp=now,
            received=now,
            linear_mps=frame.linear_x,
            angular_radps=frame.angular_z,
            operator=client_id,
        )
    raise TypeError(f"{type(frame).__name__} is a session request, not a bus message")


def _mission_step(step: MissionStepSpec, mission: MissionFrame) -> MissionStep:
    """A mission file's step as the mission module runs it (the mission's failure policy
    where the step gives none)."""
    nan = math.nan
    return MissionStep(
        kind=step.kind,
        x_m=nan if step.x is None else step.x,
        y_m=nan if step.y is None else step.y,
        yaw_rad=step.yaw,
        latitude_deg=nan if step.latitude is None else step.latitude,
        longitude_deg=nan if step.longitude is None else step.longitude,
        seconds=step.seconds or 0.0,
        message=step.message,
        stop_distance_m=step.stop_distance,
        speed_mps=step.speed,
        on_failure=step.on_failure or mission.on_failure,
        retries=mission.retries if step.retries is None else step.retries,
        beacons=(step.beacon,) if step.beacon is not None else tuple(step.beacons or ()),
    )

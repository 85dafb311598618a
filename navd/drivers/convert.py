"""Frames to bus messages: sensor data stamped on the daemon clock, requests named after
their client."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from navd.geometry import wrap_angle
from navd.lifecycle.messages import (
    BeaconObservation,
    CancelGoal,
    CompassHeading,
    ConfigChange,
    FindPoseRequest,
    GeoGoal,
    Goal,
    GpsFix,
    Imu,
    InitialPose,
    LaserScan,
    LoadMapRequest,
    ManualCommand,
    Message,
    MissionCommand,
    MissionRequest,
    MissionStep,
    RecordRequest,
    SaveMapRequest,
    Vector3,
    WheelOdometry,
)
from navd.wire import (
    BeaconFrame,
    CancelFrame,
    ConfigFrame,
    ControlRequest,
    FindPoseFrame,
    FixFrame,
    GoalFrame,
    HeadingFrame,
    ImuFrame,
    InitialPoseFrame,
    LoadMapFrame,
    MissionControlFrame,
    MissionFrame,
    MissionStepSpec,
    OdomFrame,
    RecordFrame,
    RosFixFrame,
    RosImuFrame,
    RosOdomFrame,
    RosScanFrame,
    SaveMapFrame,
    ScanFrame,
    SensorFrame,
    TeleopFrame,
)

__all__ = ["control_message", "sensor_message"]

TESLA_TO_MICROTESLA = 1e6


def _scan(frame: ScanFrame, device_id: str, stamp: float, received: float) -> Message:
    return LaserScan(
        stamp=stamp,
        received=received,
        device_id=device_id,
        angle_min=frame.angle_min,
        angle_increment=frame.angle_increment,
        ranges=frame.ranges_array(),
        range_min=frame.range_min,
        range_max=frame.range_max,
        time_increment=frame.time_increment,
    )


def _imu(frame: ImuFrame, device_id: str, stamp: float, received: float) -> Message:
    mag = frame.magnetic_field
    return Imu(
        stamp=stamp,
        received=received,
        device_id=device_id,
        gyro_radps=Vector3(*frame.angular_velocity),
        accel_mps2=Vector3(*frame.linear_acceleration),
        mag_ut=None if mag is None else Vector3(*(c * TESLA_TO_MICROTESLA for c in mag)),
    )


def _fix(frame: FixFrame, device_id: str, stamp: float, received: float) -> Message | None:
    if frame.status < 0:
        return None  # the receiver says it has no fix: nothing to use, nothing wrong
    return GpsFix(
        stamp=stamp,
        received=received,
        device_id=device_id,
        latitude_deg=frame.latitude,
        longitude_deg=frame.longitude,
        altitude_m=frame.altitude,
        horizontal_accuracy_m=frame.horizontal_accuracy,
    )


def _heading(frame: HeadingFrame, device_id: str, stamp: float, received: float) -> Message:
    return CompassHeading(
        stamp=stamp,
        received=received,
        device_id=device_id,
        bearing_deg=frame.bearing_deg,
        accuracy_deg=frame.accuracy_deg,
        true_north=frame.true_north,
    )


def _beacon(frame: BeaconFrame, device_id: str, stamp: float, received: float) -> Message:
    return BeaconObservation(
        stamp=stamp,
        received=received,
        device_id=device_id,
        beacon_id=frame.beacon,
        range_m=math.nan if frame.range_m is None else frame.range_m,
        range_std_m=frame.range_std_m,
        bearing_rad=math.nan if frame.bearing_rad is None else wrap_angle(frame.bearing_rad),
        bearing_std_rad=frame.bearing_std_rad,
    )


def _odom(frame: OdomFrame, device_id: str, stamp: float, received: float) -> Message:
    return WheelOdometry(
        stamp=stamp,
        received=received,
        device_id=device_id,
        linear_mps=frame.linear_x,
        angular_radps=frame.angular_z,
    )


_CONVERTERS: dict[type[Any], Callable[[Any, str, float, float], Message | None]] = {
    ScanFrame: _scan,
    ImuFrame: _imu,
    FixFrame: _fix,
    HeadingFrame: _heading,
    OdomFrame: _odom,
    BeaconFrame: _beacon,
    RosScanFrame: _scan,
    RosImuFrame: _imu,
    RosFixFrame: _fix,
    RosOdomFrame: _odom,
}


def sensor_message(
    frame: SensorFrame, device_id: str, stamp: float, received: float
) -> Message | None:
    """A sensor frame as its typed message; None for a GNSS frame without a fix.

    Args:
        frame: a validated sensor frame.
        device_id: the sensor's id.
        stamp: [s] its measurement time on the daemon clock.
        received: [s] its arrival on the daemon clock.

    Raises:
        WireError: a field that only the conversion can check (bad base64 ranges).
    """
    return _CONVERTERS[type(frame)](frame, device_id, stamp, received)


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

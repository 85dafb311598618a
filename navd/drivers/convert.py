"""Sensor frames to bus messages: each measurement stamped on the daemon clock (control
requests are ``lifecycle.requests``')."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from navd.geometry import wrap_angle
from navd.lifecycle.messages import (
    BatteryState,
    BeaconObservation,
    CompassHeading,
    Contact,
    DepthPoints,
    GpsFix,
    Imu,
    LaserScan,
    Message,
    RangeReading,
    Vector3,
    WheelOdometry,
)
from navd.wire import (
    BatteryFrame,
    BeaconFrame,
    ContactFrame,
    FixFrame,
    HeadingFrame,
    ImuFrame,
    OdomFrame,
    PointsFrame,
    RangeFrame,
    RosFixFrame,
    RosImuFrame,
    RosOdomFrame,
    RosScanFrame,
    ScanFrame,
    SensorFrame,
)

__all__ = ["sensor_message"]

TESLA_TO_MICROTESLA = 1e6


def _scan(frame: ScanFrame, device_id: str, stamp: float, received: float) -> Message:
    ranges = frame.ranges_array()
    return LaserScan(
        stamp=stamp,
        received=received,
        device_id=device_id,
        angle_min=frame.angle_min,
        angle_increment=frame.angle_increment,
        ranges=ranges,
        range_min=frame.range_min,
        range_max=frame.range_max,
        time_increment=frame.time_increment,
        intensities=frame.intensities_array(),
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


def _range(frame: RangeFrame, device_id: str, stamp: float, received: float) -> Message:
    reading = math.inf if frame.range is None else max(frame.range, frame.min_range)
    return RangeReading(
        stamp=stamp,
        received=received,
        device_id=device_id,
        sensor=frame.sensor or device_id,
        range_m=reading,
        field_of_view_rad=frame.field_of_view,
        min_range_m=frame.min_range,
        max_range_m=frame.max_range,
    )


def _contact(frame: ContactFrame, device_id: str, stamp: float, received: float) -> Message:
    return Contact(
        stamp=stamp,
        received=received,
        device_id=device_id,
        sensor=frame.sensor or device_id,
        kind=frame.kind,
        triggered=frame.triggered,
    )


def _points(frame: PointsFrame, device_id: str, stamp: float, received: float) -> Message:
    return DepthPoints(
        stamp=stamp,
        received=received,
        device_id=device_id,
        sensor=frame.sensor or device_id,
        points_m=frame.points_array(),
    )


def _battery(frame: BatteryFrame, device_id: str, stamp: float, received: float) -> Message:
    return BatteryState(
        stamp=stamp,
        received=received,
        device_id=device_id,
        voltage_v=frame.voltage,
        current_a=math.nan if frame.current is None else frame.current,
        percentage=math.nan if frame.percentage is None else frame.percentage,
        charging=frame.charging,
    )


_CONVERTERS: dict[type[Any], Callable[[Any, str, float, float], Message | None]] = {
    RangeFrame: _range,
    ContactFrame: _contact,
    PointsFrame: _points,
    BatteryFrame: _battery,
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

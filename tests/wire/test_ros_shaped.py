"""ROS messages dumped as JSON field for field (a header, {x, y, z} vectors, angle_max,
intensities, covariances, a status object) are taken as navd's frames."""

from __future__ import annotations

import json
import math
from typing import Any

import pytest

from navd.drivers import sensor_message
from navd.lifecycle.messages import GpsFix, Imu, LaserScan, WheelOdometry
from navd.wire import FixFrame, ImuFrame, OdomFrame, ScanFrame, WireError, decode_sensor

HEADER = {"stamp": {"sec": 1700000000, "nanosec": 250000000}, "frame_id": "laser"}
SCAN: dict[str, Any] = {
    "type": "scan",
    "header": HEADER,
    "angle_min": -1.5,
    "angle_max": 1.5,
    "angle_increment": 1.0,
    "time_increment": 0.0,
    "scan_time": 0.1,
    "range_min": 0.1,
    "range_max": 10.0,
    "ranges": [1.0, 2.0, None, 4.0],
    "intensities": [100, 100, 0, 90],
}
IMU: dict[str, Any] = {
    "type": "imu",
    "header": {"stamp": {"secs": 12, "nsecs": 5}, "frame_id": "imu_link"},  # ROS 1 names
    "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
    "orientation_covariance": [-1.0] + [0.0] * 8,
    "angular_velocity": {"x": 0.01, "y": -0.02, "z": 0.3},
    "angular_velocity_covariance": [0.0] * 9,
    "linear_acceleration": {"x": 0.1, "y": 0.0, "z": 9.81},
    "linear_acceleration_covariance": [0.0] * 9,
}
FIX: dict[str, Any] = {
    "type": "fix",
    "header": HEADER,
    "status": {"status": 2, "service": 1},
    "latitude": 52.52,
    "longitude": 13.405,
    "altitude": 34.0,
    "position_covariance": [2.25, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 9.0],
    "position_covariance_type": 2,
}

ODOMETRY: dict[str, Any] = {
    "header": {"stamp": {"sec": 40, "nanosec": 500000000}, "frame_id": "odom"},
    "child_frame_id": "base_link",
    "pose": {
        "pose": {
            "position": {"x": 3.0, "y": 1.0, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        },
        "covariance": [0.0] * 36,
    },
    "twist": {
        "twist": {"linear": {"x": 0.4, "y": 0.0, "z": 0.0}, "angular": {"x": 0, "y": 0, "z": -0.2}},
        "covariance": [0.0] * 36,
    },
}


def _decode(role: str, message: dict[str, Any]) -> Any:
    return decode_sensor(role, json.dumps(message).encode())


def test_a_laser_scan_message_is_a_scan_stamped_by_its_header() -> None:
    frame = _decode("lidar", SCAN)
    assert isinstance(frame, ScanFrame) and frame.stamp == pytest.approx(1700000000.25)
    scan = sensor_message(frame, "front", frame.stamp, frame.stamp)
    assert isinstance(scan, LaserScan) and scan.angle_min == -1.5
    assert math.isnan(scan.ranges[2]) and scan.ranges[3] == 4.0


def test_an_imu_message_with_xyz_vectors_and_covariances() -> None:
    frame = _decode("imu", IMU)
    assert isinstance(frame, ImuFrame) and frame.stamp == pytest.approx(12.000000005)
    imu = sensor_message(frame, "imu0", 1.0, 1.0)
    assert isinstance(imu, Imu)
    assert tuple(imu.gyro_radps) == (0.01, -0.02, 0.3)
    assert tuple(imu.accel_mps2) == (0.1, 0.0, 9.81)


def test_a_navsatfix_takes_its_accuracy_from_the_covariance_and_its_status_object() -> None:
    frame = _decode("gps", FIX)
    assert isinstance(frame, FixFrame) and frame.status == 2
    assert frame.horizontal_accuracy == pytest.approx(2.0)  # the larger of 1.5 and 2 m
    fix = sensor_message(frame, "gnss", 1.0, 1.0)
    assert isinstance(fix, GpsFix) and fix.horizontal_accuracy_m == pytest.approx(2.0)


def test_a_stamp_of_its_own_wins_over_the_header() -> None:
    frame = _decode("lidar", {**SCAN, "stamp": 5.0})
    assert frame.stamp == 5.0


@pytest.mark.parametrize(
    ("role", "message", "named"),
    [
        ("lidar", {**SCAN, "angle_max": 3.0}, "angle_max"),
        ("lidar", {**SCAN, "intensities": [1, 2]}, "intensities"),
        ("lidar", {**SCAN, "header": "laser"}, "header"),
        ("lidar", {**SCAN, "header": {"stamp": {"sec": 1.5}}}, "header.stamp"),
        ("imu", {**IMU, "angular_velocity": {"x": 1.0, "y": 2.0}}, "angular_velocity"),
        ("imu", {**IMU, "orientation_covariance": [0.0] * 4}, "orientation_covariance"),
        ("gps", {**FIX, "position_covariance_type": 0}, "horizontal_accuracy"),
    ],
)
def test_a_malformed_ros_message_is_refused_naming_the_field(
    role: str, message: dict[str, Any], named: str
) -> None:
    with pytest.raises(WireError, match=named):
        _decode(role, message)


def test_an_odometry_message_gives_the_body_velocity_of_its_twist() -> None:
    frame = _decode("wheel_odometry", {"type": "odom", **ODOMETRY})
    assert isinstance(frame, OdomFrame) and frame.stamp == pytest.approx(40.5)
    odom = sensor_message(frame, "wheels", 1.0, 1.0)
    assert isinstance(odom, WheelOdometry)
    assert (odom.linear_mps, odom.angular_radps) == (0.4, -0.2)
    with pytest.raises(WireError, match="twist"):
        _decode("wheel_odometry", {"type": "odom", **ODOMETRY, "twist": {"linear": 1}})


def _rosbridge(topic: str, msg: dict[str, Any]) -> bytes:
    # what rosbridge_server sends a subscriber; no navd type: the connection's role says it
    line = json.dumps({"op": "publish", "topic": topic, "msg": msg}, allow_nan=True)
    return line.encode()


@pytest.mark.parametrize(
    ("role", "topic", "message", "kind"),
    [
        ("lidar", "/scan", SCAN, LaserScan),
        ("imu", "/imu/data", IMU, Imu),
        ("gps", "/fix", FIX, GpsFix),
        ("wheel_odometry", "/odom", ODOMETRY, WheelOdometry),
    ],
)
def test_rosbridge_publish_lines_are_taken_for_each_kind(
    role: str, topic: str, message: dict[str, Any], kind: type
) -> None:
    untagged = {k: v for k, v in message.items() if k != "type"}
    frame = decode_sensor(role, _rosbridge(topic, untagged))
    assert isinstance(sensor_message(frame, "dev", 1.0, 1.0), kind)
    assert frame.stamp == _decode(role, {**untagged, "type": frame.type}).stamp


def test_rosbridge_writes_a_missing_range_as_bare_nan_and_infinity() -> None:
    msg = {k: v for k, v in SCAN.items() if k != "type"}
    line = _rosbridge("/scan", {**msg, "ranges": [1.0, math.nan, math.inf, 4.0]})
    assert b"NaN" in line and b"Infinity" in line
    scan = sensor_message(decode_sensor("lidar", line), "front", 1.0, 1.0)
    assert isinstance(scan, LaserScan)
    assert math.isnan(scan.ranges[1]) and math.isinf(scan.ranges[2])


@pytest.mark.parametrize(
    ("line", "named"),
    [
        (b'{"op": "subscribe", "topic": "/scan", "header": 1}', "op"),
        (b'{"op": "publish", "topic": "/scan", "msg": [1], "header": 1}', "msg"),
        (b'{"op": "publish", "msg": {"header": {}, "ranges": 5}}', "angle_min"),
        (b'{"op": "publish", "header": ', ""),
    ],
)
def test_a_bad_rosbridge_line_is_refused_naming_what(line: bytes, named: str) -> None:
    with pytest.raises(WireError) as caught:
        decode_sensor("lidar", line)
    assert caught.value.field.startswith(named)


def test_the_header_frame_id_is_kept_for_the_mount_check() -> None:
    assert _decode("lidar", SCAN).frame_id == "laser"
    assert _decode("imu", IMU).frame_id == "imu_link"
    assert _decode("lidar", {**SCAN, "header": {"stamp": HEADER["stamp"]}}).frame_id is None

from __future__ import annotations

import base64
import json
import math
from typing import Any

import numpy as np
import pytest

from navd.drivers import sensor_message
from navd.lifecycle import control_message
from navd.lifecycle.messages import (
    BeaconObservation,
    CompassHeading,
    ConfigChange,
    DeviceKind,
    GeoGoal,
    Goal,
    GpsFix,
    Imu,
    LaserScan,
    WheelOdometry,
)
from navd.wire import (
    SENSOR_FRAMES,
    TAGS,
    Ack,
    ClockAck,
    ClockRequest,
    ControlRequest,
    ErrorFrame,
    GoalStatusFrame,
    Hello,
    PathFrame,
    Reply,
    Welcome,
    WireError,
    decode_control,
    decode_hello,
    decode_reply,
    decode_sensor,
    encode,
)


def line(**frame: object) -> bytes:
    return json.dumps(frame).encode()


SCAN = dict(
    type="scan",
    stamp=1.0,
    angle_min=-1.0,
    angle_increment=0.5,
    range_min=0.1,
    range_max=5.0,
    ranges=[1.0, None, 3.0],
)


@pytest.mark.parametrize(
    ("raw", "field", "reason"),
    [
        (
            line(type="hello", protocol=2, role="lidar", device_id="l"),
            "protocol",
            "version 2 is not supported",
        ),
        (line(type="hello", protocol=1, role="toaster", device_id="l"), "role", "Input should be"),
        (line(type="hello", protocol=1, role="chassis", device_id="l"), "role", "Input should be"),
        (
            line(type="hello", protocol=1, role="imu", device_id="has space"),
            "device_id",
            "should match pattern",
        ),
        (line(type="hello", protocol=1, role="imu"), "device_id", "Field required"),
        (line(type="hello", protocol="1", role="imu", device_id="i"), "protocol", "valid integer"),
        (b"[1, 2]", "", "a frame must be a JSON object"),
        (b'{"type": "hel', "", "not valid JSON"),
        (line(protocol=1, role="imu", device_id="i"), "type", "missing; every frame has"),
        (line(type="hello", role="imu", device_id="i"), "protocol", "Field required"),
    ],
)
def test_bad_hello_names_the_field(raw: bytes, field: str, reason: str) -> None:
    with pytest.raises(WireError) as info:
        decode_hello(raw)
    assert info.value.field == field
    assert reason in info.value.reason


def test_hello_with_token() -> None:
    hello = decode_hello(line(type="hello", protocol=1, role="gps", device_id="g1", token="s"))
    assert (hello.role, hello.device_id, hello.token) == ("gps", "g1", "s")


@pytest.mark.parametrize(
    ("role", "raw", "field", "reason"),
    [
        (DeviceKind.IMU, line(type="scan"), "type", "'scan' is not a frame a imu client sends"),
        (
            DeviceKind.IMU,
            line(type="imu", angular_velocity=[0, 0], linear_acceleration=[0, 0, 9]),
            "angular_velocity.2",
            "Field required",
        ),
        (
            DeviceKind.IMU,
            b'{"type":"imu","angular_velocity":[0,0,NaN],"linear_acceleration":[0,0,9]}',
            "angular_velocity.2",
            "finite number",
        ),
        (
            DeviceKind.IMU,
            line(type="imu", angular_velocity=[0, 0, 0], linear_acceleration=[0, 0, 9], extra=1),
            "extra",
            "unknown field",
        ),
        (
            DeviceKind.IMU,
            line(type="imu", stamp=-1, angular_velocity=[0, 0, 0], linear_acceleration=[0, 0, 9]),
            "stamp",
            "greater than or equal",
        ),
        (DeviceKind.LIDAR, line(**{**SCAN, "ranges": [1, "x"]}), "ranges.1", "valid number"),
        (
            DeviceKind.LIDAR,
            line(**{**SCAN, "angle_increment": 0}),
            "angle_increment",
            "must be non-zero",
        ),
        (
            DeviceKind.LIDAR,
            line(**{**SCAN, "range_max": 0.05}),
            "range_max",
            "must exceed range_min",
        ),
        (DeviceKind.LIDAR, line(**{**SCAN, "ranges_f32": "AAAA"}), "ranges", "exactly one"),
        (
            DeviceKind.GPS,
            line(type="fix", latitude=91, longitude=0, horizontal_accuracy=1),
            "latitude",
            "less than or equal to 90",
        ),
        (
            DeviceKind.COMPASS,
            line(type="heading", bearing_deg=360, accuracy_deg=1),
            "bearing_deg",
            "less than 360",
        ),
        (
            DeviceKind.WHEEL_ODOMETRY,
            line(type="odom", linear_x=True, angular_z=0),
            "linear_x",
            "valid number",
        ),
        (DeviceKind.BEACON, line(type="beacon", beacon="B1"), "", "range_m, bearing_rad or both"),
        (DeviceKind.BEACON, line(type="beacon", beacon="B 1", range_m=2.0), "beacon", "pattern"),
        (
            DeviceKind.BEACON,
            line(type="beacon", beacon="B1", range_m=-1.0),
            "range_m",
            "greater than or equal to 0",
        ),
        (
            DeviceKind.BEACON,
            line(type="beacon", beacon="B1", bearing_rad=0.1, bearing_std_rad=0),
            "bearing_std_rad",
            "greater than 0",
        ),
    ],
)
def test_bad_sensor_frames_name_the_field(
    role: DeviceKind, raw: bytes, field: str, reason: str
) -> None:
    with pytest.raises(WireError) as info:
        decode_sensor(role, raw)
    assert info.value.field == field
    assert reason in info.value.reason


def test_a_beacon_frame_becomes_an_observation_with_what_it_measured() -> None:
    frame = decode_sensor(DeviceKind.BEACON, line(type="beacon", beacon="B1", bearing_rad=4.0))
    seen = sensor_message(frame, "cam", 1.0, 1.0)
    assert isinstance(seen, BeaconObservation)
    assert seen.beacon_id == "B1" and not seen.has_range and seen.has_bearing
    assert seen.bearing_rad == pytest.approx(4.0 - 2 * math.pi)  # wrapped to (-pi, pi]


def test_scan_becomes_laser_scan_with_null_as_nan() -> None:
    frame = decode_sensor(DeviceKind.LIDAR, line(**SCAN))
    msg = sensor_message(frame, "lidar0", stamp=10.0, received=10.01)
    assert isinstance(msg, LaserScan)
    assert msg.device_id == "lidar0" and msg.stamp == 10.0
    np.testing.assert_array_equal(msg.ranges, np.array([1.0, np.nan, 3.0], dtype=np.float32))


def test_binary_ranges_decode_to_the_same_scan() -> None:
    ranges = np.array([0.5, 1.25, np.inf, 7.0], dtype="<f4")
    frame = decode_sensor(
        DeviceKind.LIDAR,
        line(**{**SCAN, "ranges": None, "ranges_f32": base64.b64encode(ranges.tobytes()).decode()}),
    )
    msg = sensor_message(frame, "l", 0.0, 0.0)
    assert isinstance(msg, LaserScan)
    np.testing.assert_array_equal(msg.ranges, ranges)


@pytest.mark.parametrize(
    ("payload", "reason"),
    [("not base64!", "not valid base64"), (base64.b64encode(b"12345").decode(), "float32")],
)
def test_bad_binary_ranges(payload: str, reason: str) -> None:
    frame = decode_sensor(DeviceKind.LIDAR, line(**{**SCAN, "ranges": None, "ranges_f32": payload}))
    with pytest.raises(WireError, match=reason):
        sensor_message(frame, "l", 0.0, 0.0)


def test_imu_magnetometer_tesla_becomes_microtesla() -> None:
    frame = decode_sensor(
        DeviceKind.IMU,
        line(
            type="imu",
            angular_velocity=[0.1, 0.2, 0.3],
            linear_acceleration=[0, 0, 9.81],
            magnetic_field=[2e-5, 0, -4e-5],
        ),
    )
    msg = sensor_message(frame, "imu0", 1.0, 1.0)
    assert isinstance(msg, Imu)
    assert msg.gyro_radps == (0.1, 0.2, 0.3)
    assert msg.mag_ut == pytest.approx((20.0, 0.0, -40.0))


def test_other_sensor_conversions() -> None:
    fix = sensor_message(
        decode_sensor(
            DeviceKind.GPS,
            line(type="fix", latitude=52.5, longitude=13.4, altitude=34.0, horizontal_accuracy=1.5),
        ),
        "g",
        1.0,
        1.0,
    )
    assert isinstance(fix, GpsFix) and fix.latitude_deg == 52.5 and fix.altitude_m == 34.0
    no_fix = decode_sensor(
        DeviceKind.GPS, line(type="fix", latitude=0, longitude=0, horizontal_accuracy=1, status=-1)
    )
    assert sensor_message(no_fix, "g", 1.0, 1.0) is None
    heading = sensor_message(
        decode_sensor(DeviceKind.COMPASS, line(type="heading", bearing_deg=90.0, accuracy_deg=2.0)),
        "c",
        1.0,
        1.0,
    )
    assert isinstance(heading, CompassHeading) and heading.bearing_deg == 90.0
    odom = sensor_message(
        decode_sensor(DeviceKind.WHEEL_ODOMETRY, line(type="odom", linear_x=0.3, angular_z=-0.1)),
        "w",
        1.0,
        1.0,
    )
    assert isinstance(odom, WheelOdometry) and odom.angular_radps == -0.1


@pytest.mark.parametrize(
    ("raw", "field", "reason"),
    [
        (line(type="goal", x=1.0), "x", "give either x and y"),
        (line(type="goal", x=1, y=2, latitude=3, longitude=4), "x", "give either x and y"),
        (line(type="goal", x=1, y=True), "y", "valid number"),
        (line(type="config", changes={}), "changes", "at least 1 item"),
        (line(type="subscribe", rate_hz=500), "rate_hz", "less than or equal to 50"),
        (line(type="save_map", name="../etc/passwd"), "name", "should match pattern"),
        (line(type="scan"), "type", "is not a frame a control client sends"),
    ],
)
def test_bad_control_frames_name_the_field(raw: bytes, field: str, reason: str) -> None:
    with pytest.raises(WireError) as info:
        decode_control(raw)
    assert info.value.field == field
    assert reason in info.value.reason


def test_control_frames_become_messages() -> None:
    goal = control_message(decode_control(line(type="goal", x=1, y=2, yaw=0.5)), "ui", 3.0, 7)
    assert isinstance(goal, Goal) and (goal.goal_id, goal.x_m, goal.yaw_rad) == ("ui-7", 1.0, 0.5)
    geo = control_message(
        decode_control(line(type="goal", goal_id="g", latitude=52.0, longitude=13.0)), "ui", 3.0, 8
    )
    assert isinstance(geo, GeoGoal) and geo.goal_id == "g" and geo.yaw_rad is None
    change = control_message(decode_control(line(type="config", changes={"a.b": 1})), "ui", 3.0, 9)
    assert isinstance(change, ConfigChange)
    assert (change.request_id, change.source, dict(change.changes)) == ("ui-9", "ui", {"a.b": 1})


def test_encode_writes_nan_as_null_on_one_line() -> None:
    data = encode(GoalStatusFrame(goal_id="g", state="active", eta_s=math.nan))
    assert data.endswith(b"\n") and data.count(b"\n") == 1
    assert json.loads(data)["eta_s"] is None


def test_an_ack_leaves_out_what_its_request_does_not_have() -> None:
    assert json.loads(encode(Ack(request="cancel"))) == {"type": "ack", "request": "cancel"}
    assert json.loads(encode(ClockAck(time=1.0, sent={}))) == {
        "type": "clock_ack",
        "time": 1.0,
        "sent": {},
    }


def test_a_hello_built_in_python_says_its_tag_and_version_on_the_wire() -> None:
    raw = encode(Hello(role="imu", device_id="imu0"))
    assert json.loads(raw) == {"type": "hello", "protocol": 1, "role": "imu", "device_id": "imu0"}
    assert decode_hello(raw) == Hello(role="imu", device_id="imu0")


def test_the_tag_table_holds_every_frame_a_client_sends() -> None:
    models = [Hello, *ControlRequest.__args__, *ClockRequest.__args__, *SENSOR_FRAMES.values()]
    tags = {m.model_fields["type"].default for m in models}
    assert tags == TAGS
    assert len(tags) == len(set(models))  # no two frames share a tag


@pytest.mark.parametrize(
    "reply",
    [
        Welcome(protocol=1, daemon="navd x", device_id="a", role="imu", max_line_bytes=9),
        ErrorFrame(field="ranges.3", reason="bad", fatal=True),
        Ack(request="goal", goal_id="g"),
        ClockAck(time=2.5, sent={"chassis": 4}, missing={"imu0": 1}),
        PathFrame(goal_id="g", points=[(0.0, 1.0), (2.0, 3.0)]),
    ],
)
def test_replies_read_back_as_they_were_sent(reply: Reply) -> None:
    assert decode_reply(encode(reply)) == reply


def test_a_reply_with_fields_from_a_newer_daemon_is_still_read() -> None:
    reply = decode_reply(b'{"type":"ack","request":"goal","goal_id":"g","later":1}')
    assert reply == Ack(request="goal", goal_id="g")


def test_crlf_line_endings_are_accepted() -> None:
    frame = decode_sensor(
        DeviceKind.COMPASS, b'{"type":"heading","bearing_deg":1,"accuracy_deg":1}\r'
    )
    assert frame.bearing_deg == 1.0


DEEP = b"[" * 100_000 + b"]" * 100_000


@pytest.mark.parametrize(
    ("decode", "line"),
    [
        (
            lambda line: decode_sensor("imu", line),
            b'{"type": "imu", "stamp": 1, "x": ' + DEEP + b"}",
        ),
        (lambda line: decode_sensor("imu", line), b'{"op": "publish", "msg": ' + DEEP + b"}"),
        (decode_control, b'{"type": "goal", "x": ' + DEEP + b"}"),
    ],
    ids=["sensor", "rosbridge", "control"],
)
def test_a_line_nested_thousands_deep_is_refused_as_bad_json(decode: Any, line: bytes) -> None:
    with pytest.raises(WireError, match="JSON"):
        decode(line)

"""Recorded messages read back equal to what was written, for every recorded type."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navd.lifecycle.messages import (
    CancelGoal,
    CompassHeading,
    ConfigChange,
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DriveCommand,
    GoalStatus,
    Imu,
    LaserScan,
    LocalizationState,
    LoopTicks,
    ManualCommand,
    MapUpdate,
    Message,
    MissionStatus,
    Path,
    PoseEstimate,
    SaveMapRequest,
    SetUpDone,
    Vector3,
    WorkerJob,
)
from navd.viz.record_codec import INFO, INPUTS, OUTPUTS, RecordCodecError, decode, encode, topic_of

T = {"stamp": 12.5, "received": 12.51}
SAMPLES: list[Message] = [
    LaserScan(
        **T,
        device_id="front",
        angle_min=-math.pi,
        angle_increment=0.0174,
        ranges=np.array([1.0, np.nan, np.inf, 3.25], dtype=np.float32),
        range_min=0.1,
        range_max=12.0,
    ),
    Imu(
        **T,
        device_id="imu",
        gyro_radps=Vector3(0.1, -0.2, 0.3),
        accel_mps2=Vector3(0.0, 0.1, 9.81),
        mag_ut=None,
    ),
    CompassHeading(**T, device_id="c", bearing_deg=271.5, accuracy_deg=3.0, true_north=True),
    DeviceConnected(**T, device_id="front", kind=DeviceKind.LIDAR),
    DeviceLost(**T, device_id="front", kind=DeviceKind.LIDAR, reason="client disconnected"),
    CancelGoal(**T, goal_id=None),
    ManualCommand(**T, linear_mps=0.2, angular_radps=-0.4, operator="pad"),
    SaveMapRequest(**T, name="lab"),
    ConfigChange(
        **T,
        request_id="r1",
        changes={
            "planning.goal_weight": 2.0,
            "planning.keep_out_zones": [[[0, 0], [1, 0], [1, 1]]],
        },
        source="ui",
    ),
    PoseEstimate(
        **T,
        x_m=1.0,
        y_m=-2.0,
        yaw_rad=0.3,
        covariance=np.diag([0.01, 0.02, 0.003]),
        linear_mps=0.25,
    ),
    LocalizationState(
        **T, state="ok", position_std_m=0.02, yaw_std_rad=0.01, counters={"late_events": 3}
    ),
    Path(**T, goal_id="g", points_m=np.array([[0.0, 0.0], [1.5, 0.25]])),
    DriveCommand(**T, linear_mps=0.2, angular_radps=0.0, reason=""),
    GoalStatus(**T, goal_id="g", state="active"),  # NaN distance and ETA
    MapUpdate(
        **T,
        revision=3,
        resolution_m=0.05,
        origin_x_m=-1.0,
        origin_y_m=-2.0,
        occupancy=np.array([[-1, 0], [100, 55]], dtype=np.int8),
    ),
    WorkerJob(**T, slot="scan_match", submitted_s=12.3, started_s=12.31, finished_s=12.5),
    WorkerJob(**T, slot="local_plan", submitted_s=12.4, outcome="dropped"),  # NaN times
    LoopTicks(**T, loop="planner.control", times_s=(11.5, 11.55, 11.61)),
    SetUpDone(**T, name="estimation-setup"),
]


def _same(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray):
        return (
            isinstance(b, np.ndarray)
            and a.dtype == b.dtype
            and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        )
    if isinstance(a, float) and math.isnan(a):
        return isinstance(b, float) and math.isnan(b)
    return a == b


@pytest.mark.parametrize("message", SAMPLES, ids=lambda m: type(m).__name__)
def test_a_message_reads_back_equal(message: Message) -> None:
    topic = topic_of(type(message))
    assert topic is not None
    back = decode(topic, encode(message))
    assert type(back) is type(message)
    for f in dataclasses.fields(message):
        assert _same(getattr(message, f.name), getattr(back, f.name)), f.name
    assert dict(getattr(back, "changes", {})) == dict(getattr(message, "changes", {}))


def test_the_json_is_plain_json_foxglove_can_show() -> None:
    import json

    for message in SAMPLES:
        json.loads(encode(message), parse_constant=lambda c: pytest.fail(f"{c} in JSON"))


def test_inputs_outputs_and_info_are_on_their_own_topics() -> None:
    assert {topic_of(k) for k in INPUTS} == {f"/navd/in/{k.__name__}" for k in INPUTS}
    assert {topic_of(k) for k in OUTPUTS} == {f"/navd/out/{k.__name__}" for k in OUTPUTS}
    assert {topic_of(k) for k in INFO} == {f"/navd/info/{k.__name__}" for k in INFO}


@pytest.mark.parametrize(
    ("topic", "data", "named"),
    [
        ("/navd/in/Teleporter", b"{}", "not a topic navd records"),
        ("/navd/in/ManualCommand", b"{not json", "not a ManualCommand"),
        ("/navd/in/ManualCommand", b'{"stamp": 1.0}', "not a ManualCommand"),
    ],
)
def test_what_cannot_be_read_back_is_named(topic: str, data: bytes, named: str) -> None:
    with pytest.raises(RecordCodecError, match=named):
        decode(topic, data)


def test_a_mission_status_recorded_before_its_progress_was_nested_reads_back() -> None:
    # As recordings of November 2026 hold it: the progress's fields beside the stamps, an
    # unknown distance as "NaN".
    flat = (
        b'{"stamp":3.0,"received":3.0,"mission_id":"m1","name":"patrol","state":"running",'
        b'"step":2,"steps":4,"round":1,"rounds":1,"kind":"goto","event":"progress",'
        b'"distance_m":"NaN","eta_s":7.5,"message":"","reason":"","done":1,"failed":0}'
    )
    status = decode("/navd/info/MissionStatus", flat)
    assert isinstance(status, MissionStatus)
    assert (status.stamp, status.info.mission_id, status.info.step) == (3.0, "m1", 2)
    assert status.info.distance_m is None and status.info.eta_s == 7.5

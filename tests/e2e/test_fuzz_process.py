"""Property test: malformed input never hurts the daemon or another client.

At least 10,000 lines, each invalid by construction (garbage, broken JSON, frames with one
field removed, retyped, pushed out of range or renamed, frames of the wrong role, lines over
the size limit), are thrown at the real daemon process over real sockets. Every one must be
answered with exactly one error frame, the daemon must stay up, and a well-behaved IMU
streaming on another connection all the while must see every frame accepted. Control frames
include goals, initial poses and map saves pushed past their bounds (coordinates, headings,
uncertainties, map names that leave the map folder). A flood of connections that never say
hello must never keep an authenticated client out.
"""

from __future__ import annotations

import contextlib
import json
import socket
import threading
import time
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navd.wire import (
    Client,
    ErrorFrame,
    FixFrame,
    Frame,
    GoalFrame,
    HeadingFrame,
    ImuFrame,
    InitialPoseFrame,
    PingFrame,
    Pong,
    SaveMapFrame,
    ScanFrame,
    StatusFrame,
    SubscribeFrame,
)
from tests.e2e.test_tcp_process import IMU, Streamer, devices

pytestmark = pytest.mark.e2e

MAX_LINE = 4096
EXAMPLES = 200
LINES_PER_EXAMPLE = (50, 60)

NUMBER_WRONG = ["str", {"a": 1}, True, [1.0]]
VEC3_WRONG = ["str", [1.0, 2.0], [1.0, 2.0, 3.0, 4.0], ["a", "b", "c"], {"x": 1}]
LIST_WRONG = ["str", {"a": 1}, 5, ["x"]]
STRING_WRONG = [5, 1.5, ["x"], {"a": "b"}]


def _valid(frame: Frame) -> dict[str, Any]:
    """A valid frame as the JSON object it is sent as (the fuzzer mutates it)."""
    return frame.model_dump(mode="json", exclude_none=True)


# role -> (a valid frame, {field: wrong values}, required fields, {field: out-of-range values})
TEMPLATES: dict[str, tuple[dict[str, Any], dict[str, list[Any]], list[str], dict[str, list[Any]]]]
TEMPLATES = {
    "lidar": (
        _valid(
            ScanFrame(
                stamp=1.0,
                angle_min=-1.0,
                angle_increment=0.1,
                range_min=0.1,
                range_max=5.0,
                ranges=[1.0, 2.0],
            )
        ),
        {
            "angle_min": NUMBER_WRONG,
            "angle_increment": NUMBER_WRONG,
            "range_min": NUMBER_WRONG,
            "range_max": NUMBER_WRONG,
            "stamp": NUMBER_WRONG,
            "ranges": LIST_WRONG,
        },
        ["angle_min", "angle_increment", "range_min", "range_max"],
        {"range_min": [-1.0], "angle_increment": [0.0], "range_max": [0.05], "stamp": [-5.0]},
    ),
    "imu": (
        _valid(ImuFrame(stamp=None, angular_velocity=(0, 0, 0), linear_acceleration=(0, 0, 9.8))),
        {"angular_velocity": VEC3_WRONG, "linear_acceleration": VEC3_WRONG, "stamp": NUMBER_WRONG},
        ["angular_velocity", "linear_acceleration"],
        {"stamp": [-1.0]},
    ),
    "gps": (
        _valid(FixFrame(stamp=None, latitude=52.0, longitude=13.0, horizontal_accuracy=2.0)),
        {
            "latitude": NUMBER_WRONG,
            "longitude": NUMBER_WRONG,
            "altitude": NUMBER_WRONG,
            "horizontal_accuracy": NUMBER_WRONG,
            "status": [1.5, "1", True],
        },
        ["latitude", "longitude", "horizontal_accuracy"],
        {
            "latitude": [90.5, -91.0],
            "longitude": [180.5],
            "horizontal_accuracy": [0.0, -1.0],
            "status": [3, -2],
        },
    ),
    "compass": (
        _valid(HeadingFrame(stamp=None, bearing_deg=10.0, accuracy_deg=2.0)),
        {
            "bearing_deg": NUMBER_WRONG,
            "accuracy_deg": NUMBER_WRONG,
            "true_north": ["yes", 1, [True]],
        },
        ["bearing_deg", "accuracy_deg"],
        {"bearing_deg": [360.0, -0.1], "accuracy_deg": [0.0, 181.0]},
    ),
    "control": (
        _valid(GoalFrame(x=1.0, y=2.0, yaw=0.5)),
        {"x": NUMBER_WRONG, "y": NUMBER_WRONG, "yaw": NUMBER_WRONG, "goal_id": STRING_WRONG},
        ["x", "y"],
        {
            "goal_id": ["has space", "x" * 65],
            "x": [1e7, -2e6, 1e300],
            "y": [1e6 + 1, -1e300],
            "yaw": [13.0, -100.0],
        },
    ),
    "control:initial_pose": (
        _valid(InitialPoseFrame(x=1.0, y=2.0, yaw=0.5)),
        {
            "x": NUMBER_WRONG,
            "y": NUMBER_WRONG,
            "yaw": NUMBER_WRONG,
            "std_xy": NUMBER_WRONG,
            "std_yaw": NUMBER_WRONG,
        },
        ["x", "y", "yaw"],
        {
            "x": [1e300, -1e7],
            "y": [2e6],
            "yaw": [13.0, -1e9],
            "std_xy": [0.0, -1.0, 1e4],
            "std_yaw": [0.0, 11.0],
        },
    ),
    "control:save_map": (
        _valid(SaveMapFrame(name="lab")),
        {"name": STRING_WRONG},
        [],
        {"name": ["../x", "/etc/passwd", ".hidden", "a/b", "x" * 65]},
    ),
}
OTHER_TYPES = ["hello", "scan", "imu", "fix", "heading", "odom", "goal", "status", "welcome", ""]


def _is_bad_json(data: bytes) -> bool:
    if not data.strip():
        return False  # blank lines are allowed
    try:
        return not isinstance(json.loads(data), dict)
    except (ValueError, UnicodeDecodeError):
        return True


@st.composite
def bad_line(draw: st.DrawFn, template: str) -> bytes:
    frame, wrong, required, out_of_range = TEMPLATES[template]
    kinds = ["garbage", "bytes", "drop", "retype", "range", "extra", "role", "nan", "huge"]
    if not required:  # nothing to leave out, no number to spoil
        kinds = [k for k in kinds if k not in ("drop", "nan")]
    kind = draw(st.sampled_from(kinds))
    if kind == "garbage":
        text = draw(
            st.text(
                st.characters(codec="utf-8", exclude_characters="\n\r"), min_size=1, max_size=120
            )
        )
        data = text.encode()
        return data if _is_bad_json(data) else b"{" + data
    if kind == "bytes":
        data = draw(st.binary(min_size=1, max_size=120)).replace(b"\n", b"").replace(b"\r", b"")
        return data if _is_bad_json(data) else b"[" + data
    mutated = dict(frame)
    if kind == "drop":
        del mutated[draw(st.sampled_from(required))]
    elif kind == "retype":
        key = draw(st.sampled_from(sorted(wrong)))
        mutated[key] = draw(st.sampled_from(wrong[key]))
    elif kind == "range":
        key = draw(st.sampled_from(sorted(out_of_range)))
        mutated[key] = draw(st.sampled_from(out_of_range[key]))
    elif kind == "extra":
        mutated[draw(st.sampled_from(["speed", "x_m", "Type", "ranges2", "extra"]))] = 1
    elif kind == "role":
        mutated["type"] = draw(st.sampled_from([t for t in OTHER_TYPES if t != frame["type"]]))
    elif kind == "nan":
        key = draw(st.sampled_from([k for k in required if k not in ("ranges",)]))
        token = draw(st.sampled_from(["NaN", "Infinity", "-Infinity"]))
        return json.dumps({**mutated, key: "@@"}).replace('"@@"', token).encode()
    elif kind == "huge":
        return json.dumps(mutated).encode() + b" " * (MAX_LINE + 1)
    return json.dumps(mutated).encode()


def test_malformed_lines_are_answered_and_harm_nobody(daemon_on_port: Any) -> None:
    daemon, port = daemon_on_port(f"max_line_bytes = {MAX_LINE}\nimu_timeout_s = 60.0\n")
    good = Streamer(port, "imu", "good-imu", IMU, rate_hz=500)
    good.start()
    thrown = 0

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(data=st.data())
    def throw(data: st.DataObject) -> None:
        nonlocal thrown
        template = data.draw(st.sampled_from(sorted(TEMPLATES)))
        role = template.split(":")[0]  # "control:initial_pose" is a control client's frame
        lines = data.draw(
            st.lists(
                bad_line(template), min_size=LINES_PER_EXAMPLE[0], max_size=LINES_PER_EXAMPLE[1]
            )
        )
        # a fresh id each time: the last example's connection may not have been seen to
        # close yet, and a sensor's id stays with its connection until it has
        with Client("127.0.0.1", port, role=role, device_id=f"fuzz-{role}-{thrown}") as client:
            client.send_raw(b"".join(line + b"\n" for line in lines))
            client.send(PingFrame(id="sync"))
            errors = []
            while (frame := client.receive()) != Pong(id="sync"):
                errors.append(frame)
        assert len(errors) == len(lines)
        for frame, line in zip(errors, lines, strict=True):
            assert isinstance(frame, ErrorFrame), (line, frame)
            assert frame.reason and not frame.fatal, (line, frame)
        thrown += len(lines)

    throw()
    good.finish()
    assert thrown >= 10_000
    assert daemon.proc.poll() is None, "the daemon died"
    assert good.replies == [], "the well-behaved client got errors"
    listed = devices(port)
    assert listed["good-imu"].accepted == good.sent
    assert listed["good-imu"].rejected == 0
    time.sleep(0.1)


def test_a_flood_of_connections_that_never_say_hello_keeps_no_client_out(
    daemon_on_port: Any,
) -> None:
    daemon, port = daemon_on_port()
    halt = threading.Event()
    flood: list[socket.socket] = []

    def open_silently() -> None:
        while not halt.is_set():  # about 100 new connections a second, none saying hello
            with contextlib.suppress(OSError):
                flood.append(socket.create_connection(("127.0.0.1", port), timeout=1.0))
            time.sleep(0.01)

    flooder = threading.Thread(target=open_silently, daemon=True)
    flooder.start()
    try:
        time.sleep(0.5)  # far more silent connections than tcp.max_pending by now
        for i in range(11):
            with Client("127.0.0.1", port, device_id=f"status-{i}") as ui:
                ui.request(SubscribeFrame(rate_hz=10))
                assert isinstance(ui.receive_type(StatusFrame), StatusFrame)
            time.sleep(0.1)
    finally:
        halt.set()
        flooder.join(5.0)
        for sock in flood:
            sock.close()
    assert len(flood) > 100
    assert daemon.proc.poll() is None

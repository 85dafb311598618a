"""Commands from viewers: the ROS-shaped messages Foxglove's panels publish and navd's own
frames read as control requests; on a running view they reach the bus from loopback, and
beyond loopback only with the token."""

from __future__ import annotations

import asyncio
import json
import math
import socket
import urllib.request
from typing import Any

import pytest

from navd.config import NavdConfig
from navd.lifecycle.messages import CancelGoal, Goal, InitialPose, ManualCommand
from navd.viz.commands import MAX_COMMAND_BYTES, CommandRefusedError, read_command, viewer_request
from navd.viz.settings import VizSettings
from navd.wire import CancelFrame, EmergencyStopFrame, GoalFrame, InitialPoseFrame, TeleopFrame
from tests.drivers.conftest import record, until
from tests.viz.foxglove_client import FoxgloveClient
from tests.viz.test_node import viewed_daemon

TOKEN = "a-secret-of-sixteen-plus"


def _quaternion(yaw: float) -> dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def _pose_stamped(x: float, y: float, yaw: float) -> dict[str, Any]:
    return {
        "header": {"frame_id": "map", "stamp": {"sec": 1, "nsec": 0}},
        "pose": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": _quaternion(yaw)},
    }


def _read(topic: str, message: Any, tokens: tuple[str, ...] | None = None) -> Any:
    return read_command(topic, json.dumps(message).encode(), tokens)


def test_foxglove_panel_messages_read_as_control_requests() -> None:
    goal = _read("/goal_pose", _pose_stamped(1.5, -2.0, 0.7))
    assert isinstance(goal, GoalFrame)
    assert (goal.x, goal.y) == (1.5, -2.0) and goal.yaw == pytest.approx(0.7)
    assert _read("/move_base_simple/goal", _pose_stamped(1.0, 2.0, 0.0)).x == 1.0
    covariance = [0.0] * 36
    covariance[0], covariance[35] = 0.04, 0.01
    initial = _read(
        "/initialpose",
        {"header": {}, "pose": {**_pose_stamped(3.0, 4.0, -1.0), "covariance": covariance}},
    )
    assert isinstance(initial, InitialPoseFrame)
    assert (initial.x, initial.y) == (3.0, 4.0) and initial.yaw == pytest.approx(-1.0)
    assert (initial.std_xy, initial.std_yaw) == (pytest.approx(0.2), pytest.approx(0.1))
    twist = _read("/cmd_vel", {"linear": {"x": 0.2, "y": 0, "z": 0}, "angular": {"z": -0.5}})
    assert twist == TeleopFrame(linear_x=0.2, angular_z=-0.5)
    own = _read("/navd/command", {"type": "cancel", "goal_id": "g"})
    assert own == CancelFrame(goal_id="g")


@pytest.mark.parametrize(
    ("topic", "data", "named"),
    [
        ("/chatter", b"{}", "not a command topic"),
        ("/cmd_vel", b"{not json", "not JSON"),
        ("/cmd_vel", b"[1, 2]", "JSON object"),
        ("/cmd_vel", b'{"linear": {"x": 50}}', "linear_x"),
        ("/goal_pose", b'{"pose": {"orientation": {}}}', "not a /goal_pose message"),
        (
            "/navd/command",
            b'{"type": "config", "changes": {"safety.use_collisions": false}}',
            "not 'config'",
        ),
        ("/navd/command", b'{"type": "goal", "x": 1}', "latitude"),
        ("/cmd_vel", b" " * (MAX_COMMAND_BYTES + 1), "more than a command may be"),
        ("/navd/command", b"[" * 8000 + b"]" * 8000, "nested too deep"),
    ],
)
def test_bad_commands_are_refused_naming_what_is_wrong(topic: str, data: bytes, named: str) -> None:
    with pytest.raises(CommandRefusedError, match=named):
        read_command(topic, data, None)


def test_a_token_is_checked_when_one_is_needed() -> None:
    twist = {"linear": {"x": 0.1}, "angular": {"z": 0.0}}
    accepted = ("the-runs-own-token", TOKEN)
    with pytest.raises(CommandRefusedError, match="token"):
        _read("/cmd_vel", twist, accepted)
    with pytest.raises(CommandRefusedError, match="token"):
        _read("/cmd_vel", {**twist, "token": "wrong"}, accepted)
    for token in accepted:
        assert _read("/cmd_vel", {**twist, "token": token}, accepted) == TeleopFrame(
            linear_x=0.1, angular_z=0.0
        )


async def test_a_viewer_on_loopback_steers_through_the_bus_when_untokened_is_on() -> None:
    async with viewed_daemon(untokened_commands=True) as (daemon, node):
        assert node.port is not None
        goals, poses = record(daemon, Goal), record(daemon, InitialPose)
        drives, cancels = record(daemon, ManualCommand), record(daemon, CancelGoal)
        viewer = await FoxgloveClient.open(node.port)
        try:
            goal = await viewer.advertise("/goal_pose", "geometry_msgs/PoseStamped")
            pose = await viewer.advertise("/initialpose")
            cmd_vel = await viewer.advertise("/cmd_vel")
            own = await viewer.advertise("/navd/command")
            await viewer.publish(pose, {"pose": _pose_stamped(0.5, 0.5, 0.0)})
            await viewer.publish(goal, _pose_stamped(2.0, 1.0, 0.0))
            await viewer.publish(cmd_vel, {"linear": {"x": 0.3}, "angular": {"z": 0.1}})
            await viewer.publish(own, b"{broken")  # refused: the others go on
            await viewer.publish(own, {"type": "cancel"})
            await until(lambda: bool(cancels), timeout_s=5.0)
        finally:
            await viewer.close()
        assert [(g.x_m, g.y_m) for g in goals] == [(2.0, 1.0)]
        assert [(p.x_m, p.y_m) for p in poses] == [(0.5, 0.5)]
        assert [(d.linear_mps, d.angular_radps) for d in drives] == [(0.3, 0.1)]
        assert drives[0].operator.startswith("viewer-")
        assert node.refused == 1


async def test_on_loopback_a_command_needs_the_runs_token_from_the_page() -> None:
    """A web page from elsewhere open in a browser on the robot reaches the loopback
    WebSocket too: without the token the page server gives browsers on this machine, its
    commands are refused."""
    async with viewed_daemon() as (daemon, node):
        assert node.port is not None and node.page is not None
        drives = record(daemon, ManualCommand)
        url = f"http://127.0.0.1:{node.page.port}/config.json"
        config = json.loads(await asyncio.to_thread(_fetch, url))
        viewer = await FoxgloveClient.open(node.port)
        try:
            cmd_vel = await viewer.advertise("/cmd_vel")
            own = await viewer.advertise("/navd/command")
            await viewer.publish(cmd_vel, {"linear": {"x": 0.3}, "angular": {"z": 0.0}})
            await viewer.publish(own, {"type": "teleop", "linear_x": 0.3, "angular_z": 0.0})
            await until(lambda: node.refused == 2, timeout_s=5.0)
            assert not drives
            teleop = {"type": "teleop", "linear_x": 0.2, "angular_z": 0.0}
            await viewer.publish(own, {**teleop, "token": config["command_token"]})
            await until(lambda: bool(drives), timeout_s=5.0)
        finally:
            await viewer.close()
        assert drives[0].linear_mps == 0.2


def _fetch(url: str, host: str | None = None) -> bytes:
    request = urllib.request.Request(url, headers={"Host": host} if host else {})
    with urllib.request.urlopen(request, timeout=5) as answer:
        body: bytes = answer.read()
        return body


async def test_the_page_gives_its_token_only_to_a_browser_on_this_machine() -> None:
    async with viewed_daemon() as (_, node):
        assert node.page is not None
        url = f"http://127.0.0.1:{node.page.port}/config.json"
        local = json.loads(await asyncio.to_thread(_fetch, url))
        assert local["command_token"] == node.command_token
        # a site whose name resolves to 127.0.0.1 (DNS rebinding) does not get it
        rebound = json.loads(await asyncio.to_thread(_fetch, url, "evil.example.com:80"))
        assert "command_token" not in rebound and rebound["ws_port"] == node.port


def _address_beyond_loopback() -> str | None:
    """An address of this machine that is not loopback, if it has one."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("192.0.2.1", 9))  # no packet is sent: this only picks a route
            address = str(probe.getsockname()[0])
        except OSError:
            return None
    return None if address.startswith("127.") or address == "0.0.0.0" else address


async def test_beyond_loopback_a_viewer_without_the_token_cannot_steer() -> None:
    address = _address_beyond_loopback()
    if address is None:
        pytest.skip("this machine has no address beyond loopback to connect from")
    async with viewed_daemon(tcp={"token": TOKEN}, host="0.0.0.0", allow_remote=True) as (
        daemon,
        node,
    ):
        assert node.port is not None
        steering = [record(daemon, kind) for kind in (Goal, InitialPose, ManualCommand)]
        viewer = await FoxgloveClient.open(node.port, host=address)
        try:
            goal = await viewer.advertise("/goal_pose")
            own = await viewer.advertise("/navd/command")
            cmd_vel = await viewer.advertise("/cmd_vel")
            await viewer.publish(goal, _pose_stamped(2.0, 1.0, 0.0))
            await viewer.publish(own, {"type": "initial_pose", "x": 0.0, "y": 0.0, "yaw": 0.0})
            await viewer.publish(cmd_vel, {"linear": {"x": 0.3}, "angular": {"z": 0.0}})
            await until(lambda: node.refused == 3, timeout_s=5.0)
            await asyncio.sleep(0.1)
            assert not any(steering)
            # nor does the page hand this run's token to a browser on another machine
            assert node.page is not None
            url = f"http://{address}:{node.page.port}/config.json"
            assert "command_token" not in json.loads(await asyncio.to_thread(_fetch, url))
            # the same viewer with the token steers
            await viewer.publish(
                own, {"type": "teleop", "linear_x": 0.2, "angular_z": 0.0, "token": TOKEN}
            )
            await until(lambda: bool(steering[2]), timeout_s=5.0)
        finally:
            await viewer.close()
        assert steering[2][0].linear_mps == 0.2


async def test_a_view_beyond_loopback_without_a_token_is_read_only() -> None:
    async with viewed_daemon(host="0.0.0.0", allow_remote=True) as (daemon, node):
        assert node.port is not None
        goals = record(daemon, Goal)
        viewer = await FoxgloveClient.open(node.port)
        try:
            own = await viewer.advertise("/navd/command")
            await viewer.publish(own, {"type": "goal", "x": 1.0, "y": 0.0, "token": "anything"})
            await until(lambda: node.refused == 1, timeout_s=5.0)
        finally:
            await viewer.close()
        assert not goals


@pytest.mark.parametrize(
    ("config", "message", "named"),
    [
        ({"viz": {"commands": False}}, {"type": "cancel"}, "read-only"),
        (
            {"teleop": {"enabled": False}},
            {"type": "teleop", "linear_x": 0.1, "angular_z": 0.0, "token": "run-token"},
            "teleop.enabled is false",
        ),
        ({}, {"type": "cancel"}, "missing or wrong token"),
    ],
)
def test_the_views_rules_refuse_by_name(
    config: dict[str, Any], message: dict[str, Any], named: str
) -> None:
    settings = VizSettings.from_config(NavdConfig.model_validate(config))
    with pytest.raises(CommandRefusedError, match=named):
        viewer_request("/navd/command", json.dumps(message).encode(), settings, "run-token")
    if named == "missing or wrong token":  # the run's token lets it through
        frame = viewer_request(
            "/navd/command",
            json.dumps({**message, "token": "run-token"}).encode(),
            settings,
            "run-token",
        )
        assert frame == CancelFrame()


@pytest.mark.parametrize("config", [{}, {"viz": {"commands": False}}], ids=["default", "read-only"])
def test_an_emergency_stop_is_taken_without_a_token_its_release_is_not(
    config: dict[str, Any],
) -> None:
    settings = VizSettings.from_config(NavdConfig.model_validate(config))
    stop = json.dumps({"type": "estop", "token": "an-old-runs-token"}).encode()
    assert viewer_request("/navd/command", stop, settings, "run-token") == EmergencyStopFrame()
    release = json.dumps({"type": "estop", "engaged": False}).encode()
    with pytest.raises(CommandRefusedError, match=r"read-only|missing or wrong token"):
        viewer_request("/navd/command", release, settings, "run-token")

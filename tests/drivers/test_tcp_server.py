"""The TCP server in-process, on real sockets."""

from __future__ import annotations

import asyncio
import itertools
import json
from typing import Any

import pytest

from navd.drivers.tcp_server import TcpServer
from navd.lifecycle.messages import (
    CancelGoal,
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DeviceResumed,
    DeviceStale,
    Goal,
    GoalStatus,
    Imu,
    LaserScan,
)
from tests.drivers.conftest import AsyncClient, record, running_daemon, until

SCAN = {
    "type": "scan",
    "angle_min": -1.0,
    "angle_increment": 0.5,
    "range_min": 0.1,
    "range_max": 5.0,
    "ranges": [1.0, 2.0, None],
}
IMU = {"type": "imu", "angular_velocity": [0, 0, 0.1], "linear_acceleration": [0, 0, 9.81]}


async def test_sensor_frames_become_typed_messages_on_the_daemon_clock() -> None:
    async with running_daemon() as (daemon, port):
        scans = record(daemon, LaserScan)
        imus = record(daemon, Imu)
        lidar, welcome = await AsyncClient.hello(port, "lidar", "lidar0")
        assert welcome["type"] == "welcome" and welcome["protocol"] == 1
        imu, _ = await AsyncClient.hello(port, "imu", "imu0")
        for i in range(5):
            await lidar.send({**SCAN, "stamp": 5000.0 + 0.1 * i})
            await imu.send({**IMU, "stamp": 77.0 + 0.001 * i})
        await until(lambda: len(scans) == 5 and len(imus) == 5)
        assert {s.device_id for s in scans} == {"lidar0"}
        # client stamps (another clock) mapped onto the daemon clock, never after arrival
        assert all(s.stamp <= s.received for s in scans)
        gaps = [b.stamp - a.stamp for a, b in itertools.pairwise(scans)]
        assert all(g <= 0.1 + 1e-9 for g in gaps)
        await lidar.close()
        await imu.close()


async def test_hot_plug_is_published_and_the_device_list_follows() -> None:
    async with running_daemon() as (daemon, port):
        connected = record(daemon, DeviceConnected)
        lost = record(daemon, DeviceLost)
        control, _ = await AsyncClient.hello(port, "control", "ui")
        gps, _ = await AsyncClient.hello(port, "gps", "gps0")
        await control.send({"type": "subscribe", "rate_hz": 20})
        await control.recv_type("ack")

        async def devices() -> set[str]:
            frame = await control.recv_type("status")
            return {d["device_id"] for d in frame["devices"]}

        await until(lambda: len(connected) == 2)
        assert await devices() >= {"ui", "gps0"}
        await gps.close()
        await until(lambda: len(lost) == 1)
        assert (lost[0].device_id, lost[0].kind, lost[0].reason) == (
            "gps0",
            DeviceKind.GPS,
            "client disconnected",
        )
        status_devices = await devices()
        assert "gps0" not in status_devices
        gps, _ = await AsyncClient.hello(port, "gps", "gps0")
        await until(lambda: len(connected) == 3)
        assert "gps0" in await devices()
        await gps.close()
        await control.close()


async def test_same_device_id_replaces_the_old_session() -> None:
    async with running_daemon() as (daemon, port):
        lost = record(daemon, DeviceLost)
        scans = record(daemon, LaserScan)
        old, _ = await AsyncClient.hello(port, "lidar", "lidar0")
        new, welcome = await AsyncClient.hello(port, "lidar", "lidar0")
        assert welcome["type"] == "welcome"
        farewell = await old.recv()
        assert farewell["field"] == "device_id" and farewell["fatal"] is True
        assert (await old.recv())["type"] == "eof"
        await new.send(SCAN)
        await until(lambda: len(scans) == 1)
        assert [m.reason for m in lost] == ["replaced by a new connection"]
        (server,) = [m for m in daemon.manager.modules if isinstance(m, TcpServer)]
        assert list(server.sessions) == ["lidar0"]
        await new.close()


async def test_silent_device_goes_stale_and_resumes() -> None:
    async with running_daemon(tcp={"lidar_timeout_s": 0.1}) as (daemon, port):
        stale = record(daemon, DeviceStale)
        resumed = record(daemon, DeviceResumed)
        lidar, _ = await AsyncClient.hello(port, "lidar", "lidar0")
        await lidar.send(SCAN)
        await until(lambda: len(stale) == 1)
        assert stale[0].device_id == "lidar0" and stale[0].silent_s > 0.1
        await lidar.send(SCAN)
        await until(lambda: len(resumed) == 1)
        await lidar.close()


@pytest.mark.parametrize(
    ("token", "accepted"),
    [(None, False), ("wrong-token-wrong-token", False), ("the-right-secret-123", True)],
)
async def test_token_is_required_when_configured(token: str | None, accepted: bool) -> None:
    async with running_daemon(tcp={"token": "the-right-secret-123"}) as (_, port):
        client, answer = await AsyncClient.hello(port, "imu", "imu0", token=token)
        if accepted:
            assert answer["type"] == "welcome"
        else:
            assert (answer["type"], answer["field"], answer["fatal"]) == ("error", "token", True)
            assert (await client.recv())["type"] == "eof"
        await client.close()


async def test_server_full_refuses_with_a_reason() -> None:
    async with running_daemon(tcp={"max_clients": 2}) as (_, port):
        a, _ = await AsyncClient.hello(port, "imu", "a")
        b, _ = await AsyncClient.hello(port, "imu", "b")
        c = await AsyncClient.open(port)
        refusal = await c.recv()
        assert refusal["fatal"] and "server full: 2 clients" in refusal["reason"]
        for client in (a, b, c):
            await client.close()


async def test_handshake_deadline() -> None:
    async with running_daemon(tcp={"handshake_timeout_s": 0.1}) as (_, port):
        client = await AsyncClient.open(port)
        answer = await client.recv()
        assert answer["fatal"] and "no hello within 0.1 s" in answer["reason"]
        await client.close()


async def test_bad_frames_are_answered_and_the_session_goes_on() -> None:
    async with running_daemon(tcp={"max_line_bytes": 2048}) as (daemon, port):
        scans = record(daemon, LaserScan)
        lidar, _ = await AsyncClient.hello(port, "lidar", "lidar0")
        await lidar.send(b"{oops")
        assert (await lidar.recv())["reason"].startswith("not valid JSON")
        await lidar.send(b"x" * 5000)
        assert "longer than the limit of 2048 bytes" in (await lidar.recv())["reason"]
        await lidar.send(b"")  # blank lines are ignored
        await lidar.send({**SCAN, "ranges": "many"})
        assert (await lidar.recv())["field"] == "ranges"
        await lidar.send({"type": "ping", "id": 7})
        assert await lidar.recv() == {"type": "pong", "id": 7}
        await lidar.send(SCAN)
        await until(lambda: len(scans) == 1)
        await lidar.close()


async def test_control_requests_are_acknowledged_and_published() -> None:
    async with running_daemon() as (daemon, port):
        goals = record(daemon, Goal)
        cancels = record(daemon, CancelGoal)
        ui, _ = await AsyncClient.hello(port, "control", "ui")
        await ui.send({"type": "goal", "x": 1.5, "y": -2.0, "yaw": 0.5, "goal_id": "g1"})
        assert await ui.recv() == {"type": "ack", "request": "goal", "goal_id": "g1"}
        await ui.send({"type": "cancel"})
        assert (await ui.recv_type("ack"))["request"] == "cancel"  # after the planner's status
        await until(lambda: len(goals) == 1 and len(cancels) == 1)
        assert (goals[0].x_m, goals[0].y_m, goals[0].yaw_rad) == (1.5, -2.0, 0.5)

        await ui.send(
            {"type": "config", "request_id": "c1", "changes": {"safety.reaction_timeout_s": 0.3}}
        )
        assert (await ui.recv_type("ack"))["request_id"] == "c1"
        applied = await ui.recv_type("config_applied")
        assert applied["changed"] == ["safety.reaction_timeout_s"]
        assert daemon.config.safety.reaction_timeout_s == 0.3

        await ui.send({"type": "config", "request_id": "c2", "changes": {"tcp.port": 1}})
        rejected = await ui.recv_type("config_rejected")
        assert "tcp.port: cannot change while navd runs" in rejected["reason"]

        now = daemon.clock.now()
        daemon.bus.publish(
            GoalStatus(
                stamp=now, received=now, goal_id="g1", state="reached", distance_remaining_m=0.0
            )
        )
        progress = await ui.recv_type("goal_status")
        assert (progress["goal_id"], progress["state"], progress["eta_s"]) == (
            "g1",
            "reached",
            None,
        )
        await ui.close()


async def test_shutdown_tells_clients_and_closes() -> None:
    async with running_daemon() as (daemon, port):
        imu, _ = await AsyncClient.hello(port, "imu", "imu0")
        daemon.request_shutdown("test")
        goodbye = await imu.recv()
        assert goodbye["fatal"] and goodbye["reason"] == "daemon stopping"
        await asyncio.sleep(0)
        await imu.close()


async def test_good_and_bad_lines_in_one_write_are_answered_one_by_one() -> None:
    async with running_daemon() as (daemon, port):
        scans = record(daemon, LaserScan)
        lidar, _ = await AsyncClient.hello(port, "lidar", "lidar0")
        halves = [
            b'{"type":"scan","angle_min":0,"angle_increment":0.1',
            b'"range_min":0,"range_max":5,"ranges":[1]}',
        ]
        lidar.writer.write(
            b"\n".join(
                [
                    json.dumps({**SCAN, "stamp": 1.0}).encode(),
                    halves[0],  # two halves of a frame are two bad lines, never one good frame
                    halves[1],
                    json.dumps({**SCAN, "ranges": ["x"]}).encode(),
                    json.dumps({**SCAN, "stamp": 1.1}).encode(),
                    b'{"type":"ping","id":1}',
                ]
            )
            + b"\n"
        )
        answers = [await lidar.recv() for _ in range(4)]
        assert [a["type"] for a in answers] == ["error", "error", "error", "pong"]
        assert answers[2]["field"] == "ranges.0"
        await until(lambda: len(scans) == 2)
        assert [s.ranges.size for s in scans] == [3, 3]
        await lidar.close()


async def test_status_mode_follows_safety_and_goal_progress() -> None:
    from navd.lifecycle.messages import SafetyState

    async def status_where(client: AsyncClient, predicate: Any) -> dict[str, Any]:
        """The first status frame meeting ``predicate`` (frames already in flight are older)."""
        while True:
            status = await client.recv_type("status")
            if predicate(status):
                return status

    async with running_daemon() as (daemon, port):
        ui, _ = await AsyncClient.hello(port, "control", "ui")
        await ui.send({"type": "goal", "x": 1.0, "y": 1.0, "goal_id": "g1"})
        await ui.recv_type("ack")
        await ui.send({"type": "subscribe", "rate_hz": 50})
        await ui.recv_type("ack")
        status = await ui.recv_type("status")
        # The goal is pending until the planner takes it up (at once: it answers "active").
        assert status["goal"]["goal_id"] == "g1"
        assert (status["mode"], status["goal"]["state"]) in (
            ("idle", "pending"),
            ("navigating", "active"),
        )
        now = daemon.clock.now()
        daemon.bus.publish(
            GoalStatus(
                stamp=now,
                received=now,
                goal_id="g1",
                state="active",
                distance_remaining_m=1.4,
                eta_s=3.0,
            )
        )
        status = await asyncio.wait_for(
            status_where(ui, lambda s: s["goal"]["distance_remaining"] == 1.4), 3.0
        )
        assert (status["mode"], status["goal"]["distance_remaining"]) == ("navigating", 1.4)
        daemon.bus.publish(SafetyState(stamp=now, received=now, reasons=("lidar gone",)))
        status = await asyncio.wait_for(status_where(ui, lambda s: s["diagnostics"]["safety"]), 3.0)
        assert status["mode"] == "stopped" and status["diagnostics"]["safety"] == ["lidar gone"]
        await ui.close()

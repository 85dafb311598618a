"""The TCP server in-process, on real sockets."""

from __future__ import annotations

import asyncio
import itertools
import json
import socket
from typing import Any

import numpy as np
import pytest

from navd.drivers.tcp.server import TcpServer
from navd.lifecycle.messages import (
    CancelGoal,
    CompassHeading,
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DeviceResumed,
    DeviceStale,
    Goal,
    GoalStatus,
    GpsFix,
    Imu,
    InitialPose,
    LaserScan,
    MapUpdate,
    RangeReading,
)
from navd.wire import (
    Ack,
    AsyncClient,
    BatteryFrame,
    CancelFrame,
    ConfigAppliedFrame,
    ConfigFrame,
    ConfigRejectedFrame,
    ConnectionClosedError,
    ErrorFrame,
    FixFrame,
    GoalFrame,
    GoalStatusFrame,
    HeadingFrame,
    Hello,
    ImuFrame,
    InitialPoseFrame,
    PingFrame,
    Pong,
    RangeFrame,
    RequestRefusedError,
    SaveMapFrame,
    ScanFrame,
    StatusFrame,
    SubscribeFrame,
    Welcome,
    encode,
)
from tests.drivers.conftest import connected, hello, record, running_daemon, until

SCAN = ScanFrame(
    stamp=None,
    angle_min=-1.0,
    angle_increment=0.5,
    range_min=0.1,
    range_max=5.0,
    ranges=[1.0, 2.0, None],
)
IMU = ImuFrame(stamp=None, angular_velocity=(0, 0, 0.1), linear_acceleration=(0, 0, 9.81))


def broken(**fields: Any) -> bytes:
    """The scan frame's JSON line with ``fields`` replaced (what a faulty client sends)."""
    return json.dumps({**SCAN.model_dump(exclude_none=True), **fields}).encode() + b"\n"


async def test_sensor_frames_become_typed_messages_on_the_daemon_clock() -> None:
    async with running_daemon() as (daemon, port):
        scans = record(daemon, LaserScan)
        imus = record(daemon, Imu)
        lidar, welcome = await hello(port, "lidar", "lidar0")
        assert isinstance(welcome, Welcome) and welcome.protocol == 1
        imu = await connected(port, "imu", "imu0")
        for i in range(5):
            lidar.send(SCAN.model_copy(update={"stamp": 5000.0 + 0.1 * i}))
            imu.send(IMU.model_copy(update={"stamp": 77.0 + 0.001 * i}))
        await until(lambda: len(scans) == 5 and len(imus) == 5)
        assert {s.device_id for s in scans} == {"lidar0"}
        # client stamps (another clock) mapped onto the daemon clock, never after arrival
        assert all(s.stamp <= s.received for s in scans)
        gaps = [b.stamp - a.stamp for a, b in itertools.pairwise(scans)]
        assert all(g <= 0.1 + 1e-9 for g in gaps)
        await lidar.close()
        await imu.close()


async def test_a_dual_antenna_receiver_sends_its_heading_on_its_gps_connection() -> None:
    async with running_daemon() as (daemon, port):
        headings = record(daemon, CompassHeading)
        fixes = record(daemon, GpsFix)
        gps = await connected(port, "gps", "gnss0")
        gps.send(FixFrame(stamp=1.0, latitude=48.1, longitude=11.5, horizontal_accuracy=0.02))
        gps.send(HeadingFrame(stamp=1.0, bearing_deg=274.0, accuracy_deg=0.5, true_north=True))
        await until(lambda: len(headings) == 1 and len(fixes) == 1)
        (heading,) = headings
        assert heading.device_id == "gnss0" and heading.true_north
        assert heading.bearing_deg == 274.0
        await gps.close()


async def test_a_range_reading_without_its_mount_is_refused_naming_the_mount() -> None:
    async with running_daemon() as (daemon, port):
        readings = record(daemon, RangeReading)
        sonar = await connected(port, "range", "mcu0")
        sonar.send(
            RangeFrame(stamp=1.0, sensor="front", range=0.5, field_of_view=0.5, max_range=4.0)
        )
        refused = await sonar.receive(5.0)
        assert isinstance(refused, ErrorFrame) and refused.field == "sensor"
        assert "[mounts.ranges.front]" in refused.reason
        assert readings == []
        await sonar.close()


async def test_the_battery_shows_in_the_status_with_its_alarm() -> None:
    async with running_daemon() as (_, port):
        battery = await connected(port, "battery", "ina219-1")
        ui = await connected(port, "control", "ui")
        await ui.request(SubscribeFrame(rate_hz=20))
        battery.send(BatteryFrame(stamp=1.0, voltage=11.2, current=-2.0, percentage=0.15))

        async def status_battery() -> Any:
            while True:
                status = await ui.receive(5.0)
                battery = getattr(status, "battery", None)
                if isinstance(status, StatusFrame) and battery and battery.alarm == "low":
                    return battery

        shown = await asyncio.wait_for(status_battery(), 10.0)
        assert (shown.voltage, shown.current, shown.percentage) == (11.2, -2.0, 0.15)
        await battery.close()
        await ui.close()


async def test_hot_plug_is_published_and_the_device_list_follows() -> None:
    async with running_daemon() as (daemon, port):
        present = record(daemon, DeviceConnected)
        lost = record(daemon, DeviceLost)
        control = await connected(port, "control", "ui")
        gps = await connected(port, "gps", "gps0")
        await control.request(SubscribeFrame(rate_hz=20))

        async def devices() -> set[str]:
            frame = await control.receive_type(StatusFrame)
            return {d.device_id for d in frame.devices}

        await until(lambda: len(present) == 2)
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
        gps = await connected(port, "gps", "gps0")
        await until(lambda: len(present) == 3)
        assert "gps0" in await devices()
        await gps.close()
        await control.close()


async def test_a_device_id_stays_with_its_first_connection_until_it_falls_silent() -> None:
    async with running_daemon(tcp={"lidar_timeout_s": 0.3}) as (daemon, port):
        lost = record(daemon, DeviceLost)
        stale = record(daemon, DeviceStale)
        scans = record(daemon, LaserScan)
        old = await connected(port, "lidar", "lidar0")
        old.send(SCAN)
        # a second hello with the id of a sensor that speaks is refused; the sensor goes on
        intruder, refusal = await hello(port, "lidar", "lidar0")
        assert isinstance(refusal, ErrorFrame)
        assert (refusal.field, refusal.fatal) == ("device_id", True)
        assert "in use" in refusal.reason
        with pytest.raises(ConnectionClosedError):
            await intruder.receive()
        await intruder.close()
        old.send(SCAN)
        await until(lambda: len(scans) == 2)
        assert lost == []
        # once it has fallen silent, a new connection with its id takes over
        await until(lambda: len(stale) == 1)
        new, welcome = await hello(port, "lidar", "lidar0")
        assert isinstance(welcome, Welcome)
        farewell = await old.receive()
        assert isinstance(farewell, ErrorFrame)
        assert farewell.field == "device_id" and farewell.fatal is True
        with pytest.raises(ConnectionClosedError):
            await old.receive()
        new.send(SCAN)
        await until(lambda: len(scans) == 3)
        assert [m.reason for m in lost] == ["replaced by a new connection after going silent"]
        (server,) = [m for m in daemon.manager.modules if isinstance(m, TcpServer)]
        assert list(server.sessions) == ["lidar0"]
        await new.close()


async def test_an_id_cannot_change_its_kind() -> None:
    async with running_daemon(tcp={"imu_timeout_s": 0.1}) as (daemon, port):
        stale = record(daemon, DeviceStale)
        imu = await connected(port, "imu", "imu0")
        imu.send(IMU)
        await until(lambda: len(stale) == 1)  # silent: its id could go to a new connection,
        gps, refusal = await hello(port, "gps", "imu0")  # but only to another IMU
        assert isinstance(refusal, ErrorFrame) and refusal.field == "device_id"
        assert "a gps needs an id of its own" in refusal.reason
        for client in (imu, gps):
            await client.close()


async def test_a_control_clients_id_goes_to_its_newest_connection() -> None:
    # a user interface reconnecting over a link that died is not kept out by its old self
    async with running_daemon() as (_, port):
        old = await connected(port, "control", "tablet")
        new, welcome = await hello(port, "control", "tablet")
        assert isinstance(welcome, Welcome)
        farewell = await old.receive()
        assert isinstance(farewell, ErrorFrame) and farewell.field == "device_id"
        await old.close()
        await new.close()


async def test_a_slow_sensor_is_not_stale_between_its_own_frames() -> None:
    # a 4 Hz lidar against a 0.1 s timeout: its own period (x 1.25 + 50 ms) is what counts
    async with running_daemon(tcp={"lidar_timeout_s": 0.1}) as (daemon, port):
        stale = record(daemon, DeviceStale)
        scans = record(daemon, LaserScan)
        lidar = await connected(port, "lidar", "lidar0")
        for _ in range(8):
            lidar.send(SCAN)
            await asyncio.sleep(0.25)
        await until(lambda: len(scans) == 8)
        # the first gaps, before its period is known, may mark it stale; after them, never
        assert len(stale) <= 2
        settled = len(stale)
        for _ in range(4):
            lidar.send(SCAN)
            await asyncio.sleep(0.25)
        assert len(stale) == settled
        await until(lambda: len(stale) == settled + 1)  # and silence is still caught
        assert 0.3 < stale[-1].silent_s < 0.5
        await lidar.close()


async def test_silent_device_goes_stale_and_resumes() -> None:
    async with running_daemon(tcp={"lidar_timeout_s": 0.1}) as (daemon, port):
        stale = record(daemon, DeviceStale)
        resumed = record(daemon, DeviceResumed)
        lidar = await connected(port, "lidar", "lidar0")
        lidar.send(SCAN)
        await until(lambda: len(stale) == 1)
        assert stale[0].device_id == "lidar0" and stale[0].silent_s > 0.1
        lidar.send(SCAN)
        await until(lambda: len(resumed) == 1)
        await lidar.close()


@pytest.mark.parametrize(
    ("token", "accepted"),
    [(None, False), ("wrong-token-wrong-token", False), ("the-right-secret-123", True)],
)
async def test_token_is_required_when_configured(token: str | None, accepted: bool) -> None:
    async with running_daemon(tcp={"token": "the-right-secret-123"}) as (_, port):
        client, answer = await hello(port, "imu", "imu0", token=token)
        if accepted:
            assert isinstance(answer, Welcome)
        else:
            assert isinstance(answer, ErrorFrame)
            assert (answer.field, answer.fatal) == ("token", True)
            with pytest.raises(ConnectionClosedError):
                await client.receive()
        await client.close()


async def test_the_client_library_raises_the_refusal_with_its_reason() -> None:
    async with running_daemon(tcp={"token": "the-right-secret-123"}) as (_, port):
        with pytest.raises(RequestRefusedError, match="token: missing or wrong token") as info:
            await AsyncClient.connect("127.0.0.1", port, role="imu", device_id="imu0")
        assert info.value.error.fatal


async def test_server_full_refuses_with_a_reason() -> None:
    async with running_daemon(tcp={"max_clients": 2, "max_control_clients": 1}) as (_, port):
        a = await connected(port, "imu", "a")
        b = await connected(port, "imu", "b")
        c, refusal = await hello(port, "imu", "c")
        assert isinstance(refusal, ErrorFrame)
        assert refusal.fatal and "server full: 2 clients" in refusal.reason
        for client in (a, b, c):
            await client.close()


async def test_control_clients_cannot_take_the_slots_kept_for_sensors() -> None:
    async with running_daemon(tcp={"max_clients": 4, "max_control_clients": 2}) as (_, port):
        uis = [await connected(port, "control", f"ui{i}") for i in range(2)]
        extra, refusal = await hello(port, "control", "ui2")
        assert isinstance(refusal, ErrorFrame) and refusal.fatal
        assert "control clients full: 2" in refusal.reason
        imu, welcome = await hello(port, "imu", "imu0")  # a restarting IMU still gets in
        assert isinstance(welcome, Welcome)
        again, welcome = await hello(port, "control", "ui0")  # a UI reconnecting keeps its id
        assert isinstance(welcome, Welcome)
        for client in (*uis, extra, imu, again):
            await client.close()


async def test_connections_that_never_say_hello_never_keep_a_client_out() -> None:
    async with running_daemon(
        tcp={"max_clients": 2, "max_control_clients": 1, "max_pending": 3}
    ) as (daemon, port):
        silent = [await AsyncClient.open("127.0.0.1", port) for _ in range(10)]
        ui, welcome = await hello(port, "control", "ui")
        assert isinstance(welcome, Welcome)  # ten silent connections did not fill the slots
        # the oldest silent ones were closed with the reason (the client's own connection,
        # waiting for its hello for a moment, made one more go); the newest two still wait
        first = await silent[0].receive()
        assert isinstance(first, ErrorFrame) and first.fatal
        assert "tcp.max_pending" in first.reason
        (server,) = [m for m in daemon.manager.modules if isinstance(m, TcpServer)]
        await until(lambda: len(server.connections) == 2 + 1)
        for client in (*silent, ui):
            await client.close()


async def test_an_idle_control_client_is_closed_but_a_subscriber_or_a_pinger_stays() -> None:
    async with running_daemon(tcp={"control_idle_timeout_s": 1.0}) as (_, port):
        idle = await connected(port, "control", "idle")
        watcher = await connected(port, "control", "watcher")
        await watcher.request(SubscribeFrame(rate_hz=2))
        pinger = await connected(port, "control", "pinger")
        for i in range(4):
            await asyncio.sleep(0.4)
            pinger.send(PingFrame(id=i))
            assert await pinger.receive_type(Pong) == Pong(id=i)
        farewell = await idle.receive(1.0)
        assert isinstance(farewell, ErrorFrame) and farewell.fatal
        assert "tcp.control_idle_timeout_s" in farewell.reason
        assert isinstance(await watcher.receive_type(StatusFrame), StatusFrame)
        pinger.send(PingFrame(id=9))
        assert await pinger.receive_type(Pong) == Pong(id=9)
        for client in (idle, watcher, pinger):
            await client.close()


async def test_handshake_deadline() -> None:
    async with running_daemon(tcp={"handshake_timeout_s": 0.1}) as (_, port):
        client = await AsyncClient.open("127.0.0.1", port)
        answer = await client.receive()
        assert isinstance(answer, ErrorFrame)
        assert answer.fatal and "no hello within 0.1 s" in answer.reason
        await client.close()


async def test_bad_frames_are_answered_and_the_session_goes_on() -> None:
    async with running_daemon(tcp={"max_line_bytes": 2048}) as (daemon, port):
        scans = record(daemon, LaserScan)
        lidar = await connected(port, "lidar", "lidar0")
        lidar.send_raw(b"{oops\n")
        answer = await lidar.receive()
        assert isinstance(answer, ErrorFrame) and answer.reason.startswith("not valid JSON")
        lidar.send_raw(b"x" * 5000 + b"\n")
        answer = await lidar.receive()
        assert isinstance(answer, ErrorFrame)
        assert "longer than the limit of 2048 bytes" in answer.reason
        lidar.send_raw(b"\n")  # blank lines are ignored
        lidar.send_raw(broken(ranges="many"))
        answer = await lidar.receive()
        assert isinstance(answer, ErrorFrame) and answer.field == "ranges"
        lidar.send(PingFrame(id=7))
        assert await lidar.receive() == Pong(id=7)
        lidar.send(SCAN)
        await until(lambda: len(scans) == 1)
        await lidar.close()


async def test_control_requests_are_acknowledged_and_published() -> None:
    async with running_daemon() as (daemon, port):
        goals = record(daemon, Goal)
        cancels = record(daemon, CancelGoal)
        ui = await connected(port, "control", "ui")
        ui.send(GoalFrame(x=1.5, y=-2.0, yaw=0.5, goal_id="g1"))
        assert await ui.receive() == Ack(request="goal", goal_id="g1")
        assert (await ui.request(CancelFrame())).request == "cancel"  # after the goal status
        await until(lambda: len(goals) == 1 and len(cancels) == 1)
        assert (goals[0].x_m, goals[0].y_m, goals[0].yaw_rad) == (1.5, -2.0, 0.5)

        ack = await ui.request(ConfigFrame(request_id="c1", changes={"planning.goal_weight": 2.5}))
        assert ack.request_id == "c1"
        applied = await ui.receive_type(ConfigAppliedFrame)
        assert applied.changed == ["planning.goal_weight"]
        assert daemon.config.planning.goal_weight == 2.5

        ui.send(ConfigFrame(request_id="c2", changes={"planning.control_rate_hz": 500}))
        rejected = await ui.receive_type(ConfigRejectedFrame)
        assert "planning.control_rate_hz" in rejected.reason
        assert daemon.config.planning.control_rate_hz != 500

        now = daemon.clock.now()
        daemon.bus.publish(
            GoalStatus(
                stamp=now, received=now, goal_id="g1", state="reached", distance_remaining_m=0.0
            )
        )
        progress = await ui.receive_type(GoalStatusFrame)
        assert (progress.goal_id, progress.state, progress.eta_s) == ("g1", "reached", None)
        await ui.close()


async def test_shutdown_tells_clients_and_closes() -> None:
    async with running_daemon() as (daemon, port):
        imu = await connected(port, "imu", "imu0")
        daemon.request_shutdown("test")
        goodbye = await imu.receive()
        assert isinstance(goodbye, ErrorFrame)
        assert goodbye.fatal and goodbye.reason == "daemon stopping"
        await asyncio.sleep(0)
        await imu.close()


async def test_good_and_bad_lines_in_one_write_are_answered_one_by_one() -> None:
    async with running_daemon() as (daemon, port):
        scans = record(daemon, LaserScan)
        lidar = await connected(port, "lidar", "lidar0")
        halves = [
            b'{"type":"scan","angle_min":0,"angle_increment":0.1\n',
            b'"range_min":0,"range_max":5,"ranges":[1]}\n',
        ]
        lidar.send_raw(
            b"".join(
                [
                    encode(SCAN.model_copy(update={"stamp": 1.0})),
                    *halves,  # two halves of a frame are two bad lines, never one good frame
                    broken(ranges=["x"]),
                    encode(SCAN.model_copy(update={"stamp": 1.1})),
                    encode(PingFrame(id=1)),
                ]
            )
        )
        answers = [await lidar.receive() for _ in range(4)]
        assert [a.type for a in answers] == ["error", "error", "error", "pong"]
        assert isinstance(answers[2], ErrorFrame) and answers[2].field == "ranges.0"
        await until(lambda: len(scans) == 2)
        assert [s.ranges.size for s in scans] == [3, 3]
        await lidar.close()


async def test_status_mode_follows_safety_and_goal_progress() -> None:
    from navd.lifecycle.messages import SafetyState

    async def status_where(client: AsyncClient, predicate: Any) -> StatusFrame:
        """The first status frame meeting ``predicate`` (frames already in flight are older)."""
        while True:
            status = await client.receive_type(StatusFrame)
            if predicate(status):
                return status

    async with running_daemon(robot={"name": "rover-7"}) as (daemon, port):
        ui = await connected(port, "control", "ui")
        await ui.request(GoalFrame(x=1.0, y=1.0, goal_id="g1"))
        await ui.request(SubscribeFrame(rate_hz=50))
        status = await ui.receive_type(StatusFrame)
        assert status.robot == "rover-7"
        # The goal is pending until the planner takes it up (at once: it answers "active").
        assert status.goal is not None and status.goal.goal_id == "g1"
        assert (status.mode, status.goal.state) in (
            ("idle", "pending"),
            ("navigating", "active"),
        )
        status = await asyncio.wait_for(
            status_where(ui, lambda s: s.goal is not None and s.goal.state == "active"), 3.0
        )
        assert status.mode == "navigating"
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
            status_where(ui, lambda s: s.goal is not None and s.goal.distance_remaining == 1.4),
            3.0,
        )
        assert status.mode == "navigating"
        daemon.bus.publish(SafetyState(stamp=now, received=now, reasons=("lidar gone",)))
        status = await asyncio.wait_for(status_where(ui, lambda s: s.diagnostics.safety), 3.0)
        assert status.mode == "stopped" and status.diagnostics.safety == ["lidar gone"]
        await ui.close()


async def test_a_hello_and_data_in_one_write_are_both_taken() -> None:
    async with running_daemon() as (daemon, port):
        scans = record(daemon, LaserScan)
        lidar = await AsyncClient.open("127.0.0.1", port)
        lidar.send_raw(
            encode(Hello(role="lidar", device_id="lidar0"))
            + encode(SCAN.model_copy(update={"stamp": 1.0}))
            + b"{broken\n"
            + encode(PingFrame(id="after"))
        )
        assert isinstance(await lidar.receive(), Welcome)
        answer = await lidar.receive()
        assert isinstance(answer, ErrorFrame) and answer.reason.startswith("not valid JSON")
        assert await lidar.receive() == Pong(id="after")
        await until(lambda: len(scans) == 1)
        await lidar.close()


@pytest.mark.parametrize("granted", [False, True])
async def test_privileged_keys_need_the_config_to_grant_them(granted: bool) -> None:
    tcp = {"allow_privileged_changes": granted}
    async with running_daemon(tcp=tcp) as (daemon, port):
        ui = await connected(port, "control", "ui")
        for key, value in (
            ("safety.use_collisions", False),
            ("robot.max_linear_speed_mps", 1.0),
            ("chassis.invert_left", True),
            ("slam.map_name", "elsewhere"),
            # keys found changeable by anyone before privileges went by effect
            ("slam.lost_after_scans", 0),
            ("viz.untokened_commands", True),
            ("fleet.on_broker_lost", "continue"),
            ("planning.obstacle_persistence_s", 0.0),
            ("planning.inflation_radius_m", 0.0),
            ("estimation.lidar_gate_chi2", 1000.0),
        ):
            await ui.request(ConfigFrame(request_id=key, changes={key: value}))
            answer = await ui.receive_type(ConfigAppliedFrame | ConfigRejectedFrame)
            if granted:
                assert isinstance(answer, ConfigAppliedFrame), answer
            else:
                assert isinstance(answer, ConfigRejectedFrame)
                assert f"{key}: a privileged key" in answer.reason
                assert "tcp.allow_privileged_changes" in answer.reason
        assert daemon.config.safety.use_collisions is not granted
        await ui.close()


@pytest.mark.parametrize("name", ["../outside", "/etc/passwd", ".hidden", "a/b"])
async def test_a_map_name_cannot_leave_the_map_folder(name: str) -> None:
    async with running_daemon(tcp={"allow_privileged_changes": True}) as (_, port):
        ui = await connected(port, "control", "ui")
        with pytest.raises(RequestRefusedError, match="name"):
            await ui.request(SaveMapFrame(name="x").model_copy(update={"name": name}))
        await ui.request(ConfigFrame(request_id="n", changes={"slam.map_name": name}))
        answer = await ui.receive_type(ConfigAppliedFrame | ConfigRejectedFrame)
        assert isinstance(answer, ConfigRejectedFrame) and "slam.map_name" in answer.reason
        await ui.close()


async def test_an_initial_pose_far_out_or_off_the_map_is_refused_with_the_reason() -> None:
    async with running_daemon() as (daemon, port):
        poses = record(daemon, InitialPose)
        ui = await connected(port, "control", "ui")
        with pytest.raises(RequestRefusedError, match=r"x: Input should be less than or equal"):
            await ui.request(InitialPoseFrame(x=0, y=0, yaw=0).model_copy(update={"x": 1e300}))
        await ui.request(InitialPoseFrame(x=500.0, y=0.0, yaw=0.0))  # no map yet: it starts one
        now = daemon.clock.now()
        occupancy = np.zeros((100, 200), dtype=np.int8)  # 10 m x 5 m from (-1, -1)
        daemon.bus.publish(
            MapUpdate(
                stamp=now,
                received=now,
                revision=1,
                resolution_m=0.05,
                origin_x_m=-1.0,
                origin_y_m=-1.0,
                occupancy=occupancy,
            )
        )
        with pytest.raises(RequestRefusedError, match=r"lies 491 m outside the map \(x -1.0..9.0"):
            await ui.request(InitialPoseFrame(x=500.0, y=0.0, yaw=0.0))
        with pytest.raises(RequestRefusedError, match=r"y: \(0.0, -300.0\) m lies 299 m outside"):
            await ui.request(InitialPoseFrame(x=0.0, y=-300.0, yaw=0.0))
        await ui.request(InitialPoseFrame(x=12.0, y=-3.0, yaw=0.0))  # just off its edge: fine
        await until(lambda: len(poses) == 2)
        assert [(p.x_m, p.y_m) for p in poses] == [(500.0, 0.0), (12.0, -3.0)]
        await ui.close()


async def test_a_subscriber_that_never_reads_is_disconnected() -> None:
    tcp = {"slow_reader_timeout_s": 1.0, "status_queue": 1}
    async with running_daemon(tcp=tcp) as (daemon, port):
        lost = record(daemon, DeviceLost)
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # a small window: no slack
        sock.setblocking(False)
        await asyncio.get_running_loop().sock_connect(sock, ("127.0.0.1", port))
        sock.send(encode(Hello(role="control", device_id="deaf")))
        sock.send(encode(SubscribeFrame(rate_hz=50)))  # then never read a byte
        # its status frames pile up, are dropped for 1 s, then the connection is cut off
        await until(lambda: [m.device_id for m in lost] == ["deaf"], timeout_s=15.0)
        assert "does not read" in lost[0].reason
        sock.close()


@pytest.mark.parametrize(
    "filler", [b"\n", encode(PingFrame(id="beat")), b'{"type": "scan"}\n'], ids=str
)
async def test_a_sensor_sending_anything_but_data_still_goes_stale(filler: bytes) -> None:
    # a hung driver with a heartbeat thread: blank lines, pings or broken frames keep the
    # connection, never the sensor, alive
    async with running_daemon(tcp={"lidar_timeout_s": 0.2}) as (daemon, port):
        stale = record(daemon, DeviceStale)
        lidar = await connected(port, "lidar", "lidar0")
        lidar.send(SCAN)
        for _ in range(200):  # fillers every 50 ms until it falls stale (waited for, 10 s)
            await asyncio.sleep(0.05)
            lidar.send_raw(filler)
            if stale:
                break
        assert [m.device_id for m in stale] == ["lidar0"]
        assert stale[0].silent_s > 0.2  # silent since the scan, the fillers not counted
        await lidar.close()


async def test_a_sensor_that_sends_nothing_at_all_frees_its_slot() -> None:
    tcp = {"max_clients": 2, "max_control_clients": 1, "sensor_idle_timeout_s": 1.0}
    async with running_daemon(tcp=tcp) as (daemon, port):
        lost = record(daemon, DeviceLost)
        mute = [await connected(port, "compass", f"mute{i}") for i in range(2)]
        _, refusal = await hello(port, "control", "ui")
        assert isinstance(refusal, ErrorFrame) and "server full" in refusal.reason
        farewell = await mute[0].receive(3.0)
        assert isinstance(farewell, ErrorFrame) and "tcp.sensor_idle_timeout_s" in farewell.reason
        await until(lambda: len(lost) == 2)
        ui, welcome = await hello(port, "control", "ui")
        assert isinstance(welcome, Welcome)
        for client in (*mute, ui):
            await client.close()


async def test_a_hellos_token_never_reaches_the_log_of_a_bug(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def broken(*_: object) -> None:
        raise RuntimeError("a bug in the handshake")

    monkeypatch.setattr(TcpServer, "_handshake", broken)
    async with running_daemon(tcp={"token": "the-right-secret-123"}) as (daemon, port):
        reported: list[dict[str, Any]] = []
        real = daemon.bus.report_failure
        monkeypatch.setattr(
            daemon.bus,
            "report_failure",
            lambda module, context, err: reported.append(context) or real(module, context, err),
        )
        client = await AsyncClient.open("127.0.0.1", port)
        client.send(Hello(role="imu", device_id="imu0", token="the-right-secret-123"))
        await until(lambda: bool(reported))
        assert b"the-right-secret-123" not in reported[0]["line"]
        assert b'"token": "<redacted>"' in reported[0]["line"]
        await client.close()

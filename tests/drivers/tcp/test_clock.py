"""The clock role: a simulator moving a daemon that runs on simulated time (real sockets)."""

from __future__ import annotations

import json

from navd.lifecycle import SimClock
from navd.lifecycle.messages import LaserScan
from navd.wire import ClockAck, ClockFrame, ErrorFrame, Welcome
from tests.drivers.conftest import connected, hello, record, running_daemon
from tests.drivers.tcp.test_server import SCAN

SIMULATED = {"clock": "simulated"}


async def test_a_clock_client_is_refused_by_a_daemon_on_real_time() -> None:
    async with running_daemon() as (_, port):
        _, answer = await hello(port, "clock", "sim-clock")
    assert isinstance(answer, ErrorFrame) and answer.fatal is True
    assert answer.field == "role"
    assert "lifecycle.clock = 'simulated'" in answer.reason


async def test_time_stands_still_until_the_clock_client_moves_it() -> None:
    async with running_daemon(lifecycle=SIMULATED) as (daemon, port):
        assert isinstance(daemon.clock, SimClock)
        scans = record(daemon, LaserScan)
        clock, welcome = await hello(port, "clock", "sim-clock")
        assert isinstance(welcome, Welcome)
        lidar = await connected(port, "lidar", "lidar0")
        start = daemon.clock.now()
        for _ in range(3):
            lidar.send(SCAN.model_copy(update={"stamp": start}))
        # the step names the 3 lines: they are taken in, at the old time, before time moves
        clock.send(ClockFrame(time=start + 0.5, frames={"lidar0": 3}))
        ack = await clock.receive_type(ClockAck)
        assert ack.time == start + 0.5 and ack.missing is None
        assert daemon.clock.now() == start + 0.5
        assert [s.received for s in scans] == [start] * 3
        assert [s.stamp for s in scans] == [start] * 3  # same clock: stamps kept as sent
        # a second step goes on from there; nothing new was named
        clock.send(ClockFrame(time=start + 1.0))
        assert (await clock.receive_type(ClockAck)).time == start + 1.0
        await lidar.close()
        await clock.close()


async def test_bad_clock_frames_are_answered_by_name_and_time_stays() -> None:
    async with running_daemon(lifecycle=SIMULATED) as (daemon, port):
        clock = await connected(port, "clock", "sim-clock")
        clock.send(ClockFrame(time=5.0))
        await clock.receive_type(ClockAck)
        clock.send(ClockFrame(time=4.0))  # backwards
        error = await clock.receive_type(ErrorFrame)
        assert error.field == "time" and "backwards" in error.reason
        clock.send_raw(b'{"type": "clock", "time": "soon"}\n')
        error = await clock.receive_type(ErrorFrame)
        assert error.field == "time"
        clock.send_raw(json.dumps({"type": "clock", "time": 6.0, "frames": {"l": -1}}).encode())
        clock.send_raw(b"\n")
        error = await clock.receive_type(ErrorFrame)
        assert error.field.startswith("frames")
        assert daemon.clock.now() == 5.0
        # the connection carries on
        clock.send(ClockFrame(time=6.0))
        assert (await clock.receive_type(ClockAck)).time == 6.0
        await clock.close()


async def test_lines_that_never_come_are_named_in_the_answer() -> None:
    sections = {"lifecycle": {**SIMULATED, "lockstep_timeout_s": 0.1}}
    async with running_daemon(**sections) as (_, port):
        clock = await connected(port, "clock", "sim-clock")
        clock.send(ClockFrame(time=1.0, frames={"imu0": 4}))
        ack = await clock.receive_type(ClockAck)
    assert ack.missing == {"imu0": 4}
    assert ack.time == 1.0


async def test_one_simulator_owns_the_clock() -> None:
    async with running_daemon(lifecycle=SIMULATED) as (_, port):
        first = await connected(port, "clock", "sim-a")
        _, answer = await hello(port, "clock", "sim-b")
        assert isinstance(answer, ErrorFrame) and answer.field == "role"
        assert "'sim-a' already drives the time" in answer.reason
        await first.close()

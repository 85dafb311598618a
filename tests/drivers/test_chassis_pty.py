"""The chassis driver against a real pseudo-terminal standing in for the STM32's UART."""

from __future__ import annotations

import asyncio
import itertools
import os
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import pytest
import serial

from navd.lifecycle.messages import (
    ConfigChange,
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    SafeStop,
    VelocityCommand,
    WheelOdometry,
)
from tests.drivers.conftest import record, running_daemon, until

PERIOD_S = 0.02  # chassis.command_rate_hz = 50
REACTION_S = 0.2
# the event loop may start a tick a little late on a busy machine
SCHEDULING_ALLOWANCE_S = 0.03


class FakeStm32:
    """The far side of a pty: reads the lines navd writes, timestamps them, can talk back."""

    def __init__(self, link: Path) -> None:
        self.link = link
        self.lines: list[tuple[float, bytes]] = []
        self._partial = b""
        self.master = -1
        self.plug()

    def plug(self) -> None:
        """A new pty appears at the link path (like a USB adapter plugged back in)."""
        master, slave = os.openpty()
        os.set_blocking(master, False)
        tmp = self.link.with_suffix(".new")
        tmp.unlink(missing_ok=True)
        tmp.symlink_to(os.ttyname(slave))
        tmp.replace(self.link)
        os.close(slave)
        self.master = master
        asyncio.get_running_loop().add_reader(master, self._readable)

    def unplug(self) -> None:
        asyncio.get_running_loop().remove_reader(self.master)
        os.close(self.master)
        self.link.unlink(missing_ok=True)

    def _readable(self) -> None:
        try:
            data = os.read(self.master, 4096)
        except OSError:
            return
        now = asyncio.get_running_loop().time()
        self._partial += data
        *complete, self._partial = self._partial.split(b"\n")
        self.lines.extend((now, line + b"\n") for line in complete)

    def say(self, data: bytes) -> None:
        os.write(self.master, data)

    def since(self, t: float) -> list[bytes]:
        return [line for stamp, line in self.lines if stamp >= t]


# A robot that reaches every command of these tests within one period, so that each line
# shows its command (the ramp has tests of its own).
QUICK = {"max_linear_accel_mps2": 20.0, "max_angular_accel_radps2": 50.0}


@asynccontextmanager
async def chassis_daemon(
    tmp_path: Path,
    reaction_s: float = REACTION_S,
    robot: dict[str, float] | None = None,
    **chassis: Any,
) -> AsyncIterator[tuple[Any, FakeStm32]]:
    stm32 = FakeStm32(tmp_path / "ttyNAVD")
    settings = {
        "enabled": True,
        "port": str(stm32.link),
        "command_rate_hz": 1 / PERIOD_S,
        "reconnect_initial_s": 0.05,
        "reconnect_max_s": 0.2,
        **chassis,
    }
    async with running_daemon(
        chassis=settings,
        safety={"reaction_timeout_s": reaction_s},
        robot={"track_width_m": 0.3, **(QUICK if robot is None else robot)},
    ) as (daemon, _):
        try:
            await until(lambda: len(stm32.lines) >= 1)  # the port is open: "0 0" came first
            assert stm32.lines[0][1] == b"0 0\n"
            yield daemon, stm32
        finally:
            if stm32.master >= 0 and stm32.link.exists():
                stm32.unplug()


def drive(daemon: Any, v: float, w: float) -> None:
    now = daemon.clock.now()
    daemon.bus.publish(
        VelocityCommand(stamp=now, received=now, linear_mps=v, angular_radps=w, source="planner")
    )


async def test_zero_first_then_exact_bytes_for_known_commands(tmp_path: Path) -> None:
    async with chassis_daemon(tmp_path) as (daemon, stm32):
        loop = asyncio.get_running_loop()
        # (v, w) -> wheels (v -+ w*0.3/2) * 1000 units per m/s
        for v, w, expected in [
            (0.2, 0.5, b"125 275\n"),
            (-0.1, 0.0, b"-100 -100\n"),
            (0.0, -1.0, b"150 -150\n"),
        ]:
            start = loop.time()
            drive(daemon, v, w)
            await until(lambda e=expected, s=start: e in stm32.since(s))  # type: ignore[misc]


async def test_zero_within_reaction_timeout_after_commands_stop(tmp_path: Path) -> None:
    async with chassis_daemon(tmp_path) as (daemon, stm32):
        loop = asyncio.get_running_loop()
        for _ in range(10):  # a planner at 20 Hz
            drive(daemon, 0.3, 0.0)
            await asyncio.sleep(0.05)
        last_command = loop.time()
        await asyncio.sleep(REACTION_S + 5 * PERIOD_S)
        after = [(t, line) for t, line in stm32.lines if t >= last_command]
        first_zero = next(t for t, line in after if line == b"0 0\n")
        assert b"300 300\n" in [line for _, line in after]  # it was driving until then
        assert first_zero - last_command <= REACTION_S + PERIOD_S + SCHEDULING_ALLOWANCE_S
        assert all(line == b"0 0\n" for t, line in after if t > first_zero)


async def test_safe_stop_writes_zero_at_once(tmp_path: Path) -> None:
    async with chassis_daemon(tmp_path, reaction_s=2.0, command_rate_hz=2.0) as (daemon, stm32):
        loop = asyncio.get_running_loop()
        drive(daemon, 0.3, 0.0)
        await until(lambda: any(line == b"300 300\n" for _, line in stm32.lines), 2.0)
        stopped = loop.time()
        now = daemon.clock.now()
        daemon.bus.publish(SafeStop(stamp=now, received=now, reason="test", source="t", key="t"))
        await until(lambda: b"0 0\n" in stm32.since(stopped), 0.2)  # the next tick is 0.5 s away


async def test_lost_port_is_reported_reopened_with_zero_first_and_never_replayed(
    tmp_path: Path,
) -> None:
    async with chassis_daemon(tmp_path) as (daemon, stm32):
        lost = record(daemon, DeviceLost)
        connected = record(daemon, DeviceConnected)
        drive(daemon, 0.3, 0.0)
        await until(lambda: any(line == b"300 300\n" for _, line in stm32.lines))
        stm32.unplug()
        await until(lambda: len(lost) == 1)
        assert lost[0].kind is DeviceKind.CHASSIS and lost[0].device_id == str(stm32.link)
        drive(daemon, 0.4, 0.0)  # commanded while the port is gone: must not be replayed
        await asyncio.sleep(0.1)
        stm32.lines.clear()
        stm32.plug()
        await until(lambda: len(connected) == 1 and len(stm32.lines) >= 3)
        assert stm32.lines[0][1] == b"0 0\n"
        assert all(line == b"0 0\n" for _, line in stm32.lines)
        drive(daemon, 0.1, 0.0)  # a fresh command after reconnection is obeyed
        await until(lambda: any(line == b"100 100\n" for _, line in stm32.lines))


async def test_missing_port_at_start_does_not_stop_the_daemon(tmp_path: Path) -> None:
    link = tmp_path / "ttyNAVD"
    async with running_daemon(
        chassis={
            "enabled": True,
            "port": str(link),
            "reconnect_initial_s": 0.05,
            "reconnect_max_s": 0.1,
        }
    ) as (daemon, _):
        connected = record(daemon, DeviceConnected)
        lost = record(daemon, DeviceLost)
        await asyncio.sleep(0.3)  # several failed attempts: reported once, the daemon runs on
        assert daemon.manager.states["chassis"].value == "active"
        # several attempts failed by now; the loss is reported once (before or after we began
        # listening), never once per retry
        assert len(lost) <= 1
        stm32 = FakeStm32(link)
        await until(lambda: len(stm32.lines) >= 1)
        assert stm32.lines[0][1] == b"0 0\n"
        await until(lambda: len(connected) == 1)
        assert connected[0].kind is DeviceKind.CHASSIS
        stm32.unplug()


async def test_shutdown_writes_zero_last(tmp_path: Path) -> None:
    stm32_box: list[FakeStm32] = []
    async with chassis_daemon(tmp_path) as (daemon, stm32):
        stm32_box.append(stm32)
        drive(daemon, 0.3, 0.0)
        await until(lambda: any(line == b"300 300\n" for _, line in stm32.lines))
        daemon.request_shutdown("test")
        await until(lambda: daemon.manager.states["chassis"].value == "finalized")
        await asyncio.sleep(0.02)
    assert stm32_box[0].lines[-1][1] == b"0 0\n"


@pytest.mark.parametrize(("invert_left", "expected_w"), [(False, 0.0), (True, 200 / 0.3 / 1000)])
async def test_encoder_feedback_becomes_wheel_odometry(
    tmp_path: Path, invert_left: bool, expected_w: float
) -> None:
    async with chassis_daemon(tmp_path, feedback="encoders", invert_left=invert_left) as (
        daemon,
        stm32,
    ):
        odometry = record(daemon, WheelOdometry)
        stm32.say(b"100 100\r\n")
        stm32.say(b"garbage\n")
        await until(lambda: len(odometry) == 1)
        expected_v = 0.0 if invert_left else 0.1
        assert odometry[0].linear_mps == pytest.approx(expected_v)
        assert odometry[0].angular_radps == pytest.approx(expected_w)


async def test_a_bug_in_the_serial_loop_stops_the_wheels_and_recovers(tmp_path: Path) -> None:
    from navd.drivers.chassis import ChassisDriver

    async with chassis_daemon(tmp_path) as (daemon, stm32):
        driver = next(m for m in daemon.manager.modules if isinstance(m, ChassisDriver))
        drive(daemon, 0.3, 0.0)
        await until(lambda: any(line == b"300 300\n" for _, line in stm32.lines))
        original = driver._command_now

        def broken_once() -> tuple[int, int]:
            driver._command_now = original  # type: ignore[method-assign]
            raise ZeroDivisionError("bad calibration math")

        reopened = record(daemon, DeviceConnected)
        driver._command_now = broken_once  # type: ignore[method-assign]
        loop = asyncio.get_running_loop()
        broke = loop.time()
        await until(lambda: daemon.supervisor.record("chassis").failures == 1)
        assert "bad calibration math" in daemon.supervisor.record("chassis").last_error
        await until(lambda: b"0 0\n" in stm32.since(broke))
        await until(lambda: len(reopened) == 1)
        drive(daemon, 0.1, 0.0)  # the driver reopened and obeys fresh commands again
        await until(lambda: b"100 100\n" in stm32.since(broke))


async def test_a_new_command_rate_applies_at_once_without_a_restart(tmp_path: Path) -> None:
    stm32 = FakeStm32(tmp_path / "ttyNAVD")
    chassis = {"enabled": True, "port": str(stm32.link), "command_rate_hz": 20.0}
    try:
        async with running_daemon(chassis=chassis, lifecycle={"clock": "simulated"}) as (
            daemon,
            _,
        ):
            await until(lambda: daemon.line_counts.sent["chassis"] >= 1)  # open: "0 0" written
            clock = daemon.clock

            async def lines_in(seconds: float) -> int:
                before = daemon.line_counts.sent["chassis"]
                await clock.run_to(clock.now() + seconds)
                return daemon.line_counts.sent["chassis"] - before

            assert abs(await lines_in(1.0) - 20) <= 1
            now = clock.now()
            daemon.bus.publish(
                ConfigChange(
                    stamp=now,
                    received=now,
                    request_id="r",
                    changes={"chassis.command_rate_hz": 50.0},
                    privileged=True,  # as the config file may
                )
            )
            # the tick already waiting keeps the old period; the new grid starts after it
            assert abs(await lines_in(1.0) - 50) <= 3
    finally:
        stm32.unplug()


def _wheels(line: bytes) -> tuple[int, int]:
    left, right = line.split()
    return int(left), int(right)


async def test_what_is_written_speeds_up_within_the_limits_even_after_an_outage(
    tmp_path: Path,
) -> None:
    # 0.5 m/s^2 at 50 Hz: at most 10 units (0.01 m/s) more per line; stopping is immediate
    robot = {"max_linear_accel_mps2": 0.5, "max_angular_accel_radps2": 2.0}
    async with chassis_daemon(tmp_path, robot=robot) as (daemon, stm32):
        connected = record(daemon, DeviceConnected)

        async def keep_driving(seconds: float) -> None:
            loop = asyncio.get_running_loop()
            end = loop.time() + seconds
            while loop.time() < end:  # a planner at 20 Hz asking for full speed
                drive(daemon, 0.5, 0.0)
                await asyncio.sleep(0.05)

        def steps(lines: list[bytes]) -> list[int]:
            speeds = [_wheels(line)[0] for line in lines]
            return [b - a for a, b in itertools.pairwise(speeds)]

        await keep_driving(0.6)
        first = [line for _, line in stm32.lines]
        assert max(steps(first)) <= 10
        assert _wheels(first[-1])[0] >= 250  # it did speed up meanwhile
        # the UART goes away for a second while the planner keeps asking for full speed
        stm32.unplug()
        await keep_driving(1.0)
        stm32.lines.clear()
        stm32.plug()
        await until(lambda: len(connected) == 1)
        await keep_driving(0.4)
        after = [line for _, line in stm32.lines]
        assert after[0] == b"0 0\n"
        assert max(steps(after)) <= 10  # from a standstill again, not from before the outage
        assert _wheels(after[-1])[0] > 0
        loop = asyncio.get_running_loop()
        stopped = loop.time()
        drive(daemon, 0.0, 0.0)
        await until(lambda: b"0 0\n" in stm32.since(stopped))


async def test_a_port_another_program_holds_is_refused_by_name_and_taken_when_freed(
    tmp_path: Path,
) -> None:
    link = tmp_path / "ttyNAVD"
    stm32 = FakeStm32(link)
    holder = serial.Serial(str(link), 115200, exclusive=True)  # say, a terminal left open
    lost: list[DeviceLost] = []
    connected: list[DeviceConnected] = []

    def recorders(daemon: Any) -> None:
        daemon.bus.subscribe(DeviceLost, lost.append, module="test-recorder")
        daemon.bus.subscribe(DeviceConnected, connected.append, module="test-recorder")

    try:
        async with running_daemon(
            recorders,
            chassis={
                "enabled": True,
                "port": str(link),
                "reconnect_initial_s": 0.05,
                "reconnect_max_s": 0.1,
            },
        ):
            await until(lambda: len(lost) == 1)
            await asyncio.sleep(0.3)  # several more attempts: none writes a byte
            assert stm32.lines == [] and connected == []
            assert "ttyNAVD is in use by another program" in lost[0].reason
            holder.close()
            await until(lambda: len(connected) == 1 and len(stm32.lines) >= 1)
            assert stm32.lines[0][1] == b"0 0\n"
    finally:
        holder.close()
        stm32.unplug()


async def test_a_port_whose_first_write_fails_is_let_go_and_opened_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real_write = serial.Serial.write
    failures = [serial.SerialException("I/O error")]

    def write_failing_once(self: serial.Serial, data: bytes) -> int | None:
        if failures:
            raise failures.pop()
        return real_write(self, data)

    monkeypatch.setattr(serial.Serial, "write", write_failing_once)
    # the fixture waits for the first "0 0": it comes only if the failed port's lock was let go
    async with chassis_daemon(tmp_path) as (_, stm32):
        assert not failures
        assert stm32.lines[0][1] == b"0 0\n"

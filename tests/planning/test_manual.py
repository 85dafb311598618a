"""Driving by hand: operator commands capped and passed to the gate, the navigator paused
while an operator drives and its goal resumed afterwards, teleop switched off."""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from typing import Any

from navd.config import NavdConfig
from navd.lifecycle.messages import (
    DriveCommand,
    DriveMode,
    GoalStatus,
    ManualCommand,
    VelocityCommand,
)
from navd.logs import add_log_tap, remove_log_tap
from navd.planning.manual import ManualDriving, ManualSettings
from navd.planning.settings import manual_settings
from navd.wire import (
    CancelFrame,
    ErrorFrame,
    GoalFrame,
    InitialPoseFrame,
    StatusFrame,
    SubscribeFrame,
    TeleopFrame,
)
from tests.drivers.conftest import connected, record, running_daemon, until

SETTINGS = ManualSettings(
    enabled=True, max_linear_mps=0.5, max_angular_radps=1.0, resume_after_s=2.0
)


def test_commands_are_capped_and_manual_mode_lasts_past_the_last_one() -> None:
    manual = ManualDriving()
    assert not manual.active and not manual.over(0.0)
    assert manual.command(SETTINGS, "op", 2.0, -3.0, now=10.0) == (0.5, -1.0, True)
    assert manual.command(SETTINGS, "op", -0.2, 0.4, now=11.0) == (-0.2, 0.4, False)
    assert manual.active and manual.operator == "op"
    assert not manual.over(12.9)  # 2 s after the last command, not the first
    assert manual.over(13.0)
    assert manual.end() == "op"
    assert not manual.active and not manual.over(100.0)
    assert manual.command(SETTINGS, "other", 0.0, 0.0, now=20.0)[2]  # a new stretch


async def test_an_operator_pauses_the_goal_and_it_resumes_after_the_last_command() -> None:
    async with running_daemon(teleop={"resume_after_s": 0.6}) as (daemon, port):
        commands = record(daemon, VelocityCommand)
        statuses = record(daemon, GoalStatus)
        modes = record(daemon, DriveMode)
        control = await connected(port, "control", "ui")
        await control.request(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.05))
        await control.request(GoalFrame(x=3.0, y=0.0, goal_id="g1"))
        await until(lambda: any(c.source == "planner" and c.linear_mps > 0 for c in commands))

        operator = await connected(port, "control", "pad")
        for _ in range(5):
            operator.send(TeleopFrame(linear_x=2.0, angular_z=0.3))  # above teleop's 0.5 m/s
            await asyncio.sleep(0.1)
        teleop = [c for c in commands if c.source == "teleop:pad"]
        assert len(teleop) == 5
        assert all((c.linear_mps, c.angular_radps) == (0.5, 0.3) for c in teleop)
        first = commands.index(teleop[0])
        # while the operator drives the navigator commands nothing (one step in flight aside)
        assert sum(c.source == "planner" for c in commands[first:]) <= 1
        assert [(m.mode, m.operator, m.paused_goal) for m in modes] == [("manual", "pad", "g1")]
        paused = [s for s in statuses if s.state == "paused"]
        assert paused and paused[0].goal_id == "g1" and "pad" in paused[0].reason

        control.send(SubscribeFrame(rate_hz=20))
        status = await control.receive_type(StatusFrame)
        assert (status.mode, status.operator) == ("manual", "pad")

        # Quiet for teleop.resume_after_s: the goal is taken up again, planned afresh.
        stopped_at = len(commands)
        await until(lambda: len(modes) == 2, timeout_s=3.0)
        assert modes[-1].mode == "auto"
        await until(
            lambda: any(c.source == "planner" and c.linear_mps > 0 for c in commands[stopped_at:]),
            timeout_s=3.0,
        )
        assert statuses[-1].state == "active" and statuses[-1].goal_id == "g1"
        await operator.close()
        await control.close()


async def test_canceling_while_an_operator_drives_does_not_stop_the_operator() -> None:
    async with running_daemon(teleop={"resume_after_s": 5.0}) as (daemon, port):
        commands = record(daemon, VelocityCommand)
        statuses = record(daemon, GoalStatus)
        control = await connected(port, "control", "ui")
        await control.request(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.05))
        await control.request(GoalFrame(x=3.0, y=0.0, goal_id="g1"))
        await until(lambda: any(s.state == "active" for s in statuses))
        control.send(TeleopFrame(linear_x=0.2, angular_z=0.0))
        await until(lambda: any(c.source == "teleop:ui" for c in commands))
        since = len(commands)
        await control.request(CancelFrame())
        await until(lambda: statuses[-1].state == "canceled")
        await asyncio.sleep(0.2)
        assert not [c for c in commands[since:] if c.source == "planner"]
        await control.close()


async def test_teleop_switched_off_drives_nothing_and_says_so() -> None:
    async with running_daemon(teleop={"enabled": False}) as (daemon, port):
        commands = record(daemon, VelocityCommand)
        drives = record(daemon, DriveCommand)
        pad = await connected(port, "control", "pad")
        pad.send(TeleopFrame(linear_x=0.3, angular_z=0.0))
        refusal = await pad.receive_type(ErrorFrame)
        assert refusal.field == "type" and "teleop.enabled is false" in refusal.reason
        await asyncio.sleep(0.2)
        assert not commands and not drives
        await pad.close()


async def test_the_planner_holds_to_teleop_switched_off_as_well() -> None:
    """A ManualCommand reaching the planner anyway (teleop switched off while it was on its
    way) drives nothing, and the planner says so once per operator."""
    lines: list[dict[str, Any]] = []

    def tap(event: Mapping[str, Any]) -> None:
        lines.append(dict(event))  # a copy: the renderer takes the line apart afterwards

    async with running_daemon(teleop={"enabled": False}) as (daemon, _):
        commands = record(daemon, VelocityCommand)
        add_log_tap(tap)
        try:
            for _ in range(3):
                now = daemon.clock.now()
                daemon.bus.publish(
                    ManualCommand(
                        stamp=now, received=now, linear_mps=0.3, angular_radps=0.0, operator="pad"
                    )
                )
            await asyncio.sleep(0.1)
        finally:
            remove_log_tap(tap)
        assert not commands
        refusals = [line for line in lines if line["event"] == "teleop_refused"]
        assert len(refusals) == 1 and "teleop.enabled" in refusals[0]["reason"]


def test_teleop_settings_come_from_the_teleop_section() -> None:
    config = NavdConfig.model_validate(
        {"teleop": {"max_linear_speed_mps": 0.2, "resume_after_s": 9.0, "enabled": False}}
    )
    settings = manual_settings(config.teleop)
    assert settings == ManualSettings(False, 0.2, 1.0, 9.0)

"""Driving by hand on the real daemon and the simulated robot: ``navd teleop`` holding the up
key towards a wall is stopped by the collision guard before it; an operator whose commands
stop (the key released, the link gone) is stopped by the deadman within the reaction
timeout."""

from __future__ import annotations

import asyncio
import math
import sys
from pathlib import Path

import pytest

from navd.sim import Session, from_shapes, session
from navd.wire import EmergencyStopFrame, InitialPoseFrame, TeleopFrame

pytestmark = pytest.mark.e2e

# A room whose far wall stands 2 m ahead of the robot's centre.
WALL_X_M = 2.0
ROOM = {
    "walls": [
        [-1.5, -1.5, WALL_X_M, -1.5],
        [WALL_X_M, -1.5, WALL_X_M, 1.5],
        [WALL_X_M, 1.5, -1.5, 1.5],
        [-1.5, 1.5, -1.5, -1.5],
    ],
    "start": [0.0, 0.0, 0.0],
}
UP = b"\x1b[A"


async def _hold_up_key(s: Session, seconds: float) -> None:
    """``navd teleop`` with the up key held (the terminal repeating it every 0.05 s), then q."""
    teleop = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "navd",
        "teleop",
        "--port",
        str(s.port),
        "--speed",
        "0.5",
        stdin=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    assert teleop.stdin is not None
    for _ in range(round(seconds / 0.05)):
        teleop.stdin.write(UP)
        await teleop.stdin.drain()
        await asyncio.sleep(0.05)
    teleop.stdin.write(b"q")
    teleop.stdin.close()
    _, err = await asyncio.wait_for(teleop.communicate(), 10.0)
    assert teleop.returncode == 0, err.decode()


async def test_holding_forward_towards_a_wall_stops_before_it(tmp_path: Path) -> None:
    world = from_shapes(ROOM, "room")
    async with session(world, tmp_path) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        await asyncio.sleep(1.0)  # the first scans are in
        await _hold_up_key(s, seconds=8.0)  # 4 m of asking at 0.5 m/s: twice the way
        body = s.sim.body
        radius_m = s.config.robot.radius_m
        assert body.x_m > 0.8, "the robot drove forward on the key"
        assert body.collisions == 0 and body.min_clearance_m > 0.0
        gap_m = WALL_X_M - (body.x_m + radius_m)
        # The guard stops a command whose braking sweep would enter the stop zone: at 0.5
        # m/s that is some 0.65 m before the wall; it must not stop far off either.
        assert s.config.safety.stop_distance_m < gap_m <= 0.8
        assert (body.linear_mps, body.angular_radps) == (0.0, 0.0)


async def test_an_operator_who_goes_quiet_is_stopped_within_the_reaction_timeout(
    tmp_path: Path,
) -> None:
    world = from_shapes(ROOM, "room")
    async with session(world, tmp_path) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        await asyncio.sleep(1.0)
        for _ in range(15):  # back away from the wall at 0.3 m/s for 1.5 s
            s.control.send(TeleopFrame(linear_x=-0.3, angular_z=0.0))
            await asyncio.sleep(0.1)
        last_sent = s.sim.now()
        await asyncio.sleep(1.5)  # the operator is gone: no stop, no goodbye
        log = s.sim.robot.wheels.log
        moving = [t for t, left, right in log if t <= last_sent and (left, right) != (0, 0)]
        assert moving, "the robot drove on the operator's commands"
        stops = [t for t, left, right in log if t > last_sent and (left, right) == (0, 0)]
        assert stops, "the chassis never stopped"
        chassis_period_s = 1.0 / s.config.chassis.command_rate_hz
        # The deadline runs from the last command's arrival (a few ms after it was sent here);
        # the chassis writes its zero at its next period, and the simulator reads it from
        # the pseudo-terminal at its next turn (0.1 s covers both ends on a loaded machine).
        allowed_s = s.config.safety.reaction_timeout_s + chassis_period_s + 0.1
        assert stops[0] - last_sent <= allowed_s
        assert not [t for t, left, right in log if t > stops[0] and (left, right) != (0, 0)]
        assert math.isclose(s.sim.body.linear_mps, 0.0, abs_tol=1e-9)


async def test_an_emergency_stop_holds_the_robot_until_it_is_released(tmp_path: Path) -> None:
    world = from_shapes(ROOM, "room")
    async with session(world, tmp_path) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        await asyncio.sleep(1.0)
        body = s.sim.body

        async def drive(seconds: float, linear_mps: float) -> None:
            for _ in range(round(seconds / 0.1)):
                s.control.send(TeleopFrame(linear_x=linear_mps, angular_z=0.0))
                await asyncio.sleep(0.1)

        await drive(1.0, -0.15)  # backing away from the far wall: room to drive
        assert body.linear_mps < -0.05
        await s.control.request(EmergencyStopFrame())
        await drive(1.5, -0.15)  # the operator keeps asking: nothing moves
        stopped_at = body.x_m
        await drive(1.0, -0.15)
        assert (body.linear_mps, body.x_m) == (0.0, stopped_at)
        await s.control.request(EmergencyStopFrame(engaged=False))
        await drive(1.0, -0.15)
        assert body.x_m < stopped_at - 0.03, "released, it drives again"

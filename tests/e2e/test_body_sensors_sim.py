"""The robot's other sensors on the real daemon and the simulated robot, each against
something its lidar cannot see: a glass pane only a sonar hears, a low box only a bumper
feels, a stairwell only a cliff sensor sees, and a table top only a depth camera sees.
Without the sensor each scenario ends in a collision or a fall (the first test shows it for
the pane); with it the robot stops or steers before harm."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path
from typing import Any

import pytest

from navd.sim import Session, from_shapes, session
from navd.wire import GoalFrame, InitialPoseFrame, TeleopFrame

pytestmark = pytest.mark.e2e

RADIUS_M = 0.2  # the default robot's
# A 6 m x 4 m room; what the lidar cannot see stands 2 m ahead of the start.
ROOM: dict[str, Any] = {
    "walls": [
        [-1.5, -2.0, 4.5, -2.0],
        [4.5, -2.0, 4.5, 2.0],
        [4.5, 2.0, -1.5, 2.0],
        [-1.5, 2.0, -1.5, -2.0],
    ],
    "start": [0.0, 0.0, 0.0],
}
AHEAD_X_M = 2.0
GLASS = {"glass": [[AHEAD_X_M, -2.0, AHEAD_X_M, 2.0]]}
LOW_BOX = {"low_boxes": [[AHEAD_X_M, -0.4, 0.3, 0.8]]}
DROP = {"drops": [[AHEAD_X_M, -2.0, 2.5, 4.0]]}
# A 1 m x 1.2 m table whose legs (at its corners) the lidar sees, its top not.
TABLE = {"tables": [[1.2, -0.6, 1.0, 1.2]]}
SONAR = {"ranges": {"sonar_front": {"x_m": RADIUS_M, "yaw_rad": 0.0}}}
BUMPER = {"contacts": {"bumper_front": {"x_m": RADIUS_M}}}
CLIFF = {"contacts": {"cliff_front": {"x_m": RADIUS_M + 0.03}}}
CAMERA = {"depth": {"camera": {"x_m": 0.1, "z_m": 0.4}}}
SPEED_MPS = 0.3


def _world(hidden: dict[str, Any]) -> Any:
    return from_shapes(ROOM | hidden, "room")


async def _drive(s: Session, linear_mps: float, seconds: float) -> None:
    """Hold a teleop command for ``seconds`` (10 Hz, like an operator's joystick)."""
    for _ in range(round(seconds / 0.1)):
        s.control.send(TeleopFrame(linear_x=linear_mps, angular_z=0.0))
        await asyncio.sleep(0.1)


async def _localized(s: Session) -> None:
    s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
    await asyncio.sleep(1.0)  # the first scans and readings are in


async def _drive_towards_it(
    mounts: dict[str, Any], hidden: dict[str, Any], tmp_path: Path, speed_mps: float = SPEED_MPS
) -> Any:
    overrides = {"mounts": mounts} if mounts else None
    async with session(_world(hidden), tmp_path, overrides=overrides) as s:
        await _localized(s)
        await _drive(s, speed_mps, seconds=3.6 / speed_mps)  # 3.6 m of asking: past it
        return s.sim.body


async def test_without_its_sonar_the_robot_drives_into_a_glass_pane(tmp_path: Path) -> None:
    body = await _drive_towards_it({}, GLASS, tmp_path)
    assert body.collisions > 0, "the lidar saw the pane: the scenario shows nothing"


async def test_a_sonar_stops_the_robot_before_a_glass_pane(tmp_path: Path) -> None:
    body = await _drive_towards_it(SONAR, GLASS, tmp_path)
    assert body.x_m > 0.8, "the robot drove towards the pane"
    assert body.collisions == 0
    assert AHEAD_X_M - (body.x_m + RADIUS_M) < 0.8, "stopped by the pane, not long before"


async def test_a_bumper_stops_the_robot_at_a_low_box_and_lets_it_back_away(
    tmp_path: Path,
) -> None:
    overrides = {"mounts": BUMPER}
    async with session(_world(LOW_BOX), tmp_path, overrides=overrides) as s:
        await _localized(s)
        await _drive(s, SPEED_MPS, seconds=12.0)
        body = s.sim.body
        pressed_at = body.x_m
        assert AHEAD_X_M - (pressed_at + RADIUS_M) < 0.05, "it drove up to the box"
        # held: pushing on is refused; the body is not shoved against the box again and again
        held_steps = body.collisions
        await _drive(s, SPEED_MPS, seconds=2.0)
        assert body.collisions - held_steps <= 5
        assert body.x_m <= pressed_at + 0.01
        await _drive(s, -SPEED_MPS, seconds=2.0)
        assert body.x_m < pressed_at - 0.2, "backing away is allowed"


async def test_a_cliff_sensor_stops_the_robot_at_the_top_of_the_stairs(tmp_path: Path) -> None:
    # Braking at the default 0.5 m/s² from 0.2 m/s takes 4 cm; the sensor leads the caster
    # (half-way to the front) by 13 cm.
    body = await _drive_towards_it(CLIFF, DROP, tmp_path, speed_mps=0.2)
    assert body.x_m > 1.0, "the robot drove towards the stairs"
    assert body.falls == 0
    assert (body.linear_mps, body.angular_radps) == (0.0, 0.0)


async def _reach(s: Session, goal: tuple[float, float], within_m: float, limit_s: float) -> bool:
    body = s.sim.body
    for _ in range(round(limit_s / 0.2)):
        if math.hypot(body.x_m - goal[0], body.y_m - goal[1]) < within_m:
            return True
        await asyncio.sleep(0.2)
    return False


@pytest.mark.parametrize("camera", [False, True], ids=["without-camera", "with-camera"])
async def test_a_depth_camera_steers_the_robot_around_a_table_top(
    camera: bool, tmp_path: Path
) -> None:
    overrides = {"mounts": CAMERA} if camera else None
    async with session(_world(TABLE), tmp_path, overrides=overrides) as s:
        await _localized(s)
        goal = (3.6, 0.0)
        s.control.send(GoalFrame(x=goal[0], y=goal[1], yaw=0.0))
        if not camera:  # the lidar sees only the legs: the route runs under the top
            await _reach(s, (AHEAD_X_M, 0.0), within_m=0.3, limit_s=30.0)
            assert s.sim.body.collisions > 0, "the lidar saw the table top: nothing shown"
            return
        assert await _reach(s, goal, within_m=0.3, limit_s=90.0), "the goal past the table"
        assert s.sim.body.collisions == 0

"""Closed-loop scenarios: the real daemon process drives the simulated robot (chassis on a
real pseudo-terminal, sensors over real TCP) through the seed's test situations.

They run on simulated time in lockstep (deterministic, faster than real time), the goal
given at time 0; the lidar-unplugging scenario runs in real time, since its 300 ms is a
promise about the real process."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy import ndimage

from navd.sim import Session, World, from_shapes, session
from navd.slam import load_map
from navd.wire import (
    ConnectionClosedError,
    GoalFrame,
    GoalStatusFrame,
    InitialPoseFrame,
    PoseInfo,
    SaveMapFrame,
    StatusFrame,
    SubscribeFrame,
)

pytestmark = pytest.mark.e2e

# An 8 m x 3 m hall with a pillar off the straight line.
HALL = {
    "walls": [[-1, -1.5, 7, -1.5], [7, -1.5, 7, 1.5], [7, 1.5, -1, 1.5], [-1, 1.5, -1, -1.5]],
    "boxes": [[2.5, 0.5, 0.4, 0.4]],
    "start": [0.0, 0.0, 0.0],
    "goal": [5.5, 0.0, 0.0],
}


async def start(s: Session, world: World, goal_id: str = "g") -> None:
    """Tell navd where the robot starts and where to go; then let (simulated) time run."""
    x, y, yaw = world.start
    assert world.goal is not None
    s.control.send(InitialPoseFrame(x=x, y=y, yaw=yaw, std_xy=0.02))
    gx, gy, gyaw = world.goal
    await s.control.request(GoalFrame(x=gx, y=gy, yaw=gyaw, goal_id=goal_id))
    s.sim.release_clock()


async def outcome(s: Session, goal_id: str = "g", limit_s: float = 60.0) -> GoalStatusFrame:
    """The goal's final goal_status frame (or one saying "timeout" or "closed")."""
    deadline = s.sim.now() + limit_s
    while s.sim.now() < deadline:
        s.check()
        try:
            frame = await s.control.receive(1.0)
        except TimeoutError:
            continue
        except ConnectionClosedError:
            return GoalStatusFrame(goal_id=goal_id, state="closed")
        if (
            isinstance(frame, GoalStatusFrame)
            and frame.goal_id == goal_id
            and frame.state in ("reached", "failed", "canceled")
        ):
            return frame
    return GoalStatusFrame(goal_id=goal_id, state="timeout")


async def latest_pose(s: Session, after_s: float) -> PoseInfo:
    """The pose in the last status frame received within the next ``after_s`` seconds."""
    deadline = s.sim.now() + after_s
    pose: PoseInfo | None = None
    while s.sim.now() < deadline:
        s.check()
        try:
            frame = await s.control.receive(2.0)
        except TimeoutError:  # a slow moment of the machine: the deadline is simulated time
            continue
        if isinstance(frame, StatusFrame) and frame.pose is not None:
            pose = frame.pose
    assert pose is not None, "no pose in status"
    return pose


async def until(predicate: Any, timeout_s: float) -> None:
    deadline = asyncio.get_running_loop().time() + timeout_s
    while not predicate():
        assert asyncio.get_running_loop().time() < deadline, "condition not met in time"
        await asyncio.sleep(0.02)


async def test_lidar_unplugged_stops_the_wheels_within_300_ms_and_the_drive_goes_on(
    tmp_path: Path,
) -> None:
    world = from_shapes(HALL, "hall")
    async with session(world, tmp_path) as s:
        await start(s, world)
        await until(lambda: s.sim.body.linear_mps > 0.2, 30.0)
        unplugged_at = s.sim.now()
        s.sim.sensors.lidar_plugged = False
        await asyncio.sleep(1.5)
        # Every wheel line from 300 ms after the unplugging on is "0 0".
        after = [(t, left, right) for t, left, right in s.sim.robot.wheels.log if t >= unplugged_at]
        stopped = [t for t, left, right in after if (left, right) == (0, 0)]
        assert stopped and stopped[0] - unplugged_at <= 0.3
        assert all((left, right) == (0, 0) for t, left, right in after if t >= stopped[0])
        assert s.sim.body.linear_mps == 0.0
        s.sim.sensors.lidar_plugged = True  # plugged back: the drive goes on to the goal
        result = await outcome(s)
    assert result.state == "reached", result
    assert s.sim.body.collisions == 0


@pytest.mark.parametrize(
    ("role", "control"),
    [("lidar", "lidar_silent"), ("imu", "imu_silent"), ("imu", "imu_plugged")],
)
async def test_a_sensor_that_falls_silent_or_is_lost_stops_the_wheels_within_300_ms(
    tmp_path: Path, role: str, control: str
) -> None:
    # On simulated time in lockstep: the daemon's clock is the simulator's, so the figure is
    # exact and the same on any machine.
    world = from_shapes(HALL, "hall")
    async with session(world, tmp_path, lockstep=True, hold_clock=True) as s:
        await start(s, world)
        await until(lambda: s.sim.body.linear_mps > 0.2, 30.0)
        sensor = s.sim.sensors.sensor(role)  # type: ignore[arg-type]
        wheels = s.sim.robot.wheels.log
        setattr(s.sim.sensors, control, control.endswith("silent"))
        cut = s.sim.now()
        await until(lambda: s.sim.now() > cut + 1.0, 30.0)
        after = [(t, left, right) for t, left, right in wheels if t >= cut]
        first = next(i for i, (_, left, right) in enumerate(after) if (left, right) == (0, 0))
        assert after[first][0] - sensor.last_sent_s <= 0.3
        assert all((left, right) == (0, 0) for _, left, right in after[first:])
        setattr(s.sim.sensors, control, not control.endswith("silent"))  # back: it goes on
        result = await outcome(s)
    assert result.state == "reached", result
    assert s.sim.body.collisions == 0


async def test_a_moving_obstacle_crossing_the_route_is_never_hit(tmp_path: Path) -> None:
    # A person walking back and forth across the straight route beyond the pillar, leaving
    # over a metre of the hall free (one sweeping the whole width would be mapped as a wall
    # by SLAM, as slam_toolbox would too).
    person = {"radius": 0.25, "speed": 0.3, "path": [[4.3, -1.1], [4.3, 0.1]]}
    spec = dict(HALL, movers=[person])
    world = from_shapes(spec, "crossing")
    async with session(world, tmp_path, lockstep=True, hold_clock=True) as s:
        await start(s, world)
        result = await outcome(s, limit_s=90.0)
    assert result.state == "reached", result
    assert s.sim.body.collisions == 0
    assert s.sim.body.min_clearance_m > 0.0


async def test_a_to_b_straight_builds_a_map_that_matches_the_world(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    async with session(world, tmp_path, lockstep=True, hold_clock=True) as s:
        await start(s, world)
        result = await outcome(s)
        s.control.send(SaveMapFrame(name="hall"))
        await until((s.maps / "hall.yaml").exists, 5.0)
    assert result.state == "reached", result
    assert s.sim.body.collisions == 0
    # A to B with the pillar off the line: straight there, no detours, stopped at B.
    truth = np.array([(x, y) for _, x, y, _ in s.sim.truth])
    driven = float(np.hypot(*np.diff(truth, axis=0).T).sum())
    assert driven < 1.15 * 5.5
    assert math.hypot(truth[-1, 0] - 5.5, truth[-1, 1]) <= 0.2
    built = load_map(tmp_path / "maps" / "hall.yaml")
    assert tolerant_iou(world, built, tolerance_m=0.05) >= 0.85


def tolerant_iou(world: World, built: Any, tolerance_m: float) -> float:
    """IoU = TP / (TP + FP + FN) of the mapped obstacle cells against the world's obstacle
    surfaces the lidar could see: a mapped cell is a true positive if a surface cell lies
    within ``tolerance_m``, a false positive otherwise; a surface cell with no mapped cell
    within ``tolerance_m`` is a false negative."""
    res = built.resolution
    occupancy = built.occupancy_percent()
    mapped = occupancy >= 65
    observed = occupancy >= 0
    rows, cols = mapped.shape
    # The world's obstacles on the map's grid: a map cell holding any occupied world cell.
    wr, wc = np.nonzero(world.grid)
    x = world.origin_x_m + (wc + 0.5) * world.resolution_m
    y = world.origin_y_m + (wr + 0.5) * world.resolution_m
    r = np.floor((y - built.origin_y) / res).astype(int)
    c = np.floor((x - built.origin_x) / res).astype(int)
    keep = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
    truth = np.zeros((rows, cols), bool)
    truth[r[keep], c[keep]] = True
    surface = truth & ~ndimage.binary_erosion(truth) & ndimage.binary_dilation(observed)
    reach = max(1, math.ceil(tolerance_m / res))
    near_truth = ndimage.binary_dilation(surface, iterations=reach)
    near_mapped = ndimage.binary_dilation(mapped, iterations=reach)
    true_positive = int((mapped & near_truth).sum())  # mapped, and a wall is that near
    false_positive = int((mapped & ~near_truth).sum())  # mapped where nothing is
    false_negative = int((surface & ~near_mapped).sum())  # a seen wall nothing was mapped near
    return true_positive / (true_positive + false_positive + false_negative)


async def test_localizes_on_a_saved_map_from_a_wrong_start(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    async with session(world, tmp_path / "first", lockstep=True, hold_clock=True) as s:
        await start(s, world)
        assert (await outcome(s)).state == "reached"
        s.control.send(SaveMapFrame(name="hall"))
        await until((s.maps / "hall.yaml").exists, 5.0)
    saved = tmp_path / "first" / "maps" / "hall.yaml"
    # Second run: the map is loaded and kept; the robot is told a start 0.5 m and 15° off.
    overrides = {"slam": {"load_map": str(saved), "updating_map": False}}
    async with session(world, tmp_path / "second", overrides=overrides, lockstep=True) as s:
        x, y, yaw = world.start
        s.control.send(InitialPoseFrame(x=x + 0.4, y=y - 0.3, yaw=yaw + math.radians(15)))
        s.control.send(SubscribeFrame(rate_hz=5))
        pose = await latest_pose(s, after_s=3.0)  # a few scans to find itself
        assert math.hypot(pose.x - x, pose.y - y) < 0.1
        assert abs(pose.yaw - yaw) < math.radians(3)
        gx, gy, gyaw = world.goal or (0.0, 0.0, 0.0)
        s.control.send(GoalFrame(x=gx, y=gy, yaw=gyaw, goal_id="g"))
        result = await outcome(s)
    assert result.state == "reached", result
    end = s.sim.body
    assert math.hypot(end.x_m - gx, end.y_m - gy) <= 0.25


async def test_doubled_imu_noise_still_arrives(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    noisy = {"gyro_noise_radps": 0.004, "gyro_bias_radps": 0.006, "accel_noise_mps2": 0.1}
    async with session(world, tmp_path, sim_settings=noisy, lockstep=True, hold_clock=True) as s:
        await start(s, world)
        result = await outcome(s)
    assert result.state == "reached", result
    assert s.sim.body.collisions == 0


# A maze: over wall A at its top gap, under wall B at its bottom gap; a dead-end pocket
# between them (under the short wall C) lies on the straight line to the goal.
MAZE = {
    "walls": [
        [-1, -1, 7, -1],
        [7, -1, 7, 3],
        [7, 3, -1, 3],
        [-1, 3, -1, -1],
        [1.5, -1, 1.5, 2.0],  # A: the way on is above it (y 2.0..3.0)
        [4.0, 0.0, 4.0, 3.0],  # B: the way on is below it (y -1.0..0.0)
        [2.5, 1.0, 4.0, 1.0],  # C: closes a pocket above y = 1 against B
    ],
    "start": [0.0, 0.0, 0.0],
    "goal": [5.8, 2.0, 0.0],
}


async def test_a_maze_with_a_dead_end_is_solved_without_looping(tmp_path: Path) -> None:
    world = from_shapes(MAZE, "maze")
    async with session(world, tmp_path, lockstep=True, hold_clock=True) as s:
        await start(s, world)
        result = await outcome(s, limit_s=150.0)
    assert result.state == "reached", result
    assert s.sim.body.collisions == 0
    truth = np.array([(x, y) for _, x, y, _ in s.sim.truth])
    driven = float(np.hypot(*np.diff(truth, axis=0).T).sum())
    # The shortest way: over A, down between the walls, under B, up to the goal: ~10.5 m.
    assert driven < 3.0 * 10.5


async def test_gps_outage_indoors_does_not_stop_the_drive(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    datum = {"world": {"datum_latitude_deg": 48.0, "datum_longitude_deg": 11.5}}
    async with session(world, tmp_path, overrides=datum, lockstep=True, hold_clock=True) as s:
        await start(s, world)
        await until(lambda: "sim-gps" in s.sim.connected, 10.0)
        await until(lambda: s.sim.body.x_m > 1.0, 30.0)
        s.sim.sensors.gps_plugged = False  # under a roof: no more fixes
        result = await outcome(s)
    assert result.state == "reached", result
    assert s.sim.body.collisions == 0
    assert s.sim.body.x_m > 5.0


async def test_a_robot_kidnapped_mid_drive_is_held_finds_itself_and_reaches_its_goal(
    tmp_path: Path,
) -> None:
    # The hall is mapped on the way to its far end. On the way back the robot is picked up
    # and put down 3 m further on and 0.7 m aside; nobody tells navd. It must report itself
    # lost, hold the wheels still, find itself on the map without help, and finish the goal.
    # (Not turned half round as well: the hall is its own mirror image but for the pillar,
    # and a robot put down facing the other way sees nearly what it saw before.)
    world = from_shapes(HALL, "hall")
    async with session(world, tmp_path, lockstep=True, hold_clock=True) as s:
        await start(s, world)
        assert (await outcome(s)).state == "reached"
        await s.control.request(GoalFrame(x=0.5, y=0.0, yaw=math.pi, goal_id="back"))
        await s.control.request(SubscribeFrame(rate_hz=10))
        await until(lambda: s.sim.body.x_m < 4.3, 60.0)
        body = s.sim.body
        body.x_m, body.y_m = 1.2, -0.7
        kidnapped_at = s.sim.now()
        states: list[tuple[float, str, str]] = []  # (sim time, state, reason)
        result = GoalStatusFrame(goal_id="back", state="timeout")
        while s.sim.now() < kidnapped_at + 90.0:
            s.check()
            try:
                frame = await s.control.receive(1.0)
            except TimeoutError:
                continue
            if isinstance(frame, StatusFrame) and frame.diagnostics.localization is not None:
                where = frame.diagnostics.localization
                states.append((s.sim.now(), where.state, where.reason))
            if (
                isinstance(frame, GoalStatusFrame)
                and frame.goal_id == "back"
                and frame.state in ("reached", "failed", "canceled")
            ):
                result = frame
                break
    assert result.state == "reached", result
    assert s.sim.body.collisions == 0
    assert math.hypot(s.sim.body.x_m - 0.5, s.sim.body.y_m) <= 0.25
    # Reported lost, for scan matching's reason, then found again.
    lost = [(t, reason) for t, state, reason in states if state == "lost"]
    assert lost, states
    assert "scans in a row did not fit the map" in lost[0][1]
    found_at = max(t for t, _ in lost)
    assert any(state == "ok" for t, state, _ in states if t > found_at)
    # Held still while lost: the wheels were told to stop, and nothing else until found.
    wheels = s.sim.robot.wheels.log
    first, last = lost[0][0], lost[-1][0]
    assert (0, 0) in [(left, right) for t, left, right in wheels if first - 0.5 <= t <= first]
    assert {(left, right) for t, left, right in wheels if first <= t <= last} <= {(0, 0)}

"""The planner and the collision guard inside a running daemon, driven over the real TCP
protocol."""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import pytest

from navd.lifecycle.messages import (
    ConfigChange,
    CostmapUpdate,
    DriveCommand,
    Goal,
    GoalStatus,
    LaserScan,
    LocalTrajectory,
    Path,
    PoseEstimate,
    TrackingLost,
    VelocityCommand,
    ViewInterest,
)
from navd.logs import add_log_tap, remove_log_tap
from navd.planning.errors import GoalUnreachableError
from navd.planning.global_planner import GlobalPlanner
from navd.planning.node import PlannerNode
from navd.wire import (
    CancelFrame,
    GoalFrame,
    GoalStatusFrame,
    InitialPoseFrame,
    PathFrame,
    ScanFrame,
)
from tests.drivers.conftest import connected, record, running_daemon, until


def _room_scan(stamp: float, wall_x: float | None = None) -> ScanFrame:
    """A 360-beam scan of a 10 m square room around the origin, optionally with a wall across
    x = wall_x ahead."""
    angles = -math.pi + 2 * math.pi * np.arange(360) / 360
    ranges = 5.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))
    if wall_x is not None:
        ahead = np.cos(angles) > 1e-6
        ranges = np.where(
            ahead, np.minimum(ranges, wall_x / np.where(ahead, np.cos(angles), 1)), ranges
        )
    return ScanFrame(
        stamp=stamp,
        angle_min=-math.pi,
        angle_increment=2 * math.pi / 360,
        range_min=0.05,
        range_max=12.0,
        ranges=[round(float(r), 4) for r in ranges],
    )


async def test_a_goal_over_tcp_is_planned_and_driven_then_canceled() -> None:
    async with running_daemon() as (daemon, port):
        commands = record(daemon, VelocityCommand)
        paths = record(daemon, Path)
        statuses = record(daemon, GoalStatus)
        control = await connected(port, "control", "ui")
        await control.request(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.05))
        await control.request(GoalFrame(x=3.0, y=0.0, goal_id="g1"))
        frame = await control.receive_type(GoalStatusFrame)
        assert (frame.goal_id, frame.state) == ("g1", "active")
        route = await control.receive_type(PathFrame)  # control clients see the route too
        assert route.goal_id == "g1" and route.points[-1] == (3.0, 0.0)
        await until(lambda: bool(paths), timeout_s=10.0)
        assert paths[0].goal_id == "g1"
        assert np.allclose(paths[0].points_m[0], (0.0, 0.0), atol=0.05)
        assert np.allclose(paths[0].points_m[-1], (3.0, 0.0))
        planner = [c for c in commands if c.source == "planner"]
        await until(lambda: any(c.source == "planner" and c.linear_mps > 0 for c in commands))
        planner = [c for c in commands if c.source == "planner"]
        assert all(0.0 <= c.linear_mps <= 0.5 for c in planner)
        await control.request(CancelFrame())
        await until(lambda: any(s.state == "canceled" for s in statuses))
        assert [c for c in commands if c.source == "planner"][-1].is_stop
        await control.close()


async def test_the_collision_guard_stops_a_command_towards_a_close_wall() -> None:
    async with running_daemon() as (daemon, port):
        drives = record(daemon, DriveCommand)
        scans = record(daemon, LaserScan)
        lidar = await connected(port, "lidar", "front")
        lidar.send(_room_scan(10.0, wall_x=0.3))  # 0.1 m in front of a 0.2 m robot
        await until(lambda: bool(scans))

        def command(v: float, w: float = 0.0) -> DriveCommand:
            now = daemon.clock.now()
            daemon.bus.publish(
                VelocityCommand(stamp=now, received=now, linear_mps=v, angular_radps=w, source="t")
            )
            return drives[-1]

        forward = command(0.3)
        assert (forward.linear_mps, forward.angular_radps) == (0.0, 0.0)
        assert "obstacle" in forward.reason and "stop" in forward.reason
        backward = command(-0.1)
        assert backward.linear_mps == -0.1  # moving away is always allowed
        spin = command(0.0, 1.0)
        assert spin.angular_radps == 1.0  # a circle turning on the spot comes no closer
        lidar.send(_room_scan(10.1, wall_x=0.55))  # 0.35 m ahead: inside the slow zone
        await until(lambda: len(scans) >= 2)
        slow = command(0.3)
        assert 0.0 < slow.linear_mps < 0.3 and "slow" in slow.reason
        await lidar.close()


async def test_a_new_control_rate_applies_at_once_without_a_restart() -> None:
    async with running_daemon(lifecycle={"clock": "simulated"}) as (daemon, _):
        clock = daemon.clock
        commands = record(daemon, VelocityCommand)
        now = clock.now()
        # A goal and no pose: every control tick holds the robot ("no fresh pose estimate").
        daemon.bus.publish(Goal(stamp=now, received=now, goal_id="g", x_m=1.0, y_m=0.0))

        async def ticks_in(seconds: float) -> int:
            before = sum(c.source == "planner" for c in commands)
            await clock.run_to(clock.now() + seconds)
            return sum(c.source == "planner" for c in commands) - before

        assert abs(await ticks_in(1.0) - 20) <= 1
        now = clock.now()
        daemon.bus.publish(
            ConfigChange(
                stamp=now,
                received=now,
                request_id="r",
                changes={"planning.control_rate_hz": 5.0},
                privileged=True,  # as the config file may
            )
        )
        assert abs(await ticks_in(2.0) - 10) <= 1


async def test_planning_that_breaks_fails_its_goal_and_the_next_goal_plans(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    real_plan = GlobalPlanner.plan

    def out_of_memory(*args: object, **kwargs: object) -> object:
        raise MemoryError("a 200270 x 200235 grid")

    async with running_daemon() as (daemon, port):
        paths = record(daemon, Path)
        control = await connected(port, "control", "ui")
        await control.request(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.05))
        monkeypatch.setattr(GlobalPlanner, "plan", out_of_memory)
        await control.request(GoalFrame(x=3.0, y=0.0, goal_id="g1"))
        while (frame := await control.receive_type(GoalStatusFrame)).state == "active":
            pass
        assert (frame.goal_id, frame.state) == ("g1", "failed")
        assert frame.reason == "planning failed: MemoryError: a 200270 x 200235 grid"
        monkeypatch.setattr(GlobalPlanner, "plan", real_plan)
        await control.request(GoalFrame(x=2.0, y=1.0, goal_id="g2"))
        route = await control.receive_type(PathFrame)
        assert route.goal_id == "g2"
        assert [p.goal_id for p in paths] == ["g2"]
        assert daemon.supervisor.faulted() == {}
        assert daemon.supervisor.record("planner").failures == 1  # counted, not fatal
        await control.close()


async def test_one_goal_on_a_still_map_is_searched_once(monkeypatch: pytest.MonkeyPatch) -> None:
    searches: list[GlobalPlanner] = []
    real_plan = GlobalPlanner.plan

    def counted(self: GlobalPlanner, *args: Any, **kwargs: Any) -> Any:
        searches.append(self)
        time.sleep(0.08)  # a search that takes a while, as on an inflated map: steps go on
        return real_plan(self, *args, **kwargs)

    monkeypatch.setattr(GlobalPlanner, "plan", counted)
    async with running_daemon() as (daemon, port):
        (planner,) = [m for m in daemon.manager.modules if isinstance(m, PlannerNode)]
        control = await connected(port, "control", "ui")
        await control.request(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.05))
        await control.request(GoalFrame(x=3.0, y=0.0, goal_id="g1"))
        await control.receive_type(PathFrame)
        await asyncio.sleep(1.5)  # thirty control steps; the replan timer is 5 s away
        # (the warm-up's throwaway navigator searched too, with a planner of its own)
        assert [s for s in searches if s is planner.nav.global_planner] == [
            planner.nav.global_planner
        ]
        await control.close()


async def test_the_costmap_and_trajectory_are_made_only_while_a_viewer_asks() -> None:
    async with running_daemon() as (daemon, port):
        costmaps = record(daemon, CostmapUpdate)
        trajectories = record(daemon, LocalTrajectory)
        paths = record(daemon, Path)
        control = await connected(port, "control", "ui")
        lidar = await connected(port, "lidar", "front")
        await control.request(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.05))
        lidar.send(_room_scan(daemon.clock.now(), wall_x=2.0))
        await control.request(GoalFrame(x=1.0, y=1.0, goal_id="g1"))
        await until(lambda: bool(paths), timeout_s=10.0)
        await asyncio.sleep(0.3)
        assert not costmaps and not trajectories  # nobody watches: nothing made
        now = daemon.clock.now()
        daemon.bus.publish(ViewInterest(stamp=now, received=now, costmap=True, trajectory=True))
        await until(lambda: len(trajectories) >= 3, timeout_s=5.0)
        shown = trajectories[-1]
        assert shown.goal_id == "g1" and len(shown.points_m) > 5
        assert np.hypot(*shown.points_m[0]) < 0.3  # from the robot, where it drives
        await control.request(GoalFrame(x=1.0, y=-1.0, goal_id="g2"))  # a plan while watched
        await until(lambda: bool(costmaps), timeout_s=10.0)
        cells = costmaps[-1].occupancy
        res, x0 = costmaps[-1].resolution_m, costmaps[-1].origin_x_m
        wall_col = int((2.0 - x0) / res)
        assert (cells[:, wall_col - 1 : wall_col + 2] == 100).any()  # the wall is an obstacle
        assert cells.min() >= -1 and cells.max() == 100
        assert ((cells >= 0) & (cells < 99)).any()  # and there is free space around the robot
        daemon.bus.publish(ViewInterest(stamp=now, received=now, costmap=False, trajectory=False))
        await asyncio.sleep(0.1)
        counted = len(trajectories)
        await asyncio.sleep(0.3)
        assert len(trajectories) == counted
        await lidar.close()
        await control.close()


async def test_a_goal_waits_while_the_robot_is_lost_and_goes_on_once_it_is_found() -> None:
    async with running_daemon() as (daemon, port):
        commands = record(daemon, VelocityCommand)
        statuses = record(daemon, GoalStatus)
        estimates = record(daemon, PoseEstimate)
        control = await connected(port, "control", "ui")
        await control.request(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.05))
        await control.request(GoalFrame(x=3.0, y=0.0, goal_id="g1"))
        await until(lambda: any(c.source == "planner" and c.linear_mps > 0 for c in commands))
        now = daemon.clock.now()
        why = "scan matching lost the robot: a test says so"
        daemon.bus.publish(TrackingLost(stamp=now, received=now, lost=True, reason=why))
        await until(lambda: any(s.state == "paused" for s in statuses))
        paused = next(s for s in statuses if s.state == "paused")
        assert paused.goal_id == "g1" and paused.reason == f"waiting: {why}"
        # Stopped, and nothing but stops from the planner for as long as it is lost.
        held_from = len(commands)
        await asyncio.sleep(0.5)
        held = [c for c in commands[held_from - 1 :] if c.source == "planner"]
        assert held and all(c.is_stop for c in held)
        # Found: the goal goes on once an estimate made after the finding arrives.
        now = daemon.clock.now()
        daemon.bus.publish(TrackingLost(stamp=now, received=now, lost=False, reason="found"))
        await until(lambda: any(e.received >= now for e in estimates))
        await until(
            lambda: any(
                c.source == "planner" and c.linear_mps > 0 and c.stamp > now for c in commands
            )
        )
        assert statuses[-1].goal_id == "g1" and statuses[-1].state == "active"
        await control.close()


async def test_a_search_failing_the_same_way_is_logged_once_a_while_not_at_every_tick(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    searches = 0

    def occupied(*args: object, **kwargs: object) -> object:
        nonlocal searches
        searches += 1
        raise GoalUnreachableError("goal (3.00, 0.00) m is occupied: another robot", "occupied")

    monkeypatch.setattr(GlobalPlanner, "plan", occupied)
    said: list[dict[str, Any]] = []

    def heard(event: Mapping[str, Any]) -> None:
        said.append(dict(event))

    add_log_tap(heard)
    try:
        async with running_daemon() as (daemon, port):
            (planner,) = [m for m in daemon.manager.modules if isinstance(m, PlannerNode)]
            control = await connected(port, "control", "ui")
            await control.request(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.05))
            await control.request(GoalFrame(x=3.0, y=0.0, goal_id="g1"))
            await until(lambda: searches >= 5, timeout_s=30.0)  # tried again at every tick
            failed = [s for s in said if s["event"] == "plan_failed"]
            assert len(failed) == 1 and failed[0]["repeats"] == 0
            assert "occupied: another robot" in failed[0]["error"]
            assert planner.nav.goal is not None  # still waiting for the goal to clear
            await control.close()
    finally:
        remove_log_tap(heard)

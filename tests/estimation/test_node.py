"""The estimation module inside a running daemon, fed through the real TCP protocol."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pyproj import Geod

from navd.lifecycle.messages import (
    DriveCommand,
    LocalizationState,
    PoseEstimate,
    SafeStop,
    SafeStopCleared,
    VelocityCommand,
)
from navd.wire import (
    AsyncClient,
    FixFrame,
    GoalFrame,
    GoalStatusFrame,
    InitialPoseFrame,
    StatusFrame,
    SubscribeFrame,
)
from tests.drivers.conftest import connected, record, running_daemon, until

LOST_FAST = {"degraded_position_std_m": 0.2, "lost_position_std_m": 0.4}


async def test_initial_pose_then_silence_degrades_to_lost_and_stops_the_robot() -> None:
    async with running_daemon(estimation=LOST_FAST) as (daemon, port):
        poses = record(daemon, PoseEstimate)
        states = record(daemon, LocalizationState)
        stops = record(daemon, SafeStop)
        cleared = record(daemon, SafeStopCleared)
        drives = record(daemon, DriveCommand)
        control = await connected(port, "control", "ui")
        await control.request(InitialPoseFrame(x=2.0, y=-1.0, yaw=0.5, std_xy=0.05))
        await until(lambda: bool(poses))
        assert (poses[0].x_m, poses[0].y_m, poses[0].yaw_rad) == pytest.approx((2.0, -1.0, 0.5))
        # No position source: the uncertainty grows until localization is lost.
        await until(lambda: any(s.state == "lost" for s in states), timeout_s=5.0)
        seen = [s.state for s in states]
        assert seen.index("ok") < seen.index("degraded") < seen.index("lost")
        assert [s.key for s in stops] == ["localization"]
        now = daemon.clock.now()
        daemon.bus.publish(
            VelocityCommand(stamp=now, received=now, linear_mps=0.3, angular_radps=0.0, source="t")
        )
        assert (drives[-1].linear_mps, drives[-1].angular_radps) == (0.0, 0.0)
        assert "localization lost" in drives[-1].reason
        # A new pose brings localization back and releases the robot.
        control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.05))
        await until(lambda: bool(cleared))
        assert cleared[0].key == "localization"
        status = await _status(control)
        assert status.diagnostics.localization is not None
        assert status.diagnostics.localization.state in ("ok", "degraded")
        await control.close()


async def _status(control: AsyncClient) -> StatusFrame:
    await control.request(SubscribeFrame(rate_hz=20))
    return await control.receive_type(StatusFrame)


async def test_gps_fixes_over_tcp_land_in_the_map_frame_of_the_datum() -> None:
    datum = {"datum_latitude_deg": 48.0, "datum_longitude_deg": 11.5}
    async with running_daemon(world=datum) as (daemon, port):
        poses = record(daemon, PoseEstimate)
        gps = await connected(port, "gps", "gps0")
        lon, lat, _ = Geod(ellps="WGS84").fwd(11.5, 48.0, 0.0, 30.0)  # 30 m true north
        for i in range(3):
            gps.send(
                FixFrame(
                    stamp=100.0 + 0.2 * i,
                    latitude=lat,
                    longitude=lon,
                    altitude=500.0,
                    horizontal_accuracy=0.5,
                )
            )
        await until(lambda: bool(poses))
        pose = poses[-1]
        assert math.hypot(pose.x_m, pose.y_m) == pytest.approx(30.0, abs=0.05)
        assert pose.y_m > 29.9  # north is +y (to the UTM grid convergence here, < 0.1 m)
        assert np.all(np.linalg.eigvalsh(pose.covariance) > 0.0)
        await gps.close()


async def test_a_latitude_longitude_goal_becomes_a_map_goal_through_the_datum() -> None:
    from navd.lifecycle.messages import Goal

    datum = {"datum_latitude_deg": 48.0, "datum_longitude_deg": 11.5}
    async with running_daemon(world=datum) as (daemon, port):
        goals = record(daemon, Goal)
        control = await connected(port, "control", "ui")
        await until(lambda: daemon_estimator_ready(daemon))
        lon, lat, _ = Geod(ellps="WGS84").fwd(11.5, 48.0, 90.0, 20.0)  # 20 m east
        await control.request(GoalFrame(latitude=lat, longitude=lon, goal_id="east"))
        await until(lambda: bool(goals))
        assert goals[0].goal_id == "east"
        # The map frame is the UTM grid (zone 32 here) shifted to the datum.
        from pyproj import Proj

        utm = Proj(proj="utm", zone=32, ellps="WGS84")
        e0, n0 = utm(11.5, 48.0)
        e1, n1 = utm(lon, lat)
        assert (goals[0].x_m, goals[0].y_m) == pytest.approx((e1 - e0, n1 - n0), abs=0.01)
        assert math.hypot(goals[0].x_m, goals[0].y_m) == pytest.approx(20.0, abs=0.05)
        await control.close()


async def test_a_latitude_longitude_goal_without_a_datum_fails_with_the_reason() -> None:
    async with running_daemon() as (daemon, port):
        control = await connected(port, "control", "ui")
        await until(lambda: daemon_estimator_ready(daemon))
        control.send(GoalFrame(latitude=48.0, longitude=11.5, goal_id="g"))
        status = await control.receive_type(GoalStatusFrame)
        assert (status.goal_id, status.state) == ("g", "failed")
        assert "no GPS datum yet" in status.reason
        await control.close()


def daemon_estimator_ready(daemon: object) -> bool:
    from navd.estimation.node import EstimationNode

    node = next(m for m in daemon.manager.modules if isinstance(m, EstimationNode))  # type: ignore[attr-defined]
    return node.estimator is not None

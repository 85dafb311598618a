"""Velocity profile, stuck monitor and collision guard: exact values in small tables."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.geometry import IDENTITY, Footprint, LidarMount, Pose2, SensorMounts
from navd.lifecycle.messages import LaserScan
from navd.planning.guard import GuardSettings, guard_scale
from navd.planning.guard_node import CollisionGuard
from navd.planning.profile import VelocityProfile
from navd.planning.settings import guard_settings, stuck_settings
from navd.planning.stuck import StuckMonitor, StuckPhase

PROFILE = VelocityProfile(0.5, 0.05, 0.5, 1.0, 1.0, (0.0, 0.5), (1.5, 0.8), 2.0)


@pytest.mark.parametrize(
    ("remaining", "moving", "expected"),
    [
        (10.0, 5.0, 0.5),  # cruising
        (10.0, 0.5, 0.5 * 0.125),  # start ramp (t/T)^3
        (10.0, 0.0, 0.05),  # never below the minimum
        (0.5, 5.0, 0.25),  # approach taper 0.5 * d / 1 m (sqrt(2 a d) = 0.707 is looser)
        (0.01, 5.0, 0.05),  # floor near the goal
    ],
)
def test_speed_cap(remaining: float, moving: float, expected: float) -> None:
    assert PROFILE.speed_cap(remaining, moving) == pytest.approx(expected)


def test_braking_distance_limits_the_cap_when_it_is_tighter() -> None:
    gentle = VelocityProfile(2.0, 0.0, 0.5, 0.0, 0.0, (0.0,), (1.0,), 2.0)
    assert gentle.speed_cap(1.0, 10.0) == pytest.approx(math.sqrt(2 * 0.5 * 1.0))


@pytest.mark.parametrize(
    ("v", "w"), [(0.0, 1.5), (0.25, 1.15), (0.5, 0.8), (1.0, 0.8), (-0.25, 1.15)]
)
def test_yaw_rate_table_is_interpolated(v: float, w: float) -> None:
    assert PROFILE.yaw_rate_cap(v) == pytest.approx(w)


@pytest.mark.parametrize(
    ("error", "rate"),
    [
        (2.0, 1.5),  # far: the table's rate standing still
        (-2.0, -1.5),  # the sign of the error
        (0.5, 1.0),  # near: sqrt(a |e|) with a = 2 rad/s^2, braking at half of it
        (-0.08, -0.4),
        (0.0, 0.0),
    ],
)
def test_a_turn_on_the_spot_runs_at_the_top_rate_until_it_must_brake(
    error: float, rate: float
) -> None:
    assert PROFILE.turn_rate(error) == pytest.approx(rate)


def test_stuck_monitor_phases_follow_the_configured_times() -> None:
    config = NavdConfig.model_validate(
        {
            "planning": {
                "stuck_time_s": 1.0,
                "stuck_time_force_backward_s": 2.0,
                "max_stuck_time_s": 4.0,
                "backup_distance_m": 0.3,
            }
        }
    )
    monitor = StuckMonitor(stuck_settings(config.planning, config.robot))
    phases = {t: monitor.update(t, Pose2(0.0, 0.0, 0.0)) for t in (0.0, 0.5, 1.5, 1.9)}
    assert [p.phase for p in phases.values()] == [StuckPhase.MOVING] * 2 + [StuckPhase.PUSHING] * 2
    # The minimum speed rises linearly from min to max speed over max_stuck_time.
    assert phases[1.5].min_speed_mps == pytest.approx(0.05 + 0.45 * 1.5 / 4.0)
    assert monitor.update(2.1, Pose2(0.0, 0.0, 0.0)).phase is StuckPhase.BACKING
    # Backing holds even though moving 0.1 m would count as progress, until 0.3 m.
    assert monitor.update(2.5, Pose2(-0.15, 0.0, 0.0)).phase is StuckPhase.BACKING
    assert monitor.update(3.0, Pose2(-0.31, 0.0, 0.0)).phase is StuckPhase.BACKED_OUT
    assert monitor.update(3.1, Pose2(-0.31, 0.0, 0.0)).phase is StuckPhase.MOVING
    # Turning counts as progress too.
    monitor.update(5.0, Pose2(0.0, 0.0, 0.0))
    assert monitor.update(5.9, Pose2(0.0, 0.0, 0.6)).phase is StuckPhase.MOVING
    assert monitor.update(10.5, Pose2(0.0, 0.0, 0.6)).phase is StuckPhase.STUCK


MOUNTS = SensorMounts(LidarMount(IDENTITY, 0.1))
GUARD = GuardSettings(Footprint.rectangle(0.4, 0.3), 0.15, 0.5, 0.4, 0.5, 2.0, 0.05, True, MOUNTS)


@pytest.mark.parametrize(
    ("wall_x", "v", "w", "scale"),
    [
        (3.0, 0.5, 0.0, 1.0),  # far: braking 1 s + one period sweeps 0.525 m
        (1.1, 0.5, 0.0, 0.4),  # 0.9 m ahead, the sweep leaves 0.375 m: slow down
        (0.6, 0.5, 0.0, 0.0),  # 0.4 m ahead, the sweep reaches the wall: stop
        (0.6, -0.2, 0.0, 1.0),  # backing away
        (0.3, 0.0, 1.0, 0.0),  # the corners (0.25 m out) swing into a wall 0.1 m ahead
        (0.6, 0.0, 1.0, 0.4),  # they come within 0.35 m: slow
        (0.8, 0.0, 1.0, 1.0),  # a turn on the spot that stays 0.55 m clear
    ],
)
def test_guard_scales_by_the_clearance_of_the_braking_sweep(wall_x, v, w, scale) -> None:
    wall = np.column_stack([np.full(201, wall_x), np.linspace(-1.0, 1.0, 201)])
    assert guard_scale(wall, v, w, GUARD)[0] == scale


def test_guard_stops_every_move_until_its_kernel_is_loaded() -> None:
    """A fresh process (as the daemon before its warm-up): the guard is asked on the event
    loop, which must not compile, so it stops the robot rather than pass a command unchecked."""
    code = (
        "import numpy as np\n"
        "from navd.planning.guard import guard_scale, warm_up_guard\n"
        "from navd.planning.settings import default_guard\n"
        "s = default_guard()\n"
        "far = np.array([[9.0, 9.0]])\n"
        "print(guard_scale(far, 0.3, 0.0, s))\n"
        "warm_up_guard(s)\n"
        "print(guard_scale(far, 0.3, 0.0, s))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=True
    )
    before, after = done.stdout.splitlines()
    assert before.startswith("(0.0, 'collision guard starting")
    assert after == "(1.0, '')"


def test_guard_passes_everything_when_collisions_are_off() -> None:
    disabled = dataclasses.replace(GUARD, enabled=False)
    wall = np.column_stack([np.full(201, 0.25), np.linspace(-1.0, 1.0, 201)])
    assert guard_scale(wall, 0.5, 0.0, disabled) == (1.0, "")


def _half_scan(device_id: str, ranges: list[float]) -> LaserScan:
    """A 180° sweep of four rays from -90° to +90° (the lidar's own frame)."""
    return LaserScan(
        stamp=1.0,
        received=1.0,
        device_id=device_id,
        angle_min=-math.pi / 2,
        angle_increment=math.pi / 3,
        ranges=np.array(ranges, dtype=np.float32),
        range_min=0.05,
        range_max=10.0,
    )


def test_the_guard_sees_what_either_of_two_lidars_sees() -> None:
    config = NavdConfig.model_validate(
        {
            "mounts": {
                "lidars": {
                    "front": {"x_m": 0.1},
                    "rear": {"x_m": -0.1, "yaw_rad": 3.1416, "upside_down": True},
                }
            }
        }
    )
    guard = CollisionGuard()
    guard.settings = SimpleNamespace(value=guard_settings(config))  # type: ignore[assignment]
    far = 9.0
    guard._on_scan(_half_scan("front", [far, far, far, far]))
    guard._on_scan(_half_scan("rear", [far, 0.2, 0.2, far]))  # something right behind
    back = guard.limit(-0.2, 0.0)
    assert back[0] == 0.0 and "obstacle" in back[2]  # the rear lidar's: no reversing
    assert guard.limit(0.3, 0.0) == (0.3, 0.0, "")  # the way ahead is free
    guard._on_scan(_half_scan("front", [far, 0.25, 0.25, far]))  # and now ahead too
    assert guard.limit(0.3, 0.0)[0] == 0.0
    assert guard.limit(-0.2, 0.0)[0] == 0.0  # the rear lidar's latest still counts

"""Where beacon, gate and approach steps send the robot, worked out by hand."""

from __future__ import annotations

import math

import pytest

from navd.geometry import Pose2
from navd.lifecycle.messages import MissionStep
from navd.missions import UnknownBeaconError
from navd.missions.waypoints import (
    GATE_SIDE_M,
    STAGING_M,
    approach_pose,
    beacon_waypoints,
    waypoint_pose,
)

PLACES = {"a": (0.0, 0.0), "b": (0.0, 2.0), "far": (10.0, 0.0), "near": (2.0, 0.0)}


@pytest.mark.parametrize(("robot_x", "crossing_yaw"), [(-3.0, 0.0), (3.0, math.pi)])
def test_a_gate_is_crossed_square_to_its_line_from_the_robots_side(
    robot_x: float, crossing_yaw: float
) -> None:
    gate = MissionStep(kind="gate", beacons=("a", "b"))
    before, beyond = beacon_waypoints(gate, PLACES, Pose2(robot_x, 1.0, 0.0))
    side = math.copysign(GATE_SIDE_M, robot_x)
    assert (before.x_m, before.y_m) == pytest.approx((side, 1.0))
    assert (beyond.x_m, beyond.y_m) == pytest.approx((-side, 1.0))
    assert math.cos(before.yaw_rad - crossing_yaw) == pytest.approx(1.0)  # type: ignore[operator]


def test_beacons_are_visited_nearest_first_from_where_the_robot_is() -> None:
    visit = MissionStep(kind="visit_beacons", beacons=("far", "near"), stop_distance_m=0.5)
    order = beacon_waypoints(visit, PLACES, Pose2(1.0, 0.0, 0.0))
    assert [(w.x_m, w.y_m) for w in order] == [(2.0, 0.0), (10.0, 0.0)]
    assert all(w.short_m == 0.5 for w in order)


def test_a_beacon_with_no_place_is_named() -> None:
    with pytest.raises(UnknownBeaconError, match="beacon ghost has no place"):
        beacon_waypoints(MissionStep(kind="beacon", beacons=("ghost",)), PLACES, None)


def test_a_beacon_goal_stops_short_facing_it_or_stays_when_already_near() -> None:
    point = beacon_waypoints(
        MissionStep(kind="beacon", beacons=("far",), stop_distance_m=1.0), PLACES, None
    )[0]
    assert waypoint_pose(point, Pose2(0.0, 0.0, 2.0)) == pytest.approx((9.0, 0.0, 0.0))
    x, y, yaw = waypoint_pose(point, Pose2(10.0, 0.5, 0.0))
    assert (x, y) == (10.0, 0.5)
    assert yaw == pytest.approx(-math.pi / 2)


def test_an_approach_stages_then_stops_along_the_line_it_came_on() -> None:
    step = MissionStep(kind="approach", x_m=4.0, y_m=3.0, stop_distance_m=1.0)
    start = Pose2(0.0, 0.0, 0.0)  # the line from it: (0.8, 0.6) a metre
    stop = approach_pose(step, start, final=True)
    stage = approach_pose(step, start, final=False)
    assert stop == pytest.approx((3.2, 2.4, math.atan2(3.0, 4.0)))
    back = 1.0 + STAGING_M
    assert stage == pytest.approx((4.0 - 0.8 * back, 3.0 - 0.6 * back, math.atan2(3.0, 4.0)))

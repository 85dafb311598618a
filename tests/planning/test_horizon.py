"""Far goals: a coarse route over the whole area and the fine route in a window that rolls
with the robot; sizes bounded whatever the distance; a wall beyond the window is planned
around on the coarse grid, and one in it on the fine grid."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.geometry import IDENTITY
from navd.planning.goal import GoalState, NavGoal
from navd.planning.horizon import COARSE_MAX_CELLS
from navd.planning.navigator import Navigator
from navd.planning.settings import NavigatorSettings
from tests.planning.drive import drive


def config(**planning: object) -> NavdConfig:
    return NavdConfig.model_validate({"planning": planning})


@pytest.mark.parametrize("distance_m", [60.0, 500.0, 5000.0])
def test_a_far_goal_plans_on_a_window_and_a_coarse_grid_whatever_its_distance(
    distance_m: float,
) -> None:
    nav = Navigator(NavigatorSettings.from_config(config(max_goal_distance_m=10_000.0)))
    nav.set_goal(NavGoal("g", distance_m, 0.0))
    request = nav.request(0.0, IDENTITY)
    assert request.coarse is not None
    # the window: 30 m at 5 cm cells, around the robot, whatever the distance
    assert (request.frame.rows, request.frame.cols) == (600, 600)
    assert request.coarse.frame.rows * request.coarse.frame.cols <= COARSE_MAX_CELLS
    path = request.solve(nav.global_planner)
    assert path.fine_length_m is not None and 10.0 < path.fine_length_m < 15.0
    assert tuple(path.points_m[-1]) == (distance_m, 0.0)
    assert path.points_m[:, 1] == pytest.approx(0.0, abs=0.5)  # open ground: straight on


def test_a_near_goal_or_one_on_a_small_map_is_planned_whole() -> None:
    nav = Navigator(NavigatorSettings.from_config(config()))
    nav.set_goal(NavGoal("g", 8.0, 0.0))
    assert nav.request(0.0, IDENTITY).coarse is None
    occupancy = np.zeros((400, 1600), dtype=np.int8)  # an 80 x 20 m map: 640k cells
    nav.set_map(occupancy, 0.05, -10.0, -10.0)
    nav.set_goal(NavGoal("g", 60.0, 0.0))
    assert nav.request(0.0, IDENTITY).coarse is None


def test_a_wall_beyond_the_window_is_planned_around_on_the_coarse_grid() -> None:
    nav = Navigator(NavigatorSettings.from_config(config()))
    # a mapped 200 x 60 m area (2.4M cells: more than max_plan_cells) with a wall across
    # it at x = 50 m, open only at its north end (y 25..30)
    res = 0.05
    occupancy = np.zeros((round(60 / res), round(200 / res)), dtype=np.int8)
    col = round((50.0 + 20.0) / res)
    occupancy[: round((25.0 + 30.0) / res), col : col + 4] = 100
    nav.set_map(occupancy, res, -20.0, -30.0)
    nav.set_goal(NavGoal("g", 120.0, 0.0))
    request = nav.request(0.0, IDENTITY)
    assert request.coarse is not None
    path = request.solve(nav.global_planner)
    near_wall = path.points_m[np.abs(path.points_m[:, 0] - 50.0) < 1.0]
    # through the opening (the coarse route may round its corner by a block)
    assert near_wall.size and (near_wall[:, 1] > 24.5).all()


def test_the_robot_drives_to_a_goal_beyond_its_window_around_a_wall_it_meets() -> None:
    # a 20 m window and a wall across the way 12 m out, seen only when the robot is near
    cfg = NavdConfig.model_validate(
        {"robot": {"footprint": "rectangle"}, "planning": {"local_window_m": 20.0}}
    )
    wall = np.array([[12.0, -3.0, 12.0, 3.0]])
    goal = NavGoal("g", 30.0, 0.0)
    result = drive(cfg, wall, IDENTITY, goal, max_time_s=150, known_map=False)
    assert result.state is GoalState.REACHED
    x, y, _ = result.poses[-1]
    assert math.hypot(x - 30.0, y) <= cfg.planning.goal_xy_tolerance_m
    assert result.plan_reasons.count("near the end of the planning window") >= 2
    assert result.min_clearance_m > 0.0

"""The navigator driving a kinematic robot: arrival, heading, obstacles, dead ends, failures."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from navd.bench.synthetic_room import WALLS
from navd.config import NavdConfig
from navd.geometry import IDENTITY, Pose2
from navd.planning.dwa import LocalPlanner
from navd.planning.errors import GoalRefusedError
from navd.planning.goal import GoalState, NavGoal
from navd.planning.navigator import Navigator
from navd.planning.settings import NavigatorSettings
from navd.planning.stuck import StuckPhase
from tests.planning.drive import drive

NO_WALLS = np.empty((0, 4))


def config(**planning: object) -> NavdConfig:
    return NavdConfig.model_validate({"robot": {"footprint": "rectangle"}, "planning": planning})


@pytest.mark.parametrize("goal", [(3.0, 0.0), (2.0, 2.0), (-2.0, 1.0)])
def test_reaches_a_goal_in_free_space_and_stops_within_tolerance(goal) -> None:
    cfg = config()
    result = drive(cfg, NO_WALLS, IDENTITY, NavGoal("g", *goal), max_time_s=40, known_map=False)
    assert result.state is GoalState.REACHED
    x, y, _ = result.poses[-1]
    assert math.hypot(x - goal[0], y - goal[1]) <= cfg.planning.goal_xy_tolerance_m
    assert result.steps[-1].linear_mps == 0.0 and result.steps[-1].angular_radps == 0.0


@pytest.mark.parametrize("yaw", [math.pi / 2, math.pi, -2.5])
def test_turns_to_the_target_heading(yaw: float) -> None:
    cfg = config()
    result = drive(
        cfg, NO_WALLS, IDENTITY, NavGoal("g", 2.0, 0.0, yaw), max_time_s=40, known_map=False
    )
    assert result.state is GoalState.REACHED
    x, y, heading = result.poses[-1]
    assert math.hypot(x - 2.0, y) <= cfg.planning.goal_xy_tolerance_m
    assert (
        abs((heading - yaw + math.pi) % (2 * math.pi) - math.pi)
        <= cfg.planning.goal_yaw_tolerance_rad
    )


@pytest.mark.parametrize("goal", [(-0.37, 0.12, -0.54), (-0.6, -0.3, 0.3), (0.1, -0.5, 2.0)])
def test_a_near_goal_behind_the_robot_facing_away_is_driven_to_then_turned_on(
    goal: tuple[float, float, float],
) -> None:
    # within the approach distance, a goal the robot must back into if it faced the goal's
    # heading: it drives there facing the way, then turns (it used to turn first, to the
    # goal's heading, and creep away from the goal for good)
    cfg = config()
    result = drive(cfg, NO_WALLS, IDENTITY, NavGoal("g", *goal), max_time_s=30, known_map=False)
    assert result.state is GoalState.REACHED
    x, y, heading = result.poses[-1]
    assert math.hypot(x - goal[0], y - goal[1]) <= cfg.planning.goal_xy_tolerance_m
    assert abs(math.remainder(heading - goal[2], math.tau)) <= cfg.planning.goal_yaw_tolerance_rad
    # and never farther from the goal than it started, give or take a turn's swing
    start = math.hypot(goal[0], goal[1])
    assert max(math.hypot(px - goal[0], py - goal[1]) for px, py, _ in result.poses) < start + 0.1


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_goal_abeam_is_turned_to_on_the_spot_then_driven_to_and_turned_on(side: float) -> None:
    # 0.45 m to the side, to be reached facing the way the robot faces now. The local planner
    # alone turned ever slower as it came round, creeping forward (12 s to get there); the
    # robot now turns on the spot at its top rate until it must brake, both ways.
    cfg = config()
    goal = NavGoal("g", 0.0, side * 0.45, 0.0)
    result = drive(cfg, NO_WALLS, IDENTITY, goal, max_time_s=30, known_map=False)
    assert result.state is GoalState.REACHED
    period_s = 1.0 / cfg.planning.control_rate_hz
    first_move = next(i for i, (v, _) in enumerate(result.commands) if v > 0.0)
    # the route is 90 degrees off: no forward motion before the robot faces it within 20 deg
    assert abs(math.remainder(result.poses[first_move][2] - side * math.pi / 2, math.tau)) < 0.35
    assert first_move * period_s < 2.0  # a quarter turn, accelerating and braking
    assert result.time_s < 7.0


@pytest.mark.parametrize("turning", [-0.3, -1.0])
def test_a_robot_turning_the_other_way_when_a_goal_comes_turns_round_to_it(
    turning: float,
) -> None:
    # The route is up and to the left; the robot is still turning right (from its last
    # goal). It stops that turn and turns left on the spot: it used to take the turn the
    # other way for a goal to the left (aimed too far round) or give the turn up at once.
    goal = NavGoal("g", -1.0, 1.0)
    cfg = config()
    still = drive(cfg, NO_WALLS, IDENTITY, goal, max_time_s=30, known_map=False)
    result = drive(
        cfg, NO_WALLS, IDENTITY, goal, max_time_s=30, known_map=False, turning_radps=turning
    )
    assert still.state is GoalState.REACHED and result.state is GoalState.REACHED
    assert result.time_s <= still.time_s + 1.0
    # it never turned right farther than stopping a turn of that rate takes (and a margin)
    braking = turning**2 / (2 * cfg.robot.max_angular_accel_radps2)
    assert min(p[2] for p in result.poses) > -(braking + 0.1)


def test_the_last_turn_on_the_spot_does_not_slow_as_it_comes_round() -> None:
    cfg = config()
    result = drive(
        cfg, NO_WALLS, IDENTITY, NavGoal("g", 1.0, 0.0, math.pi / 2), max_time_s=30, known_map=False
    )
    assert result.state is GoalState.REACHED
    period_s = 1.0 / cfg.planning.control_rate_hz
    arrived = next(i for i, (x, y, _) in enumerate(result.poses) if math.hypot(x - 1.0, y) <= 0.15)
    # A quarter turn less the 0.2 rad tolerance at up to 1.25 rad/s (the aim's cap over the
    # 2 s horizon), braking at 1 rad/s^2: under 2 s; the local planner's own turn took 4 s,
    # never faster than 0.7 rad/s.
    assert (len(result.poses) - arrived) * period_s < 2.5
    assert max(abs(w) for _, w in result.commands[arrived:]) >= 1.2


def test_a_turn_on_the_spot_that_slows_against_walls_is_given_up_before_the_stuck_monitor(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A corridor too narrow for the rectangle to turn round in, the goal behind: its turn
    # toward the route slows as its corners near the walls; once under half the rate it wants
    # it is left to the local planner (before, it went on until the stuck monitor ended it).
    turns: list[bool] = []
    choose = LocalPlanner.choose

    def spy(self: LocalPlanner, *args: Any) -> Any:
        turns.append(args[-1].rotate_only)
        return choose(self, *args)

    monkeypatch.setattr(LocalPlanner, "choose", spy)
    walls = np.array([(-4.0, 0.34, 4.0, 0.34), (-4.0, -0.34, 4.0, -0.34)])
    cfg = config()
    result = drive(cfg, walls, IDENTITY, NavGoal("g", -2.0, 0.0), max_time_s=8, known_map=False)
    period_s = 1.0 / cfg.planning.control_rate_hz
    tried = turns.index(False)  # the turn on the spot came first, then the usual choice
    assert 0 < tried * period_s < cfg.planning.stuck_time_s - 1.0
    assert result.min_clearance_m >= cfg.safety.collision_distance_m - 0.02


def test_drives_through_the_room_without_touching_a_wall() -> None:
    cfg = config()
    result = drive(
        cfg, WALLS, Pose2(-5.0, -3.0, 0.0), NavGoal("g", 0.0, 2.5, math.pi / 2), max_time_s=80
    )
    assert result.state is GoalState.REACHED
    assert result.min_clearance_m >= cfg.safety.collision_distance_m - 0.02


def test_an_obstacle_missing_from_the_map_blocks_the_route_and_is_driven_around() -> None:
    # The map is empty; a wall across the straight route is only seen by the lidar.
    wall = np.array([(1.5, -1.0, 1.5, 1.0)])
    cfg = config()
    result = drive(cfg, wall, IDENTITY, NavGoal("g", 3.0, 0.0), max_time_s=60, known_map=False)
    assert result.state is GoalState.REACHED
    assert "route blocked by an obstacle" in result.plan_reasons
    assert result.min_clearance_m >= cfg.safety.collision_distance_m - 0.02
    assert max(abs(p[1]) for p in result.poses) > 1.0  # it went round the end of the wall


def test_a_robot_facing_a_dead_end_backs_out_and_replans() -> None:
    # A narrow pocket (0.6 m) the 0.4 x 0.3 m robot cannot turn in; the goal is behind its end.
    pocket = np.array([(1.2, 0.3, 2.0, 0.3), (1.2, -0.3, 2.0, -0.3), (2.0, -0.3, 2.0, 0.3)])
    cfg = NavdConfig.model_validate(
        {
            "robot": {"footprint": "rectangle"},
            # 0.15 m each side in the pocket: the guard's stop distance must be below that.
            "safety": {"stop_distance_m": 0.1},
            "planning": {
                "stuck_time_s": 1.0,
                "stuck_time_force_backward_s": 2.0,
                "max_stuck_time_s": 8.0,
                "backup_distance_m": 0.6,
            },
        }
    )
    result = drive(
        cfg,
        pocket,
        Pose2(1.6, 0.0, 0.0),
        NavGoal("g", 3.5, 0.0),
        max_time_s=80,
        map_box=(-1, -2, 5, 2),
    )
    assert result.state is GoalState.REACHED
    phases = [s.phase for s in result.steps]
    assert StuckPhase.BACKING in phases
    assert "backed out" in result.plan_reasons
    assert min(c[0] for c in result.commands) < 0.0  # it drove backwards
    assert min(p[0] for p in result.poses) < 1.2 - 0.2  # out of the pocket
    assert result.min_clearance_m >= cfg.safety.collision_distance_m - 0.02


def test_an_unreachable_goal_fails_with_the_reason_after_the_patience() -> None:
    box = np.array(
        [(2.0, -0.5, 3.0, -0.5), (3.0, -0.5, 3.0, 0.5), (3.0, 0.5, 2.0, 0.5), (2.0, 0.5, 2.0, -0.5)]
    )
    cfg = config(stuck_time_s=1.0, stuck_time_force_backward_s=2.0, max_stuck_time_s=3.0)
    result = drive(
        cfg, box, IDENTITY, NavGoal("g", 2.5, 0.0), max_time_s=20, map_box=(-1, -2, 5, 2)
    )
    assert result.state is GoalState.FAILED
    assert "no route" in result.steps[-1].reason
    assert all(c == (0.0, 0.0) for c in result.commands)
    assert result.time_s == pytest.approx(3.0, abs=0.1)


def test_a_goal_beyond_the_distance_limit_fails_at_once_with_the_reason() -> None:
    nav = Navigator(NavigatorSettings.from_config(config(max_goal_distance_m=50.0)))
    nav.set_goal(NavGoal("g", 40.0, 40.0))
    with pytest.raises(GoalRefusedError) as refused:
        nav.request(0.0, IDENTITY)
    nav.plan_failed(0.0, refused.value)
    assert nav.state is GoalState.FAILED
    assert "is 57 m from the robot" in nav.failure  # hypot(40, 40)
    assert "planning.max_goal_distance_m (50 m)" in nav.failure
    step = nav.step(0.1, IDENTITY)
    assert (step.linear_mps, step.angular_radps, step.reason) == (0.0, 0.0, nav.failure)


def test_stuck_for_good_fails_after_the_allowed_replans() -> None:
    # A ring 0.3 m round the robot with a gap ahead of it to the right (-y): the route leaves
    # through the gap, but the 0.4 x 0.3 m robot faces +y and cannot turn or move in the ring.
    a = np.linspace(-math.pi / 2 + 1.2, 3 * math.pi / 2 - 1.2, 40)
    arc_ = np.column_stack([0.3 * np.cos(a), 0.3 * np.sin(a)])
    ring = np.column_stack([arc_[:-1], arc_[1:]])
    cfg = config(
        stuck_time_s=0.5, stuck_time_force_backward_s=1.0, max_stuck_time_s=1.5, max_stuck_replans=1
    )
    result = drive(
        cfg,
        ring,
        Pose2(0.0, 0.0, math.pi / 2),
        NavGoal("g", 0.0, -3.0),
        max_time_s=20,
        known_map=False,
    )
    assert result.state is GoalState.FAILED
    assert "stuck" in result.steps[-1].reason
    assert sum(s.stuck_detected for s in result.steps) == 2


def test_cancel_stops_the_robot() -> None:
    nav = Navigator(NavigatorSettings.from_config(config()))
    nav.set_goal(NavGoal("g", 3.0, 0.0))
    nav.accept_plan(0.0, nav.plan(0.0, IDENTITY))
    for k in range(30):
        step = nav.step(0.05 * k, IDENTITY)
    assert step.linear_mps > 0.0
    assert nav.cancel() == NavGoal("g", 3.0, 0.0)
    step = nav.step(2.0, IDENTITY)
    assert (step.linear_mps, step.angular_radps, step.state) == (0.0, 0.0, GoalState.CANCELED)
    assert nav.plan_reason(2.0, IDENTITY) is None


def test_keep_out_zones_are_driven_around_and_never_entered() -> None:
    zone = ((1.0, -1.0), (2.0, -1.0), (2.0, 1.0), (1.0, 1.0))
    cfg = config(keep_out_zones=[list(map(list, zone))])
    result = drive(cfg, NO_WALLS, IDENTITY, NavGoal("g", 3.0, 0.0), max_time_s=60, known_map=False)
    assert result.state is GoalState.REACHED
    # The footprint's centre stays out of the zone grown by the inscribed radius.
    inside = [
        p
        for p in result.poses
        if 1.0 - 0.15 < p[0] < 2.0 + 0.15 and -1.0 - 0.15 < p[1] < 1.0 + 0.15
    ]
    assert inside == []


def test_a_settings_change_mid_goal_keeps_the_stuck_watch_going() -> None:
    cfg = config(stuck_time_s=1.0, stuck_time_force_backward_s=2.0, max_stuck_time_s=4.0)
    nav = Navigator(NavigatorSettings.from_config(cfg))
    nav.set_goal(NavGoal("g", 3.0, 0.0))
    nav.accept_plan(0.0, nav.plan(0.0, IDENTITY))
    for k in range(16):  # 0.75 s of commands that move nothing: a robot held by a rug
        nav.step(0.05 * k, IDENTITY)
    # An operator retunes a weight meanwhile; the robot has not moved for 0.75 s all the same.
    retuned = config(
        stuck_time_s=1.0, stuck_time_force_backward_s=2.0, max_stuck_time_s=4.0, goal_weight=2.0
    )
    nav.configure(NavigatorSettings.from_config(retuned))
    assert nav.settings.dwa.weights[0] == 2.0
    assert nav.step(1.2, IDENTITY).phase is StuckPhase.PUSHING  # stuck since 0 s, not 0.75 s


def test_a_goal_with_points_to_pass_goes_through_them_without_stopping() -> None:
    # a dogleg: up to (2, 1.5), then on to (4, 0); each way point counted as it is passed
    cfg = config()
    goal = NavGoal("g", 4.0, 0.0, via=((2.0, 1.5),), pass_within_m=0.3)
    result = drive(cfg, NO_WALLS, IDENTITY, goal, max_time_s=40, known_map=False)
    assert result.state is GoalState.REACHED
    near = [math.hypot(x - 2.0, y - 1.5) for x, y, _ in result.poses]
    closest = int(np.argmin(near))
    assert near[closest] <= 0.3  # it went there, not straight to the goal
    passed = [step.via_passed for step in result.steps]
    assert passed[0] == 0 and passed[-1] == 1 and passed == sorted(passed)
    # and drove on through it: well above the speed it arrives at a goal with
    assert result.steps[closest].linear_mps >= 0.25
    direct = drive(cfg, NO_WALLS, IDENTITY, NavGoal("g", 2.0, 1.5), known_map=False)
    assert direct.steps[-1].linear_mps == 0.0  # a goal of its own is a stop

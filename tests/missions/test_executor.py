"""A mission's state machine, step by step: goals sent and their ends, waits, pauses for a
person, approaches, failure policies, rounds, and a person's pause, resume and cancel."""

from __future__ import annotations

import math

import pytest

from navd.geometry import Pose2
from navd.lifecycle.messages import (
    CancelGoal,
    GeoGoal,
    Goal,
    GoalStatus,
    Message,
    MissionRequest,
    MissionStatus,
    MissionStep,
)
from navd.missions.executor import MissionExecutor
from navd.missions.waypoints import STAGING_M

HERE = Pose2(0.0, 0.0, 0.0)


def _mission(*steps: MissionStep, rounds: int = 1) -> MissionExecutor:
    request = MissionRequest(
        stamp=0.0, received=0.0, mission_id="m", name="test", steps=steps, rounds=rounds
    )
    return MissionExecutor(request)


def _goals(messages: list[Message]) -> list[Goal]:
    return [m for m in messages if isinstance(m, Goal)]


def _events(messages: list[Message]) -> list[str]:
    return [m.info.event for m in messages if isinstance(m, MissionStatus)]


def _end(goal: Goal | GeoGoal, state: str, reason: str = "") -> GoalStatus:
    return GoalStatus(stamp=1.0, received=1.0, goal_id=goal.goal_id, state=state, reason=reason)


def goto(x: float, y: float, **kw: object) -> MissionStep:
    return MissionStep(kind="goto", x_m=x, y_m=y, **kw)  # type: ignore[arg-type]


def test_a_patrol_sends_each_goal_in_turn_and_goes_round_again() -> None:
    mission = _mission(goto(1, 0), goto(1, 1), rounds=2)
    out = mission.start(0.0, HERE)
    assert _events(out) == ["started", "step_started"]
    seen = []
    for _ in range(4):
        (goal,) = _goals(out)
        seen.append((goal.x_m, goal.y_m, goal.goal_id))
        out = mission.on_goal_status(_end(goal, "reached"), 1.0, HERE)
    assert [s[:2] for s in seen] == [(1, 0), (1, 1), (1, 0), (1, 1)]
    assert [s[2] for s in seen] == ["m:1.1.1.1a", "m:1.1.2.2a", "m:1.2.1.3a", "m:1.2.2.4a"]
    assert _events(out) == ["step_done", "completed"]
    assert mission.state == "completed" and mission.done == 4


def test_only_the_steps_own_goal_moves_the_mission_on() -> None:
    mission = _mission(goto(1, 0), goto(2, 0))
    (goal,) = _goals(mission.start(0.0, HERE))
    other = Goal(stamp=0.0, received=0.0, goal_id="someone-else", x_m=5.0, y_m=5.0)
    assert mission.on_goal_status(_end(other, "reached"), 1.0, HERE) == []
    progress = GoalStatus(
        stamp=1.0,
        received=1.0,
        goal_id=goal.goal_id,
        state="active",
        distance_remaining_m=0.7,
        eta_s=2.0,
    )
    (status,) = mission.on_goal_status(progress, 1.0, HERE)
    assert isinstance(status, MissionStatus) and status.info.event == "progress"
    assert (status.info.distance_m, status.info.eta_s, status.info.step, status.info.steps) == (
        0.7,
        2.0,
        1,
        2,
    )


@pytest.mark.parametrize(
    ("policy", "retries", "events", "state", "goals_sent"),
    [
        ("skip", 0, ["step_skipped", "step_started"], "running", 2),
        ("retry", 2, ["step_retried"], "running", 2),
        ("abort", 0, ["step_failed", "failed"], "failed", 1),
    ],
)
def test_a_failed_step_follows_its_policy(
    policy: str, retries: int, events: list[str], state: str, goals_sent: int
) -> None:
    mission = _mission(goto(9, 9, on_failure=policy, retries=retries), goto(1, 0))
    (goal,) = _goals(mission.start(0.0, HERE))
    out = mission.on_goal_status(_end(goal, "failed", "no route"), 1.0, HERE)
    assert _events(out) == events
    assert mission.state == state and mission.reason == "no route"
    assert 1 + len(_goals(out)) == goals_sent


def test_retries_run_out_and_then_the_mission_fails() -> None:
    mission = _mission(goto(9, 9, on_failure="retry", retries=2), goto(1, 0))
    (goal,) = _goals(mission.start(0.0, HERE))
    ids = [goal.goal_id]
    for _ in range(2):
        (goal,) = _goals(mission.on_goal_status(_end(goal, "failed"), 1.0, HERE))
        ids.append(goal.goal_id)
    out = mission.on_goal_status(_end(goal, "failed"), 1.0, HERE)
    assert ids == ["m:1.1.1.1a", "m:1.1.1.2a", "m:1.1.1.3a"]
    assert _events(out) == ["step_failed", "failed"] and mission.failed == 1


def test_a_wait_waits_on_the_clock_and_a_pause_on_a_person() -> None:
    mission = _mission(
        MissionStep(kind="wait", seconds=5.0),
        MissionStep(kind="pause", message="load the parcel"),
        goto(1, 0),
    )
    mission.start(10.0, HERE)
    assert mission.on_tick(14.9, HERE) == []
    out = mission.on_tick(15.0, HERE)
    assert _events(out) == ["step_done", "step_started", "waiting"]
    waiting = [m for m in out if isinstance(m, MissionStatus)][-1]
    assert waiting.info.state == "waiting" and waiting.info.message == "load the parcel"
    assert mission.on_tick(100.0, HERE) == []  # a pause does not end by itself
    out, refusal = mission.command("continue", 20.0, HERE)
    assert refusal == "" and _goals(out)[0].x_m == 1
    _, refusal = mission.command("continue", 21.0, HERE)
    assert "no step waits" in refusal


def test_an_approach_drives_to_a_staging_pose_then_slowly_to_its_stop() -> None:
    step = MissionStep(
        kind="approach", x_m=5.0, y_m=0.0, yaw_rad=0.0, stop_distance_m=0.4, speed_mps=0.1
    )
    mission = _mission(step)
    (staging,) = _goals(mission.start(0.0, HERE))
    assert (staging.x_m, staging.y_m, staging.yaw_rad) == pytest.approx(
        (5.0 - 0.4 - STAGING_M, 0.0, 0.0)
    )
    assert staging.max_speed_mps is None
    (final,) = _goals(mission.on_goal_status(_end(staging, "reached"), 1.0, HERE))
    assert (final.x_m, final.y_m) == pytest.approx((4.6, 0.0)) and final.max_speed_mps == 0.1
    out = mission.on_goal_status(_end(final, "reached"), 2.0, HERE)
    assert _events(out) == ["step_done", "completed"]
    # without a yaw: along the line from where the robot began the step
    free = _mission(MissionStep(kind="approach", x_m=3.0, y_m=4.0, stop_distance_m=1.0))
    (staging,) = _goals(free.start(0.0, Pose2(0.0, 0.0, 2.0)))
    assert (staging.x_m, staging.y_m) == pytest.approx((3.0 - 2.0 * 0.6, 4.0 - 2.0 * 0.8))
    assert staging.yaw_rad == pytest.approx(math.atan2(4.0, 3.0))


def test_pause_resume_and_cancel_by_a_person() -> None:
    mission = _mission(goto(1, 0), goto(2, 0))
    (goal,) = _goals(mission.start(0.0, HERE))
    out, _ = mission.command("pause", 1.0, HERE)
    assert [m.goal_id for m in out if isinstance(m, CancelGoal)] == [goal.goal_id]
    assert mission.state == "paused"
    # the planner says the cancelled goal was cancelled: nothing more happens
    assert mission.on_goal_status(_end(goal, "canceled"), 1.1, HERE) == []
    out, _ = mission.command("resume", 2.0, HERE)
    (again,) = _goals(out)
    assert (again.x_m, again.y_m) == (1, 0) and mission.state == "running"
    out, _ = mission.command("cancel", 3.0, HERE)
    assert [m.goal_id for m in out if isinstance(m, CancelGoal)] == [again.goal_id]
    assert mission.state == "canceled"
    _, refusal = mission.command("resume", 4.0, HERE)
    assert "has ended" in refusal


def test_a_goal_replaced_by_a_persons_goal_pauses_the_mission() -> None:
    mission = _mission(goto(1, 0))
    (goal,) = _goals(mission.start(0.0, HERE))
    out = mission.on_goal_status(_end(goal, "canceled", "replaced by goal g7"), 1.0, HERE)
    assert _events(out) == ["paused"] and mission.reason == "replaced by goal g7"
    out, _ = mission.command("resume", 2.0, HERE)
    assert len(_goals(out)) == 1


def test_a_gps_step_sends_a_geo_goal() -> None:
    mission = _mission(MissionStep(kind="goto_gps", latitude_deg=48.1, longitude_deg=11.5))
    (goal,) = [m for m in mission.start(0.0, HERE) if isinstance(m, GeoGoal)]
    assert (goal.latitude_deg, goal.longitude_deg) == (48.1, 11.5)
    assert _events(mission.on_goal_status(_end(goal, "reached"), 1.0, HERE)) == [
        "step_done",
        "completed",
    ]


def test_a_mission_run_again_under_its_id_is_not_paused_by_the_old_runs_cancel() -> None:
    request = MissionRequest(
        stamp=0.0, received=0.0, mission_id="patrol", name="p", steps=(goto(1, 0),)
    )
    first, second = MissionExecutor(request, run=1), MissionExecutor(request, run=2)
    (old,) = _goals(first.start(0.0, HERE))
    (new,) = _goals(second.start(0.0, HERE))
    assert old.goal_id != new.goal_id
    # the planner says the first run's goal was cancelled (the new run replaced it)
    assert second.on_goal_status(_end(old, "canceled"), 1.0, HERE) == []
    assert second.state == "running"
    assert _events(second.on_goal_status(_end(new, "reached"), 2.0, HERE))[-1] == "completed"


def test_a_resumed_step_sends_a_goal_of_a_new_id() -> None:
    mission = _mission(goto(1, 0))
    (goal,) = _goals(mission.start(0.0, HERE))
    mission.command("pause", 1.0, HERE)
    (again,) = _goals(mission.command("resume", 2.0, HERE)[0])
    assert again.goal_id != goal.goal_id
    # the cancelled first goal's late status leaves the resumed step alone
    assert mission.on_goal_status(_end(goal, "canceled"), 2.5, HERE) == []
    assert mission.state == "running"


def test_a_patrol_whose_every_step_fails_stops_after_a_round() -> None:
    mission = _mission(goto(9, 9, on_failure="skip"), goto(8, 8, on_failure="skip"), rounds=0)
    out = mission.start(0.0, HERE)
    for _ in range(2):
        (goal,) = _goals(out)
        out = mission.on_goal_status(_end(goal, "failed", "no route"), 1.0, HERE)
    assert mission.state == "failed" and "every step of round 1 failed" in mission.reason
    assert _goals(out) == []


# --- beacon steps -----------------------------------------------------------------------

PLACES = {"B1": (4.0, 0.0), "B2": (1.0, 0.0), "B3": (1.0, 2.5), "G1": (5.0, -1.0), "G2": (5.0, 1.0)}


def _beacon_mission(*steps: MissionStep) -> MissionExecutor:
    mission = _mission(*steps)
    mission.places = PLACES
    return mission


def test_visiting_beacons_drives_to_the_nearest_next_stopping_short_and_facing_each() -> None:
    step = MissionStep(kind="visit_beacons", beacons=("B1", "B2", "B3"), stop_distance_m=0.5)
    mission = _beacon_mission(step)
    out = mission.start(0.0, HERE)
    reached: list[tuple[float, float]] = []
    pose = HERE
    while _goals(out):
        (goal,) = _goals(out)
        assert goal.yaw_rad is not None
        # it stops short of a beacon along the way the robot comes, facing it
        target = min(PLACES.values(), key=lambda p: math.dist(p, (goal.x_m, goal.y_m)))
        assert math.dist(target, (goal.x_m, goal.y_m)) == pytest.approx(0.5)
        facing = math.atan2(target[1] - goal.y_m, target[0] - goal.x_m)
        assert goal.yaw_rad == pytest.approx(facing)
        reached.append(target)
        pose = Pose2(goal.x_m, goal.y_m, goal.yaw_rad)
        out = mission.on_goal_status(_end(goal, "reached"), 1.0, pose)
    # from the origin: B2 (1 m; B1 is 4 m) first, then B3 (2.5 m from it; B1 3 m), then B1
    assert reached == [PLACES["B2"], PLACES["B3"], PLACES["B1"]]
    assert _events(out) == ["step_done", "completed"]


def test_visiting_all_beacons_takes_every_beacon_with_a_place() -> None:
    mission = _beacon_mission(MissionStep(kind="visit_beacons"))
    out = mission.start(0.0, HERE)
    goals = 0
    while _goals(out):
        goals += 1
        (goal,) = _goals(out)
        out = mission.on_goal_status(_end(goal, "reached"), 1.0, Pose2(goal.x_m, goal.y_m, 0.0))
    assert goals == len(PLACES)


@pytest.mark.parametrize(("start_x", "first_x", "second_x"), [(0.0, 4.0, 6.0), (9.0, 6.0, 4.0)])
def test_a_gate_is_passed_square_to_its_line_from_the_robots_side(
    start_x: float, first_x: float, second_x: float
) -> None:
    mission = _beacon_mission(MissionStep(kind="gate", beacons=("G1", "G2")))
    pose = Pose2(start_x, 0.3, 0.0)
    (before,) = _goals(mission.start(0.0, pose))
    (after,) = _goals(mission.on_goal_status(_end(before, "reached"), 1.0, pose))
    assert (before.x_m, before.y_m) == pytest.approx((first_x, 0.0))
    assert (after.x_m, after.y_m) == pytest.approx((second_x, 0.0))
    heading = 0.0 if start_x < 5.0 else math.pi
    for goal in (before, after):
        assert goal.yaw_rad is not None
        assert math.cos(goal.yaw_rad - heading) == pytest.approx(1.0)
    out = mission.on_goal_status(_end(after, "reached"), 2.0, pose)
    assert _events(out) == ["step_done", "completed"]


def test_a_beacon_without_a_place_fails_the_step_by_its_policy_naming_the_known_ones() -> None:
    mission = _beacon_mission(
        MissionStep(kind="beacon", beacons=("B9",), on_failure="skip"),
        MissionStep(kind="beacon", beacons=("B1",)),
    )
    out = mission.start(0.0, HERE)
    skipped = [m for m in out if isinstance(m, MissionStatus) and m.info.event == "step_skipped"]
    assert (
        skipped
        and "B9 has no place" in skipped[0].info.reason
        and "B1, B2" in skipped[0].info.reason
    )
    (goal,) = _goals(out)  # on to the next step
    assert math.dist((goal.x_m, goal.y_m), PLACES["B1"]) == pytest.approx(0.0)
    empty = _mission(MissionStep(kind="visit_beacons"))
    assert "no beacon has a place" in empty.start(0.0, HERE)[-1].info.reason  # type: ignore[attr-defined]


def test_a_skipped_steps_failure_is_not_said_of_the_steps_that_succeed_after_it() -> None:
    mission = _mission(goto(9, 9, on_failure="skip"), goto(1, 0), goto(2, 0))
    (far,) = _goals(mission.start(0.0, HERE))
    out = mission.on_goal_status(_end(far, "failed", "no route for 15 s"), 1.0, HERE)
    assert mission.reason == "no route for 15 s"  # said while it is news
    (near,) = _goals(out)
    (last,) = _goals(mission.on_goal_status(_end(near, "reached"), 2.0, HERE))
    assert mission.reason == ""
    done = mission.on_goal_status(_end(last, "reached"), 3.0, HERE)
    assert _events(done)[-1] == "completed" and mission.reason == ""


def test_a_cancel_says_who_cancelled() -> None:
    mission = _mission(goto(1, 0))
    mission.start(0.0, HERE)
    mission.command("cancel", 1.0, HERE, by="replaced by mission m2")
    assert (mission.state, mission.reason) == ("canceled", "replaced by mission m2")

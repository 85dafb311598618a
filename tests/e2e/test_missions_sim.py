"""Missions on the real daemon driving the simulated office (lockstep): a patrol of four
waypoints twice round, each step reported; a step whose goal cannot be reached follows its
policy; a pause for a person waits for their "continue"."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import pytest

from navd.sim import Session, office, session
from navd.wire import InitialPoseFrame, MissionControlFrame, MissionFrame, MissionStatusFrame
from tests.e2e.missions import follow_mission

pytestmark = pytest.mark.e2e

# Around the office, through the start room's 1 m door both ways each round: the corridor
# by the door, the corridor's east end, the lower-right area, and back into the start room.
PATROL = [(3.5, 3.2), (8.5, 3.2), (9.0, 1.2), (0.8, 1.9)]


async def _run(s: Session, mission: MissionFrame, limit_s: float) -> list[MissionStatusFrame]:
    """Send ``mission`` from the robot's start; every mission status up to its end."""
    s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
    return await follow_mission(s, mission, limit_s)


def _steps(points: list[tuple[float, float]], **extra: Any) -> list[dict[str, Any]]:
    return [{"kind": "goto", "x": x, "y": y, **extra} for x, y in points]


async def test_a_patrol_runs_twice_round_and_reports_every_step(tmp_path: Path) -> None:
    mission = MissionFrame.model_validate(
        {"mission_id": "patrol", "name": "office round", "rounds": 2, "steps": _steps(PATROL)}
    )
    async with session(office(), tmp_path, lockstep=True, hold_clock=True) as s:
        seen = await _run(s, mission, limit_s=400.0)
        truth = [(x, y) for _, x, y, _ in s.sim.truth]
    assert seen[-1].state == "completed", seen[-1]
    done = [(f.round, f.step) for f in seen if f.event == "step_done"]
    assert done == [(r, i) for r in (1, 2) for i in (1, 2, 3, 4)]
    started = [(f.round, f.step) for f in seen if f.event == "step_started"]
    assert started == done
    assert seen[-1].done == 8 and seen[-1].failed == 0
    assert any(f.event == "progress" and f.distance_m is not None for f in seen)
    # the robot was at each waypoint, twice (within the goal tolerance and a little)
    for x, y in PATROL:
        near = [math.hypot(px - x, py - y) < 0.35 for px, py in truth]
        visits = sum(1 for a, b in itertools.pairwise(near) if b and not a)
        assert visits >= 2, f"({x}, {y}) visited {visits} times"
    assert s.sim.body.collisions == 0


@pytest.mark.parametrize(
    ("policy", "goal", "said", "state", "done", "failed"),
    [
        # beyond the goal distance navd plans for: refused at once
        ("skip", (4000.0, 0.0), "max_goal_distance_m", "completed", 2, 1),
        ("abort", (4000.0, 0.0), "max_goal_distance_m", "failed", 1, 1),
        # inside a desk (never seen into): no route, given up after a while
        ("skip", (2.1, 1.1), "no route", "completed", 2, 1),
    ],
)
async def test_an_unreachable_step_follows_its_policy(
    tmp_path: Path,
    policy: str,
    goal: tuple[float, float],
    said: str,
    state: str,
    done: int,
    failed: int,
) -> None:
    steps = [
        {"kind": "goto", "x": 2.0, "y": 1.9},
        {"kind": "goto", "x": goal[0], "y": goal[1], "on_failure": policy},
        {"kind": "goto", "x": 0.3, "y": 0.2},
    ]
    mission = MissionFrame.model_validate({"mission_id": "m", "steps": steps})
    async with session(office(), tmp_path, lockstep=True, hold_clock=True) as s:
        seen = await _run(s, mission, limit_s=200.0)
    last = seen[-1]
    assert (last.state, last.done, last.failed) == (state, done, failed), last
    event = "step_skipped" if policy == "skip" else "step_failed"
    (bad,) = [f for f in seen if f.event == event]
    assert bad.step == 2 and said in bad.reason


async def test_a_pause_step_waits_for_a_persons_continue(tmp_path: Path) -> None:
    steps = [
        {"kind": "pause", "message": "put the parcel on"},
        {"kind": "wait", "seconds": 2.0},
        {"kind": "goto", "x": 1.0, "y": 1.9},
    ]
    mission = MissionFrame.model_validate({"mission_id": "deliver", "steps": steps})
    async with session(office(), tmp_path, lockstep=True, hold_clock=True) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        await s.control.request(mission)
        s.sim.release_clock()
        waiting = await _until(s, lambda f: f.event == "waiting")
        assert waiting.message == "put the parcel on" and waiting.state == "waiting"
        await _hold(s, 3.0)  # nothing moves on by itself
        assert math.hypot(s.sim.body.x_m, s.sim.body.y_m) < 0.05
        await s.control.request(MissionControlFrame(action="continue"))
        told = s.sim.now()
        await _until(s, lambda f: f.event == "step_started" and f.step == 3)
        assert s.sim.now() - told >= 2.0 - 0.2  # then the 2 s wait
        done = await _until(s, lambda f: f.state == "completed", limit_s=60.0)
    assert done.done == 3


async def _until(s: Session, test: Any, limit_s: float = 30.0) -> MissionStatusFrame:
    """The next mission status passing ``test`` within ``limit_s`` of simulated time."""
    deadline = s.sim.now() + limit_s
    seen = []
    while s.sim.now() < deadline:
        s.check()
        try:
            frame = await s.control.receive(1.0)
        except TimeoutError:
            continue
        if isinstance(frame, MissionStatusFrame):
            seen.append(frame)
            if test(frame):
                return frame
    raise AssertionError(f"no such mission status within {limit_s} s; saw {seen}")


async def _hold(s: Session, seconds: float) -> None:
    """Let ``seconds`` of simulated time pass, reading what comes."""
    deadline = s.sim.now() + seconds
    while s.sim.now() < deadline:
        s.check()
        try:
            await s.control.receive(0.5)
        except TimeoutError:
            continue

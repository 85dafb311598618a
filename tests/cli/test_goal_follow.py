"""``navd goal --wait`` follows a goal: its progress, and safety's holds the moment they change."""

from __future__ import annotations

from collections.abc import Iterator
from types import SimpleNamespace

import pytest

from navd.cli.control import _follow
from navd.wire import Diagnostics, GoalStatusFrame, Reply, StatusFrame


class ScriptedClient:
    """A control client whose frames are given in advance."""

    def __init__(self, frames: list[Reply]) -> None:
        self._frames: Iterator[Reply] = iter(frames)
        self.timeout_s: float | None = 5.0
        self.sock = SimpleNamespace(settimeout=lambda _s: None)

    def receive(self) -> Reply:
        return next(self._frames)


def held(*reasons: str) -> StatusFrame:
    # Only the safety reasons are read: the rest of a status frame is left out.
    return StatusFrame.model_construct(diagnostics=Diagnostics.model_construct(safety=[*reasons]))


def goal(state: str, left_m: float | None = None, goal_id: str = "g1") -> GoalStatusFrame:
    return GoalStatusFrame(goal_id=goal_id, state=state, distance_remaining=left_m)


def test_a_hold_is_shown_the_moment_it_starts_and_ends(capsys: pytest.CaptureFixture[str]) -> None:
    frames = [
        held(),  # before the goal's first report: nothing to show yet
        goal("active", 3.0),
        held("lidar stale"),
        held("lidar stale"),  # unchanged: no line
        goal("active", 2.9),  # within the progress period: no line
        goal("active", 1.0, goal_id="other"),  # another client's goal
        held(),
        goal("reached", 0.1),
    ]
    last = _follow(ScriptedClient(frames), "g1")  # type: ignore[arg-type]
    assert last.state == "reached"
    assert capsys.readouterr().err.splitlines() == [
        "g1: active, 3.0 m to go",
        "g1: active, 3.0 m to go - held by safety: lidar stale",
        "g1: active, 2.9 m to go",
    ]

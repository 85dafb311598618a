"""A goal, where it stands, and what one control step decided about it."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from navd.planning.stuck import StuckPhase

__all__ = ["GoalState", "NavGoal", "Step"]


class GoalState(StrEnum):
    """Where a goal stands (GoalStatus.state)."""

    ACTIVE = "active"
    REACHED = "reached"
    FAILED = "failed"
    CANCELED = "canceled"


@dataclass(frozen=True, slots=True)
class NavGoal:
    """A goal in the map frame: [m, m], and [rad] or None for any heading; a top speed
    [m/s] of its own, or None for the robot's; points [m] to pass through on the way, each
    passed within ``pass_within_m`` [m]."""

    goal_id: str
    x_m: float
    y_m: float
    yaw_rad: float | None = None
    max_speed_mps: float | None = None
    via: tuple[tuple[float, float], ...] = ()
    pass_within_m: float = 0.5


@dataclass(frozen=True, slots=True)
class Step:
    """What one control step decided.

    Attributes:
        linear_mps, angular_radps: the command.
        state: the goal's state after the step (None without a goal).
        remaining_m: [m] route length left (NaN while unknown).
        eta_s: [s] estimated time to arrival (NaN while unknown).
        reason: why the goal failed, or what the robot is waiting for.
        stuck_detected: the robot was stuck for max_stuck_time (StuckDetected).
        phase: the stuck monitor's phase.
        via_passed: how many of the goal's via points the robot has passed.
    """

    linear_mps: float
    angular_radps: float
    state: GoalState | None
    remaining_m: float = math.nan
    eta_s: float = math.nan
    reason: str = ""
    stuck_detected: bool = False
    phase: StuckPhase = StuckPhase.MOVING
    via_passed: int = 0

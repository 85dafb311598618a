"""What a group of robots is asked: where its centre goes, in which formation, how far apart,
how fast, released how far at a time."""

from __future__ import annotations

import math
from dataclasses import dataclass

from navd.fleetctl.errors import GroupGoalError
from navd.fleetctl.formation import Formation

__all__ = ["GroupGoal"]


@dataclass(frozen=True, slots=True)
class GroupGoal:
    """What the group is asked.

    Attributes:
        x_m, y_m: [m] where the group's centre goes (map frame).
        heading_rad: [rad] which way the formation faces there (None: the way it drives).
        formation: line, column or triangle.
        spacing_m: [m] between neighbouring robots (a triangle's back row drives spacing / 2
            beside the lane of the robot ahead: keep it wider than the clearance navd keeps
            from another robot, docs/fleet.md says why).
        step_m: [m] the centre's way is released this much at a time (a column: half its
            spacing at a time, see ``group_route``).
        start_delay_s: [s] all robots start this long after the orders go out.
        speed_mps: [m/s] the group's top speed (each edge's maxSpeed): slow enough that a
            robot told to wait stops short of running ahead.
    """

    x_m: float
    y_m: float
    heading_rad: float | None = None
    formation: Formation = "triangle"
    spacing_m: float = 1.5
    step_m: float = 1.5
    start_delay_s: float = 2.0
    speed_mps: float = 0.3

    def __post_init__(self) -> None:
        numbers = [self.x_m, self.y_m, self.spacing_m, self.step_m, self.start_delay_s]
        numbers += [self.speed_mps] + ([] if self.heading_rad is None else [self.heading_rad])
        if not all(math.isfinite(v) for v in numbers):
            raise GroupGoalError(f"a group goal's numbers must be finite: {self}")
        if min(self.spacing_m, self.step_m, self.speed_mps) <= 0 or self.start_delay_s < 0:
            raise GroupGoalError(
                f"a group goal's spacing_m, step_m and speed_mps must be > 0 and its "
                f"start_delay_s >= 0: {self}"
            )

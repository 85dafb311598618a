"""Turning on the spot: toward the route before driving on when the robot stands facing away
from it (as Nav2's rotation shim does), and to the goal's heading at the goal. The local
planner does the turning; this aims it and says when a turn toward the route is given up.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2, angle_between, wrap_angle
from navd.planning.dwa import DwaChoice, LocalPlanner, Window
from navd.planning.profile import VelocityProfile
from navd.planning.route import Route
from navd.planning.stuck import StuckPhase

__all__ = [
    "MAX_TURN_AIM_RAD",
    "ROUTE_FACED_RAD",
    "STANDING_MPS",
    "TURN_FIRST_RAD",
    "TURN_USEFUL_SHARE",
    "SpotTurns",
]

FloatArray = npt.NDArray[np.float64]

# [rad] a turn on the spot aims the local planner at most this far ahead of the robot's
# heading: the local planner reads a heading nearer pi ahead as one the other way round when
# the robot still turns the other way. Over the default 2 s horizon it caps a turn on the
# spot at 1.25 rad/s (the yaw-rate table allows 1.5 standing).
MAX_TURN_AIM_RAD = 2.5
# A robot standing (below STANDING_MPS [m/s]) with its route more than TURN_FIRST_RAD off its
# heading turns on the spot until it faces the route within ROUTE_FACED_RAD, as Nav2's
# rotation shim does; the local planner's own turn toward it slowed as the error shrank, and
# crept forward meanwhile (4.5 s to turn 1.5 rad). A turn on the spot that cannot go toward
# the route at TURN_USEFUL_SHARE of the rate it wants (something in the way of the robot's
# corners) is left to the local planner until the robot has moved.
TURN_FIRST_RAD = math.radians(60.0)
ROUTE_FACED_RAD = math.radians(15.0)
STANDING_MPS = 0.02
TURN_USEFUL_SHARE = 0.5


class SpotTurns:
    """Whether the robot turns on the spot to face the route, and how it is aimed."""

    def __init__(self) -> None:
        self.turning_first = False  # turning on the spot to face the route
        self.refused = False  # ... and it could not: not again until the robot moved

    def reset(self) -> None:
        """A new goal: no turn under way."""
        self.turning_first = False
        self.refused = False

    def aim(
        self,
        local: LocalPlanner,
        command: tuple[float, float],
        pose: Pose2,
        rate: float,
        at: tuple[float, float],
    ) -> tuple[Pose2, Window]:
        """The local planner's target and window for turning on the spot at ``rate`` [rad/s]
        (the profile's ``turn_rate``, signed).

        The local planner picks the turn whose horizon ends nearest the heading it is given:
        it is given the heading that rate reaches within the horizon.
        """
        horizon = local.settings.horizon_s
        # A robot still turning the other way ends its horizon that far round already: the
        # aim comes nearer, or it would read as a heading that way round.
        against = min(math.copysign(1.0, rate) * command[1], 0.0) * horizon
        reach = max(min(abs(rate) * horizon, MAX_TURN_AIM_RAD + against), 0.0)
        return Pose2(at[0], at[1], pose.yaw + math.copysign(reach, rate)), Window(
            0.0, rotate_only=True
        )

    def toward(
        self,
        local: LocalPlanner,
        profile: VelocityProfile,
        command: tuple[float, float],
        pose: Pose2,
        point: tuple[float, float],
        *,
        obstacles: FloatArray,
        route: Route,
    ) -> DwaChoice | None:
        """The local planner's turn on the spot toward ``point``; None, and no such turn again
        until the robot has moved, if it cannot turn there usefully (see TURN_USEFUL_SHARE)."""
        toward = math.atan2(point[1] - pose.y, point[0] - pose.x)
        wanted = profile.turn_rate(wrap_angle(toward - pose.yaw))
        target, window = self.aim(local, command, pose, wanted, point)
        choice = local.choose(pose, command, obstacles, route.field, target, window)
        side = math.copysign(1.0, wanted)
        now_toward = side * command[1]  # [rad/s] negative: still turning the other way
        step = local.settings.angular_accel_radps2 * local.settings.period_s
        if now_toward < 0.0:  # still turning the other way: it must slow that turn
            useful = now_toward + TURN_USEFUL_SHARE * step
        else:
            useful = TURN_USEFUL_SHARE * min(abs(wanted), now_toward + step)
        if choice is None or side * choice.angular_radps < useful:
            self.turning_first = False
            self.refused = True
            return None
        return choice

    def faces_route_first(
        self,
        command: tuple[float, float],
        pose: Pose2,
        carrot: tuple[float, float],
        phase: StuckPhase,
        *,
        aligning: bool,
    ) -> bool:
        """Whether to turn on the spot toward the route before driving on (see
        TURN_FIRST_RAD); never while stuck handling pushes or backs the robot, nor at the goal
        (turning to its heading)."""
        if aligning:
            self.turning_first = False
            return False
        off = angle_between(pose.yaw, math.atan2(carrot[1] - pose.y, carrot[0] - pose.x))
        standing = abs(command[0]) < STANDING_MPS
        self.refused = self.refused and standing
        if self.refused:
            return False
        keep = off > ROUTE_FACED_RAD if self.turning_first else standing and off > TURN_FIRST_RAD
        self.turning_first = phase is StuckPhase.MOVING and keep
        return self.turning_first

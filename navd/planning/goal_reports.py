"""What the planner says of its goal: the goal's status when it changes (remembered, so a
navigator step does not say it again), its progress every ``STATUS_PERIOD_S`` while it
drives, the stop command, and what a viewer watches (the local planner's chosen rollout, the
costmap of the last plan)."""

from __future__ import annotations

import math
import threading

import numpy as np
from structlog.typing import FilteringBoundLogger

from navd.geometry import Pose2
from navd.lifecycle import Clock
from navd.lifecycle.messages import CostmapUpdate, GoalStatus, LocalTrajectory, VelocityCommand
from navd.planning.costmap import Costmap, ros_costmap
from navd.planning.dwa import DwaSettings, arc
from navd.planning.goal import GoalState, Step

__all__ = [
    "PAUSED",
    "SOURCE",
    "STATUS_PERIOD_S",
    "GoalReports",
    "costmap_update",
    "trajectory",
]

STATUS_PERIOD_S = 0.5
SOURCE = "planner"
PAUSED = "paused"  # GoalStatus.state of a goal paused while an operator drives


class GoalReports:
    """The goal's status messages, and the stop.

    Args:
        clock: the daemon's clock (the messages' stamps).
        log: the planner's logger (a goal that ends is logged).
    """

    def __init__(self, clock: Clock, log: FilteringBoundLogger) -> None:
        self._clock = clock
        self._log = log
        # The state last said of the goal in hand, and when: said from the event loop and from
        # the workers, so changed under a lock of their own.
        self._lock = threading.Lock()
        self.last_state: GoalState | None = None
        self._status_at = -math.inf
        self._via_passed = 0

    def stop(self) -> VelocityCommand:
        """The zero command, from the planner."""
        now = self._clock.now()
        return VelocityCommand(
            stamp=now, received=now, linear_mps=0.0, angular_radps=0.0, source=SOURCE
        )

    def status(
        self, goal_id: str, state: GoalState, reason: str = "", *, shown: str | None = None
    ) -> GoalStatus:
        """The status of the goal the navigator holds (remembered, so a step does not repeat
        it); ``shown`` replaces the state's name (an active goal shown as paused)."""
        message = self.plain(goal_id, shown or state, reason)
        with self._lock:
            self.last_state = state
            self._status_at = message.stamp
            if state is GoalState.ACTIVE:  # a new goal: none of its via points passed yet
                self._via_passed = 0
        return message

    def plain(self, goal_id: str, state: str, reason: str = "") -> GoalStatus:
        """A goal's status, not remembered (a goal the navigator never took)."""
        now = self._clock.now()
        return GoalStatus(stamp=now, received=now, goal_id=goal_id, state=str(state), reason=reason)

    def due(self, goal_id: str, step: Step, stamp: float) -> GoalStatus | None:
        """The step's status if its state changed or the last is ``STATUS_PERIOD_S`` old."""
        with self._lock:
            changed = step.state is not self.last_state
            passed = step.via_passed != self._via_passed  # a node driven through: said at once
            if not (changed or passed) and stamp - self._status_at < STATUS_PERIOD_S:
                return None
            self.last_state = step.state
            self._status_at = stamp
            self._via_passed = step.via_passed
        if changed and step.state is not GoalState.ACTIVE:
            self._log.info("goal_done", goal_id=goal_id, state=str(step.state), reason=step.reason)
        return GoalStatus(
            stamp=stamp,
            received=stamp,
            goal_id=goal_id,
            state=str(step.state),
            distance_remaining_m=step.remaining_m,
            eta_s=step.eta_s,
            reason=step.reason,
            via_passed=step.via_passed,
        )


def trajectory(
    goal_id: str, pose: Pose2, step: Step, stamp: float, dwa: DwaSettings
) -> LocalTrajectory:
    """The chosen command rolled out over the local planner's horizon, for a viewer."""
    steps = max(round(dwa.horizon_s / dwa.step_s), 1)
    rollout = arc(pose, step.linear_mps, step.angular_radps, dwa.step_s, steps)
    points = np.vstack([[pose.x, pose.y], rollout[:, :2]])
    return LocalTrajectory(
        stamp=stamp,
        received=stamp,
        goal_id=goal_id,
        linear_mps=step.linear_mps,
        angular_radps=step.angular_radps,
        points_m=points,
    )


def costmap_update(costmap: Costmap, stamp: float) -> CostmapUpdate:
    """The costmap of a plan as a viewer is shown it (ROS costmap values)."""
    frame = costmap.frame
    return CostmapUpdate(
        stamp=stamp,
        received=stamp,
        resolution_m=frame.resolution_m,
        origin_x_m=frame.origin_x_m,
        origin_y_m=frame.origin_y_m,
        occupancy=ros_costmap(costmap),
    )

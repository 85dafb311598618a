"""The navigator as the planner's worker jobs drive it: goals and cancels applied in order,
A* on a snapshot of the layers, one navigator step per control period. The navigator is
shared by these threads under one lock, held only for cheap work (A* runs outside it) and
never taken on the event loop while the daemon runs; a few flags (what came, whether a
search runs or is due) have a lock of their own, held a few lines at a time.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from structlog.typing import FilteringBoundLogger

from navd.geometry import Pose2
from navd.lifecycle import Clock
from navd.lifecycle.messages import (
    CancelGoal,
    Goal,
    Message,
    Path,
    StuckDetected,
    VelocityCommand,
    ViewInterest,
)
from navd.planning.dwa import DwaSettings
from navd.planning.errors import PlanningError
from navd.planning.goal import GoalState, NavGoal
from navd.planning.goal_reports import PAUSED, SOURCE, GoalReports, costmap_update, trajectory
from navd.planning.navigator import Navigator

__all__ = ["PLAN_FAILED_LOG_S", "NavigatorJobs", "Resume"]

# [s] a search failing the same way (tried again at every tick while, say, another robot
# stands on the goal) is logged again at most this often, with how often it failed meanwhile
PLAN_FAILED_LOG_S = 5.0


@dataclass(frozen=True, slots=True)
class Resume:
    """Take up the goal ``goal_id`` again after manual driving, or once the robot lost on
    its map was found again (queued with goals)."""

    goal_id: str
    why: str = "resumed after manual driving"


class NavigatorJobs:
    """The navigator and the jobs that drive it (see the module docstring).

    Args:
        nav: the navigator.
        reports: the goal's status messages (shared with the event loop's side).
        clock, log: the planner's.
        held: whether the navigator must wait (an operator drives, the robot is lost): a
            glance from a worker at what the event loop owns.
        operator: who drives by hand ("" when no one), a glance likewise.
        dwa: the local planner's settings in force (for a viewer's rollout).
    """

    def __init__(
        self,
        nav: Navigator,
        reports: GoalReports,
        *,
        clock: Clock,
        log: FilteringBoundLogger,
        held: Callable[[], bool],
        operator: Callable[[], str],
        dwa: Callable[[], DwaSettings],
    ) -> None:
        self.nav = nav
        self.lock = threading.Lock()  # the navigator: worker jobs only, never the event loop
        self._flags = threading.Lock()  # the three fields below, a few lines at a time
        self._inbox: list[Goal | CancelGoal | Resume] = []
        self._planning = False
        self._plan_due: str | None = None
        self._reports = reports
        self._clock = clock
        self._log = log
        self._held = held
        self._operator = operator
        self._dwa = dwa
        self.broken: Exception | None = None  # a search that broke, not yet reported
        # the last planning failure logged (its text, when) and how many like it since: only
        # the planning worker touches them, one search at a time
        self._failure_logged: tuple[str, float] | None = None
        self._failures_unlogged = 0
        # What a viewer watches (set on the loop, read by workers: a stale glance costs one
        # message more or less)
        self.watched = ViewInterest(stamp=0.0, received=0.0, costmap=False, trajectory=False)

    # --- goals ------------------------------------------------------------------------

    def post(self, request: Goal | CancelGoal | Resume) -> None:
        """Queue a goal, a cancel or a resume for the next ``take_requests``."""
        with self._flags:
            self._inbox.append(request)

    def take_requests(self) -> tuple[Message, ...]:
        """Worker: apply the goals and cancels that came, in order."""
        with self._flags:
            requests, self._inbox = self._inbox, []
        messages: list[Message] = []
        with self.lock:
            for request in requests:
                if isinstance(request, Goal):
                    messages += self._start(request)
                elif isinstance(request, CancelGoal):
                    messages += self._cancel(request)
                else:
                    messages += self._resume(request)
        return tuple(messages)

    def _resume(self, request: Resume) -> list[Message]:
        """Take the goal up again after manual driving, if it is still the one paused."""
        goal = self.nav.goal
        if (
            goal is None
            or goal.goal_id != request.goal_id
            or self.nav.state is not GoalState.ACTIVE
        ):
            return []
        self.nav.resume(request.why)
        return [self._reports.status(goal.goal_id, GoalState.ACTIVE)]

    def _start(self, goal: Goal) -> list[Message]:
        previous = self.nav.cancel()
        self.nav.set_goal(
            NavGoal(
                goal.goal_id,
                goal.x_m,
                goal.y_m,
                goal.yaw_rad,
                goal.max_speed_mps,
                goal.via,
                goal.pass_within_m,
            )
        )
        with self._flags:
            self._plan_due = "new goal"
        messages: list[Message] = []
        reports = self._reports
        if previous is not None and previous.goal_id != goal.goal_id:
            why = f"replaced by {goal.goal_id!r}"
            messages.append(reports.status(previous.goal_id, GoalState.CANCELED, why))
        self._log.info("goal", goal_id=goal.goal_id, x=goal.x_m, y=goal.y_m, yaw=goal.yaw_rad)
        operator = self._operator()
        if operator:
            why = f"an operator ({operator}) drives by hand"
            messages.append(reports.status(goal.goal_id, GoalState.ACTIVE, why, shown=PAUSED))
        else:
            messages.append(reports.status(goal.goal_id, GoalState.ACTIVE))
        return messages

    def _cancel(self, cancel: CancelGoal) -> list[Message]:
        goal = self.nav.goal
        if goal is None or cancel.goal_id not in (None, goal.goal_id):
            return []
        active = self.nav.cancel()
        if active is None:
            return []
        self._log.info("goal_canceled", goal_id=active.goal_id)
        reports = self._reports
        canceled = reports.status(active.goal_id, GoalState.CANCELED, "canceled by a client")
        if self._operator():
            return [canceled]  # an operator's driving is not the goal's to stop
        return [reports.stop(), canceled]

    # --- the route --------------------------------------------------------------------

    def next_search(self) -> str | None:
        """Event loop: why A* must run now (the last step said so and none runs), marking
        it running; None otherwise."""
        with self._flags:
            reason = None if self._planning else self._plan_due
            if reason is not None:
                self._planning = True
                self._plan_due = None
        return reason

    def _log_failure(self, now: float, reason: str, error: str) -> None:
        """Log a failed search, unless it failed the same way within PLAN_FAILED_LOG_S."""
        last = self._failure_logged
        if last is not None and last[0] == error and now - last[1] < PLAN_FAILED_LOG_S:
            self._failures_unlogged += 1
            return
        self._log.warning(
            "plan_failed", reason=reason, error=error, repeats=self._failures_unlogged
        )
        self._failure_logged, self._failures_unlogged = (error, now), 0

    def plan(self, now: float, pose: Pose2, reason: str) -> tuple[Message, ...]:
        """Worker: a snapshot of the layers (under the lock), A* on it (outside), then the
        route to the navigator. Whatever goes wrong fails or delays the goal with the reason;
        the next goal plans afresh. The search counts as over only once its outcome is in the
        navigator (under its lock): a step in between would see the reason it answered still
        standing and ask for the same search again."""
        goal = None
        began = time.perf_counter()
        try:
            with self.lock:
                goal = self.nav.goal
                request = self.nav.request(now, pose)
            costmap = request.costmap()
            path = request.solve(self.nav.global_planner, costmap)
        except PlanningError as err:
            self._log_failure(now, reason, str(err))
            with self.lock:
                if self.nav.goal is goal:
                    self.nav.plan_failed(now, err)
                self._planned()
                return self._failed()
        except Exception as err:  # out of memory, or a bug: the goal fails, the planner goes on
            self._log.exception("plan_broke", reason=reason, error=f"{type(err).__name__}")
            self.broken = err  # counted against the module at the next tick, on the loop
            with self.lock:
                if self.nav.goal is goal:
                    self.nav.abort(f"planning failed: {type(err).__name__}: {err}")
                self._planned()
                return self._failed()
        else:
            self._failure_logged, self._failures_unlogged = None, 0
            with self.lock:
                self._planned()
                if self.nav.goal is not goal or goal is None:
                    return ()  # the goal changed meanwhile: this route is for the old one
                self.nav.accept_plan(now, path)
        finally:
            self._planned()  # whatever happened, the planner is free for the next search
        self._log.info(
            "planned",
            reason=reason,
            length_m=round(path.length_m, 2),
            points=len(path.points_m),
            expanded=path.cells_expanded,
            reused=path.reused,
            window=path.fine_length_m is not None,  # a far goal's (``horizon``)
            ms=round(1e3 * (time.perf_counter() - began), 1),  # snapshot, costmap and search
        )
        stamp = self._clock.now()
        route = Path(stamp=stamp, received=stamp, goal_id=goal.goal_id, points_m=path.points_m)
        if not self.watched.costmap:
            return (route,)
        return (route, costmap_update(costmap, stamp))

    def _planned(self) -> None:
        with self._flags:
            self._planning = False

    def _failed(self) -> tuple[Message, ...]:
        """Under the lock: the stop and the status of a goal that has just failed, if it has."""
        goal, failure = self.nav.goal, self.nav.failure
        if goal is None or not failure or self._reports.last_state is GoalState.FAILED:
            return ()  # not failed, or already told
        self._log.info("goal_done", goal_id=goal.goal_id, state="failed", reason=failure)
        reports = self._reports
        return (reports.stop(), reports.status(goal.goal_id, GoalState.FAILED, failure))

    # --- control ----------------------------------------------------------------------

    def step(
        self, now: float, pose: Pose2, driven: tuple[float, float] | None
    ) -> tuple[Message, ...]:
        """Worker: one navigator step, from ``driven`` [m/s, rad/s] when the robot is known to
        do that rather than what the navigator chose last (None); the command, and status
        when it is due."""
        with self.lock:
            goal = self.nav.goal
            if goal is None or self.nav.state is not GoalState.ACTIVE or self._held():
                return ()
            step = self.nav.step(now, pose, driven)
            replans = self.nav.stuck_replans
            # Whether A* must run is decided here, in the worker; the next tick submits it.
            # While a search runs its reason still stands: asking again would plan twice.
            due = self.nav.plan_reason(now, pose)
            with self._flags:
                if not self._planning:
                    self._plan_due = due
        stamp = self._clock.now()
        if self._held():
            return ()  # an operator took the wheel while this step ran, or the robot is lost
        messages: list[Message] = [
            VelocityCommand(
                stamp=stamp,
                received=stamp,
                linear_mps=step.linear_mps,
                angular_radps=step.angular_radps,
                source=SOURCE,
            )
        ]
        if self.watched.trajectory:
            messages.append(trajectory(goal.goal_id, pose, step, stamp, self._dwa()))
        if step.stuck_detected:
            giving_up = step.state is GoalState.FAILED
            self._log.warning("stuck", goal_id=goal.goal_id, replans=replans, giving_up=giving_up)
            messages.append(
                StuckDetected(
                    stamp=stamp,
                    received=stamp,
                    goal_id=goal.goal_id,
                    x_m=pose.x,
                    y_m=pose.y,
                    replans=replans,
                    giving_up=giving_up,
                )
            )
        status = self._reports.due(goal.goal_id, step, stamp)
        if status is not None:
            messages.append(status)
        return tuple(messages)

"""The planner module: goals in, velocity commands, routes and goal progress out.

Every ``planning.control_rate_hz`` tick (on the event loop, cheap) submits one navigator step
to the ``local_plan`` worker slot (goal checks, stuck handling, velocity profile, DWA; it
returns the VelocityCommand and decides whether the route must be planned); when the last
step said so, the tick also submits A* to the ``global_plan`` slot, which takes a snapshot of
the layers and plans on it. Map updates and scans feed the layers in the ``planning_map``
and ``planning_scan`` slots. The navigator is shared by these threads under one lock, held
only for cheap work: A* runs outside it. New settings reach the navigator under the same
lock (its stuck watch, route and layers carry on).

The robot is never driven on an old pose: when the last PoseEstimate is older than
``POSE_TIMEOUT_S`` the step commands zero.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from navd.config import NavdConfig
from navd.geometry.mount import LidarMount
from navd.geometry.pose import Pose2
from navd.geometry.scan import laser_points
from navd.lifecycle.messages import (
    CancelGoal,
    Goal,
    GoalStatus,
    LaserScan,
    MapUpdate,
    Message,
    Path,
    PoseEstimate,
    StuckDetected,
    VelocityCommand,
)
from navd.lifecycle.module import Module, ModuleContext
from navd.planning.errors import PlanningError
from navd.planning.navigator import GoalState, NavGoal, Navigator, Step
from navd.planning.settings import NavigatorSettings
from navd.planning.warmup import warm_up

__all__ = ["PlannerNode", "PlannerSettings"]

POSE_TIMEOUT_S = 0.5
STATUS_PERIOD_S = 0.5
SOURCE = "planner"


@dataclass(frozen=True, slots=True)
class PlannerSettings:
    """The planner module's settings.

    Attributes:
        navigator: what the navigator runs on.
        control_period_s: [s] period of the control tick.
        mount: where the lidar sits, for the scan obstacles.
        obstacle_range_m: [m] farther ranges neither mark nor clear scan obstacles.
    """

    navigator: NavigatorSettings
    control_period_s: float
    mount: LidarMount
    obstacle_range_m: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> PlannerSettings:
        """The settings the robot, safety, planning and lidar sections describe."""
        return cls(
            navigator=NavigatorSettings.from_config(config),
            control_period_s=1.0 / config.planning.control_rate_hz,
            mount=LidarMount.of(config.lidar),
            obstacle_range_m=config.planning.obstacle_range_m,
        )


class PlannerNode(Module):
    """Runs the Navigator on live goals, poses, maps and scans."""

    def __init__(self) -> None:
        super().__init__("planner")
        self._lock = threading.Lock()
        self._pose: Pose2 | None = None
        self._pose_stamp = -math.inf
        self._planning = False
        self._plan_due: str | None = None
        self._status_at = -math.inf
        self._last_state: GoalState | None = None

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(PlannerSettings, self._settings_changed)
        self.nav = Navigator(self.settings.value.navigator)
        ctx.subscribe(Goal, self._on_goal)
        ctx.subscribe(CancelGoal, self._on_cancel)
        ctx.subscribe(PoseEstimate, self._on_pose)
        ctx.subscribe(MapUpdate, self._on_map)
        ctx.subscribe(LaserScan, self._on_scan)

    async def on_activate(self) -> None:
        self.ctx.warm_up(warm_up, name="warm-up")
        self.ctx.every(lambda: self.settings.value.control_period_s, self._tick, name="control")

    def settings_in_use(self) -> tuple[object, ...]:
        with self._lock:
            return (self.settings.value, *self.nav.settings_in_use())

    def _settings_changed(self, old: PlannerSettings, new: PlannerSettings) -> None:
        if new.navigator != old.navigator:
            with self._lock:
                self.nav.configure(new.navigator)

    async def on_deactivate(self) -> None:
        with self._lock:
            active = self.nav.cancel()
        if active is not None:
            self._stop("the daemon is stopping")
            self._status(active.goal_id, GoalState.CANCELED, reason="the daemon is stopping")

    # --- inputs (event loop) ---------------------------------------------------------------

    def _on_goal(self, goal: Goal) -> None:
        with self._lock:
            previous = self.nav.cancel()
            self.nav.set_goal(NavGoal(goal.goal_id, goal.x_m, goal.y_m, goal.yaw_rad))
            self._plan_due = "new goal"
        if previous is not None and previous.goal_id != goal.goal_id:
            self._status(
                previous.goal_id, GoalState.CANCELED, reason=f"replaced by {goal.goal_id!r}"
            )
        self.ctx.log.info("goal", goal_id=goal.goal_id, x=goal.x_m, y=goal.y_m, yaw=goal.yaw_rad)
        self._status(goal.goal_id, GoalState.ACTIVE)

    def _on_cancel(self, cancel: CancelGoal) -> None:
        with self._lock:
            goal = self.nav.goal
            if goal is None or (cancel.goal_id is not None and cancel.goal_id != goal.goal_id):
                return
            active = self.nav.cancel()
        if active is not None:
            self._stop("goal canceled")
            self._status(active.goal_id, GoalState.CANCELED, reason="canceled by a client")
            self.ctx.log.info("goal_canceled", goal_id=active.goal_id)

    def _on_pose(self, pose: PoseEstimate) -> None:
        self._pose = pose.pose
        self._pose_stamp = pose.stamp

    def _on_map(self, update: MapUpdate) -> None:
        def job() -> None:
            with self._lock:
                self.nav.set_map(
                    np.asarray(update.occupancy),
                    update.resolution_m,
                    update.origin_x_m,
                    update.origin_y_m,
                )

        self.ctx.submit("planning_map", job)

    def _on_scan(self, scan: LaserScan) -> None:
        pose = self._pose
        if pose is None:
            return
        settings = self.settings.value

        def job() -> None:
            points = laser_points(scan, settings.mount, max_range_m=settings.obstacle_range_m)
            with self._lock:
                self.nav.add_scan(pose, points.hits, points.misses, scan.stamp)

        self.ctx.submit("planning_scan", job)

    # --- control (event loop, then workers) ------------------------------------------------

    def _tick(self, now: float) -> None:
        """Event loop, cheap: submit this period's step, and A* if the last step asked."""
        pose = self._pose
        with self._lock:
            if self.nav.state is not GoalState.ACTIVE:
                return
        if pose is None or now - self._pose_stamp > POSE_TIMEOUT_S:
            self._stop("no fresh pose estimate")
            return
        with self._lock:
            reason = None if self._planning else self._plan_due
            if reason is not None:
                self._planning = True
                self._plan_due = None
        if reason is not None:
            self.ctx.submit("global_plan", lambda: self._plan(now, pose, reason))
        self.ctx.submit("local_plan", lambda: self._step(now, pose))

    def _plan(self, now: float, pose: Pose2, reason: str) -> tuple[Message, ...]:
        """Worker: a snapshot of the layers (under the lock), A* on it (outside), then the
        route to the navigator."""
        try:
            with self._lock:
                request = self.nav.request(now, pose)
            path = request.solve(self.nav.global_planner)
        except PlanningError as err:
            with self._lock:
                self.nav.plan_failed(now, err)
                self._planning = False
            self.ctx.log.warning("plan_failed", reason=reason, error=str(err))
            return ()
        with self._lock:
            goal = self.nav.goal
            self._planning = False
            if goal is None or (goal.x_m, goal.y_m) != request.goal_xy_m:
                return ()  # the goal changed meanwhile: this route is for the old one
            self.nav.accept_plan(now, path)
        self.ctx.log.info(
            "planned",
            reason=reason,
            length_m=round(path.length_m, 2),
            points=len(path.points_m),
            expanded=path.cells_expanded,
        )
        stamp = self.ctx.clock.now()
        return (Path(stamp=stamp, received=stamp, goal_id=goal.goal_id, points_m=path.points_m),)

    def _step(self, now: float, pose: Pose2) -> tuple[Message, ...]:
        """Worker: one navigator step; the command, and status when it is due."""
        with self._lock:
            goal = self.nav.goal
            if goal is None or self.nav.state is not GoalState.ACTIVE:
                return ()
            step = self.nav.step(now, pose)
            replans = self.nav.stuck_replans
            # Whether A* must run is decided here, in the worker; the next tick submits it.
            # While a search runs its reason still stands: asking again would plan twice.
            if not self._planning:
                self._plan_due = self.nav.plan_reason(now, pose)
        stamp = self.ctx.clock.now()
        messages: list[Message] = [
            VelocityCommand(
                stamp=stamp,
                received=stamp,
                linear_mps=step.linear_mps,
                angular_radps=step.angular_radps,
                source=SOURCE,
            )
        ]
        if step.stuck_detected:
            giving_up = step.state is GoalState.FAILED
            self.ctx.log.warning(
                "stuck", goal_id=goal.goal_id, replans=replans, giving_up=giving_up
            )
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
        status = self._status_due(goal.goal_id, step, stamp)
        if status is not None:
            messages.append(status)
        return tuple(messages)

    def _status_due(self, goal_id: str, step: Step, stamp: float) -> GoalStatus | None:
        changed = step.state is not self._last_state
        if not changed and stamp - self._status_at < STATUS_PERIOD_S:
            return None
        self._last_state = step.state
        self._status_at = stamp
        if changed and step.state is not GoalState.ACTIVE:
            self.ctx.log.info(
                "goal_done", goal_id=goal_id, state=str(step.state), reason=step.reason
            )
        return GoalStatus(
            stamp=stamp,
            received=stamp,
            goal_id=goal_id,
            state=str(step.state),
            distance_remaining_m=step.remaining_m,
            eta_s=step.eta_s,
            reason=step.reason,
        )

    def _stop(self, why: str) -> None:
        now = self.ctx.clock.now()
        self.ctx.publish(
            VelocityCommand(
                stamp=now, received=now, linear_mps=0.0, angular_radps=0.0, source=SOURCE
            )
        )
        self.ctx.log.debug("planner_stop", reason=why)

    def _status(self, goal_id: str, state: GoalState, reason: str = "") -> None:
        now = self.ctx.clock.now()
        self._last_state = state
        self._status_at = now
        self.ctx.publish(
            GoalStatus(stamp=now, received=now, goal_id=goal_id, state=str(state), reason=reason)
        )

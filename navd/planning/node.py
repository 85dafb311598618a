"""The planner module: goals in, velocity commands, routes and goal progress out.

Every ``planning.control_rate_hz`` tick (on the event loop, cheap) submits one navigator step
to the ``local_plan`` worker slot (goal checks, stuck handling, velocity profile, DWA; it
returns the VelocityCommand and decides whether the route must be planned); when the last
step said so, the tick also submits A* to the ``global_plan`` slot, which takes a snapshot of
the layers and plans on it. Goals and cancels reach the navigator through the
``planning_goals`` slot, map updates and scans through ``planning_map`` and
``planning_scan``. The navigator is shared by these threads under one lock, held only for
cheap work (A* runs outside it) and never taken on the event loop while the daemon runs, so
no snapshot of a large map can stall the loop. New settings reach the navigator under the
same lock, in a worker.

Operators drive by hand with ManualCommand: each is capped to the teleop limits and passed
to the safety gate as a VelocityCommand of its own source (``teleop:OPERATOR``), stamped
when it arrived, so the chassis stops on its own once they stop coming. While an operator
drives the navigator is not stepped and its goal shows as paused; ``teleop.resume_after_s``
after the last command the goal resumes, planned afresh. DriveMode says who drives.

A goal farther than ``planning.max_goal_distance_m`` from the robot fails at once with the
reason; one that needs a larger grid than ``planning.max_plan_cells`` fails when it is
planned; planning that breaks in any other way fails the goal too, never the module.

The robot is never driven on an old pose: when the last PoseEstimate is older than
``POSE_TIMEOUT_S`` the step commands zero. DWA's acceleration window starts from zero
whenever the robot was stopped meanwhile (a safety hold, a chassis that reopened its port, a
silence long enough for the chassis to stop itself), not from the navigator's last choice.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass

import numpy as np

from navd.geometry import Pose2, laser_points
from navd.lifecycle import Module, ModuleContext
from navd.lifecycle.messages import (
    CancelGoal,
    CostmapUpdate,
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DriveCommand,
    DriveMode,
    Goal,
    GoalStatus,
    LaserScan,
    LocalTrajectory,
    ManualCommand,
    MapUpdate,
    Message,
    NearbyRobots,
    Path,
    PoseEstimate,
    StuckDetected,
    TrackingLost,
    VelocityCommand,
    ViewInterest,
)
from navd.planning.costmap import ros_costmap
from navd.planning.dwa import arc
from navd.planning.errors import PlanningError
from navd.planning.goal import GoalState, NavGoal, Step
from navd.planning.manual import ManualDriving
from navd.planning.navigator import Navigator
from navd.planning.settings import PlannerSettings, goal_too_far
from navd.planning.warmup import warm_up

__all__ = ["PlannerNode"]


@dataclass(frozen=True, slots=True)
class _Resume:
    """Take up the goal ``goal_id`` again after manual driving, or once the robot lost on
    its map was found again (queued with goals)."""

    goal_id: str
    why: str = "resumed after manual driving"


POSE_TIMEOUT_S = 0.5
STATUS_PERIOD_S = 0.5
SOURCE = "planner"
PAUSED = "paused"  # GoalStatus.state of a goal paused while an operator drives
# [s] a search failing the same way (tried again at every tick while, say, another robot
# stands on the goal) is logged again at most this often, with how often it failed meanwhile
PLAN_FAILED_LOG_S = 5.0


class PlannerNode(Module):
    """Runs the Navigator on live goals, poses, maps and scans."""

    def __init__(self) -> None:
        super().__init__("planner")
        self._lock = threading.Lock()  # the navigator: worker jobs only, never the event loop
        self._flags = threading.Lock()  # the three fields below, a few lines at a time
        self._inbox: list[Goal | CancelGoal | _Resume] = []
        self._planning = False
        self._plan_due: str | None = None
        self._pose: Pose2 | None = None
        self._pose_stamp = -math.inf
        # Whether the robot stands still though the navigator may think otherwise: the gate
        # passed a stop, or the chassis (re)opened its port; and when the gate last spoke.
        self._stopped = False
        self._drive_stamp = -math.inf
        self._status_at = -math.inf
        self._last_state: GoalState | None = None
        self._broken: Exception | None = None  # a search that broke, not yet reported
        # the last planning failure logged (its text, when) and how many like it since: only
        # the planning worker touches them, one search at a time
        self._failure_logged: tuple[str, float] | None = None
        self._failures_unlogged = 0
        self.manual = ManualDriving()  # event loop only
        # What a viewer watches (set on the loop, read by workers: a stale glance costs one
        # message more or less)
        self._watched = ViewInterest(stamp=0.0, received=0.0, costmap=False, trajectory=False)
        self._teleop_refused: set[str] = set()  # operators told teleop is off (once each)
        self._lost = ""  # why the robot is lost on its map: the goal waits, stopped
        self._found_at: float | None = None  # found again then [s]: resume at the next pose

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(PlannerSettings.from_config, self._settings_changed)
        self.nav = Navigator(self.settings.value.navigator)
        ctx.subscribe(Goal, self._on_goal)
        ctx.subscribe(CancelGoal, self._on_cancel)
        ctx.subscribe(ManualCommand, self._on_manual)
        ctx.subscribe(ViewInterest, self._on_view_interest)
        ctx.subscribe(PoseEstimate, self._on_pose)
        ctx.subscribe(MapUpdate, self._on_map)
        ctx.subscribe(LaserScan, self._on_scan)
        ctx.subscribe(NearbyRobots, self._on_robots)
        ctx.subscribe(DriveCommand, self._on_drive)
        ctx.subscribe(DeviceLost, self._on_chassis)
        ctx.subscribe(DeviceConnected, self._on_chassis)
        ctx.subscribe(TrackingLost, self._on_tracking)

    async def on_activate(self) -> None:
        self.ctx.warm_up(warm_up, name="warm-up")
        self.ctx.every(lambda: self.settings.value.control_period_s, self._tick, name="control")

    def settings_in_use(self) -> tuple[object, ...]:
        with self._lock:  # a check's question (tests), not the running daemon's
            return (self.settings.value, *self.nav.settings_in_use())

    def _settings_changed(self, old: PlannerSettings, new: PlannerSettings) -> None:
        if new.navigator != old.navigator:

            def job() -> None:
                with self._lock:
                    self.nav.configure(new.navigator)

            self.ctx.submit("planning_settings", job)

    async def on_deactivate(self) -> None:
        with self._lock:  # the loop waits for the navigator once: the daemon is stopping
            active = self.nav.cancel()
        if active is not None:
            self.ctx.publish(self._stop_command())
            self.ctx.publish(
                self._status(active.goal_id, GoalState.CANCELED, "the daemon is stopping")
            )

    # --- inputs (event loop) ---------------------------------------------------------------

    def _on_goal(self, goal: Goal) -> None:
        pose = self._pose
        if pose is not None:
            refusal = goal_too_far(
                self.settings.value.navigator, (pose.x, pose.y), (goal.x_m, goal.y_m)
            )
            if refusal is not None:
                self.ctx.log.warning("goal_refused", goal_id=goal.goal_id, reason=refusal)
                self.ctx.publish(self._goal_status(goal.goal_id, GoalState.FAILED, refusal))
                return
        self._post(goal)

    def _on_cancel(self, cancel: CancelGoal) -> None:
        goal = self.nav.goal  # a glance without the lock: the job decides under it
        if (
            self.nav.state is GoalState.ACTIVE
            and goal is not None
            and cancel.goal_id in (None, goal.goal_id)
            and not self.manual.active  # an operator's driving is not the goal's to stop
        ):
            self.ctx.publish(self._stop_command())  # stopping never waits for a worker
        self._post(cancel)

    def _on_view_interest(self, interest: ViewInterest) -> None:
        self._watched = interest

    def _on_manual(self, cmd: ManualCommand) -> None:
        settings = self.settings.value.manual
        if not settings.enabled:
            if cmd.operator not in self._teleop_refused:
                self._teleop_refused.add(cmd.operator)
                self.ctx.log.warning(
                    "teleop_refused",
                    operator=cmd.operator,
                    reason="teleop.enabled is false; set it true to drive by hand",
                )
            return
        now = self.ctx.clock.now()
        linear, angular, started = self.manual.command(
            settings, cmd.operator, cmd.linear_mps, cmd.angular_radps, now
        )
        if started:
            goal = self.nav.goal if self.nav.state is GoalState.ACTIVE else None
            paused = "" if goal is None else goal.goal_id
            self.ctx.log.info("manual_drive", operator=cmd.operator, paused_goal=paused or None)
            self.ctx.publish(
                DriveMode(
                    stamp=now,
                    received=now,
                    mode="manual",
                    operator=cmd.operator,
                    paused_goal=paused,
                )
            )
            if goal is not None:
                why = f"an operator ({cmd.operator}) drives by hand"
                self.ctx.publish(self._status(goal.goal_id, GoalState.ACTIVE, why, shown=PAUSED))
        # Stamped when it arrived: the chassis stops once the operator's commands stop coming.
        self.ctx.publish(
            VelocityCommand(
                stamp=cmd.received,
                received=now,
                linear_mps=linear,
                angular_radps=angular,
                source=f"teleop:{cmd.operator}",
            )
        )

    def _end_manual(self, now: float) -> None:
        """Event loop: the operator has been quiet for teleop.resume_after_s; the navigator
        takes the goal up again (in a worker, under its lock)."""
        operator = self.manual.end()
        goal = self.nav.goal if self.nav.state is GoalState.ACTIVE else None
        self.ctx.log.info(
            "auto_drive", after=operator, resumed_goal=None if goal is None else goal.goal_id
        )
        self.ctx.publish(DriveMode(stamp=now, received=now, mode="auto"))
        if goal is not None:  # in line with goals and cancels: none replaces another
            self._post(_Resume(goal.goal_id))

    def _post(self, request: Goal | CancelGoal | _Resume) -> None:
        with self._flags:
            self._inbox.append(request)
        self.ctx.submit("planning_goals", self._take_requests)

    def _on_drive(self, cmd: DriveCommand) -> None:
        self._stopped = cmd.is_stop
        self._drive_stamp = cmd.stamp

    def _on_chassis(self, msg: DeviceLost | DeviceConnected) -> None:
        if msg.kind is DeviceKind.CHASSIS:  # the chassis stops on losing or reopening its port
            self._stopped = True

    def _on_tracking(self, tracking: TrackingLost) -> None:
        """Lost on the map: the goal waits, the robot stopped, while SLAM searches for it
        (the stuck watch must not count that time); found: the goal is taken up again from
        where the robot really is."""
        if tracking.lost:
            self._lost, self._found_at = tracking.reason, None
            self.ctx.publish(self._stop_command())
            goal = self.nav.goal if self.nav.state is GoalState.ACTIVE else None
            if goal is not None:
                why = f"waiting: {tracking.reason}"
                self.ctx.publish(self._status(goal.goal_id, GoalState.ACTIVE, why, shown=PAUSED))
        elif self._lost:
            # Found: the goal goes on from the first estimate made after the re-seed.
            self._found_at = tracking.received

    def _on_pose(self, pose: PoseEstimate) -> None:
        self._pose = pose.pose
        self._pose_stamp = pose.stamp
        if self._found_at is not None and pose.received >= self._found_at:
            self._lost, self._found_at = "", None
            goal = self.nav.goal if self.nav.state is GoalState.ACTIVE else None
            if goal is not None:
                self._post(_Resume(goal.goal_id, "found again on the map"))

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

    def _on_robots(self, nearby: NearbyRobots) -> None:
        def job() -> None:
            with self._lock:
                self.nav.set_robots(nearby.robots)

        self.ctx.submit("planning_robots", job)  # the latest wins

    def _on_scan(self, scan: LaserScan) -> None:
        pose = self._pose
        if pose is None:
            return
        settings = self.settings.value

        def job() -> None:
            mount = settings.mounts.lidar(scan.device_id)
            points = laser_points(scan, mount, max_range_m=settings.obstacle_range_m)
            with self._lock:
                self.nav.add_scan(
                    pose, points.hits, points.misses, scan.stamp, points.view, lidar=scan.device_id
                )

        # one slot per lidar: a busy worker must not keep dropping one lidar's marks
        self.ctx.submit(f"planning_scan:{scan.device_id}", job)

    # --- goals (worker) ----------------------------------------------------------------------

    def _take_requests(self) -> tuple[Message, ...]:
        """Worker: apply the goals and cancels that came, in order."""
        with self._flags:
            requests, self._inbox = self._inbox, []
        messages: list[Message] = []
        with self._lock:
            for request in requests:
                if isinstance(request, Goal):
                    messages += self._start(request)
                elif isinstance(request, CancelGoal):
                    messages += self._cancel(request)
                else:
                    messages += self._resume(request)
        return tuple(messages)

    def _resume(self, request: _Resume) -> list[Message]:
        """Take the goal up again after manual driving, if it is still the one paused."""
        goal = self.nav.goal
        if (
            goal is None
            or goal.goal_id != request.goal_id
            or self.nav.state is not GoalState.ACTIVE
        ):
            return []
        self.nav.resume(request.why)
        return [self._status(goal.goal_id, GoalState.ACTIVE)]

    def _start(self, goal: Goal) -> list[Message]:
        previous = self.nav.cancel()
        self.nav.set_goal(
            NavGoal(goal.goal_id, goal.x_m, goal.y_m, goal.yaw_rad, goal.max_speed_mps)
        )
        with self._flags:
            self._plan_due = "new goal"
        messages: list[Message] = []
        if previous is not None and previous.goal_id != goal.goal_id:
            why = f"replaced by {goal.goal_id!r}"
            messages.append(self._status(previous.goal_id, GoalState.CANCELED, why))
        self.ctx.log.info("goal", goal_id=goal.goal_id, x=goal.x_m, y=goal.y_m, yaw=goal.yaw_rad)
        operator = self.manual.operator  # a glance from the worker: the loop owns it
        if operator:
            why = f"an operator ({operator}) drives by hand"
            messages.append(self._status(goal.goal_id, GoalState.ACTIVE, why, shown=PAUSED))
        else:
            messages.append(self._status(goal.goal_id, GoalState.ACTIVE))
        return messages

    def _cancel(self, cancel: CancelGoal) -> list[Message]:
        goal = self.nav.goal
        if goal is None or cancel.goal_id not in (None, goal.goal_id):
            return []
        active = self.nav.cancel()
        if active is None:
            return []
        self.ctx.log.info("goal_canceled", goal_id=active.goal_id)
        canceled = self._status(active.goal_id, GoalState.CANCELED, "canceled by a client")
        if self.manual.active:
            return [canceled]  # an operator's driving is not the goal's to stop
        return [self._stop_command(), canceled]

    # --- control (event loop, then workers) ------------------------------------------------

    def _tick(self, now: float) -> None:
        """Event loop, cheap: submit this period's step, and A* if the last step asked."""
        broken, self._broken = self._broken, None
        if broken is not None:  # supervision hears of a search that broke (it failed its goal)
            self.ctx.bus.report_failure(self.name, {"job": "global_plan"}, broken)
        if self.manual.over(now):
            self._end_manual(now)
            return  # the goal resumes first (its job is queued); the next tick steps
        if self.manual.active or self._lost:
            return  # an operator drives, or the robot is lost: the navigator waits
        if self.nav.state is not GoalState.ACTIVE:  # a glance: the step decides under the lock
            return
        pose = self._pose
        if pose is None or now - self._pose_stamp > POSE_TIMEOUT_S:
            self.ctx.publish(self._stop_command())
            self.ctx.log.debug("planner_stop", reason="no fresh pose estimate")
            return
        with self._flags:
            reason = None if self._planning else self._plan_due
            if reason is not None:
                self._planning = True
                self._plan_due = None
        if reason is not None:
            self.ctx.submit("global_plan", lambda: self._plan(now, pose, reason))
        silent = now - self._drive_stamp > self.settings.value.reaction_timeout_s
        # From a standstill the ramp starts at zero, whatever the navigator last chose (the
        # gate held the robot, the chassis reopened, or stopped itself for want of commands).
        driven = (0.0, 0.0) if self._stopped or silent else None
        self._stopped = False
        self.ctx.submit("local_plan", lambda: self._step(now, pose, driven))

    def _log_failure(self, now: float, reason: str, error: str) -> None:
        """Log a failed search, unless it failed the same way within PLAN_FAILED_LOG_S."""
        last = self._failure_logged
        if last is not None and last[0] == error and now - last[1] < PLAN_FAILED_LOG_S:
            self._failures_unlogged += 1
            return
        self.ctx.log.warning(
            "plan_failed", reason=reason, error=error, repeats=self._failures_unlogged
        )
        self._failure_logged, self._failures_unlogged = (error, now), 0

    def _plan(self, now: float, pose: Pose2, reason: str) -> tuple[Message, ...]:
        """Worker: a snapshot of the layers (under the lock), A* on it (outside), then the
        route to the navigator. Whatever goes wrong fails or delays the goal with the reason;
        the next goal plans afresh. The search counts as over only once its outcome is in the
        navigator (under its lock): a step in between would see the reason it answered still
        standing and ask for the same search again."""
        goal = None
        began = time.perf_counter()
        try:
            with self._lock:
                goal = self.nav.goal
                request = self.nav.request(now, pose)
            costmap = request.costmap()
            path = request.solve(self.nav.global_planner, costmap)
        except PlanningError as err:
            self._log_failure(now, reason, str(err))
            with self._lock:
                if self.nav.goal is goal:
                    self.nav.plan_failed(now, err)
                self._planned()
                return self._failed()
        except Exception as err:  # out of memory, or a bug: the goal fails, the planner goes on
            self.ctx.log.exception("plan_broke", reason=reason, error=f"{type(err).__name__}")
            self._broken = err  # counted against the module at the next tick, on the loop
            with self._lock:
                if self.nav.goal is goal:
                    self.nav.abort(f"planning failed: {type(err).__name__}: {err}")
                self._planned()
                return self._failed()
        else:
            self._failure_logged, self._failures_unlogged = None, 0
            with self._lock:
                self._planned()
                if self.nav.goal is not goal or goal is None:
                    return ()  # the goal changed meanwhile: this route is for the old one
                self.nav.accept_plan(now, path)
        finally:
            self._planned()  # whatever happened, the planner is free for the next search
        self.ctx.log.info(
            "planned",
            reason=reason,
            length_m=round(path.length_m, 2),
            points=len(path.points_m),
            expanded=path.cells_expanded,
            reused=path.reused,
            window=path.fine_length_m is not None,  # a far goal's (``horizon``)
            ms=round(1e3 * (time.perf_counter() - began), 1),  # snapshot, costmap and search
        )
        stamp = self.ctx.clock.now()
        route = Path(stamp=stamp, received=stamp, goal_id=goal.goal_id, points_m=path.points_m)
        if not self._watched.costmap:
            return (route,)
        frame = costmap.frame
        shown = CostmapUpdate(
            stamp=stamp,
            received=stamp,
            resolution_m=frame.resolution_m,
            origin_x_m=frame.origin_x_m,
            origin_y_m=frame.origin_y_m,
            occupancy=ros_costmap(costmap),
        )
        return (route, shown)

    def _planned(self) -> None:
        with self._flags:
            self._planning = False

    def _failed(self) -> tuple[Message, ...]:
        """Under the lock: the stop and the status of a goal that has just failed, if it has."""
        goal, failure = self.nav.goal, self.nav.failure
        if goal is None or not failure or self._last_state is GoalState.FAILED:
            return ()  # not failed, or already told
        self.ctx.log.info("goal_done", goal_id=goal.goal_id, state="failed", reason=failure)
        return (self._stop_command(), self._status(goal.goal_id, GoalState.FAILED, failure))

    def _step(
        self, now: float, pose: Pose2, driven: tuple[float, float] | None
    ) -> tuple[Message, ...]:
        """Worker: one navigator step, from ``driven`` [m/s, rad/s] when the robot is known to
        do that rather than what the navigator chose last (None); the command, and status
        when it is due."""
        with self._lock:
            goal = self.nav.goal
            held = self.manual.active or self._lost
            if goal is None or self.nav.state is not GoalState.ACTIVE or held:
                return ()
            step = self.nav.step(now, pose, driven)
            replans = self.nav.stuck_replans
            # Whether A* must run is decided here, in the worker; the next tick submits it.
            # While a search runs its reason still stands: asking again would plan twice.
            due = self.nav.plan_reason(now, pose)
            with self._flags:
                if not self._planning:
                    self._plan_due = due
        stamp = self.ctx.clock.now()
        if self.manual.active or self._lost:
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
        if self._watched.trajectory:
            messages.append(self._trajectory(goal.goal_id, pose, step, stamp))
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

    def _trajectory(self, goal_id: str, pose: Pose2, step: Step, stamp: float) -> LocalTrajectory:
        """The chosen command rolled out over the local planner's horizon, for a viewer."""
        dwa = self.settings.value.navigator.dwa
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

    def _stop_command(self) -> VelocityCommand:
        now = self.ctx.clock.now()
        return VelocityCommand(
            stamp=now, received=now, linear_mps=0.0, angular_radps=0.0, source=SOURCE
        )

    def _status(
        self, goal_id: str, state: GoalState, reason: str = "", *, shown: str | None = None
    ) -> GoalStatus:
        """The status of the goal the navigator holds (remembered, so a step does not repeat
        it); ``shown`` replaces the state's name (an active goal shown as paused)."""
        message = self._goal_status(goal_id, shown or state, reason)
        self._last_state = state
        self._status_at = message.stamp
        return message

    def _goal_status(self, goal_id: str, state: str, reason: str = "") -> GoalStatus:
        now = self.ctx.clock.now()
        return GoalStatus(stamp=now, received=now, goal_id=goal_id, state=str(state), reason=reason)

"""The planner module: goals in, velocity commands, routes and goal progress out.

Every ``planning.control_rate_hz`` tick (on the event loop, cheap) submits one navigator step
to the ``local_plan`` worker slot (goal checks, stuck handling, velocity profile, DWA; it
returns the VelocityCommand and decides whether the route must be planned); when the last
step said so, the tick also submits A* to the ``global_plan`` slot, which takes a snapshot of
the layers and plans on it. Goals and cancels reach the navigator through the
``planning_goals`` slot, map updates and scans through ``planning_map`` and
``planning_scan`` (range sensors and depth cameras through ``planning_near``, each into the
proximity layer that lidar rays never clear; a bumper or a cliff sensor that is triggered
marks its spot there, kept ``CONTACT_MARK_S``). The jobs are ``navigator_jobs``': the
navigator is shared by these threads
under one lock, never taken on the event loop while the daemon runs, so no snapshot of a
large map can stall the loop. New settings reach the navigator under the same lock, in a
worker. What is said of the goal is ``goal_reports``'.

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
from collections.abc import Callable

import numpy as np

from navd.geometry import Pose2, ScanPoints, band_points, cone_points, laser_points
from navd.lifecycle import Module, ModuleContext
from navd.lifecycle.messages import (
    CancelGoal,
    Contact,
    DepthPoints,
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DriveCommand,
    DriveMode,
    EmergencyStop,
    Goal,
    LaserScan,
    ManualCommand,
    MapUpdate,
    NearbyRobots,
    PoseEstimate,
    RangeReading,
    TrackingLost,
    VelocityCommand,
    ViewInterest,
)
from navd.planning.goal import GoalState
from navd.planning.goal_reports import PAUSED, GoalReports
from navd.planning.manual import ManualDriving
from navd.planning.navigator import Navigator
from navd.planning.navigator_jobs import NavigatorJobs, Resume
from navd.planning.settings import PlannerSettings, goal_too_far
from navd.planning.warmup import warm_up

__all__ = ["PlannerNode"]

POSE_TIMEOUT_S = 0.5
CONTACT_MARK_S = 60.0  # [s] a spot a bumper or a cliff sensor felt is kept this long


class PlannerNode(Module):
    """Runs the Navigator on live goals, poses, maps and scans."""

    def __init__(self) -> None:
        super().__init__("planner")
        self._pose: Pose2 | None = None
        self._pose_stamp = -math.inf
        # Whether the robot stands still though the navigator may think otherwise: the gate
        # passed a stop, or the chassis (re)opened its port; and when the gate last spoke.
        self._stopped = False
        self._drive_stamp = -math.inf
        self.manual = ManualDriving()  # event loop only
        self._teleop_refused: set[str] = set()  # operators told teleop is off (once each)
        self._lost = ""  # why the robot is lost on its map: the goal waits, stopped
        self._found_at: float | None = None  # found again then [s]: resume at the next pose

    @property
    def nav(self) -> Navigator:
        """The navigator (its jobs', under their lock)."""
        return self.jobs.nav

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(PlannerSettings.from_config, self._settings_changed)
        self.reports = GoalReports(ctx.clock, ctx.log)
        self.jobs = NavigatorJobs(
            Navigator(self.settings.value.navigator),
            self.reports,
            clock=ctx.clock,
            log=ctx.log,
            held=lambda: self.manual.active or bool(self._lost),
            operator=lambda: self.manual.operator,  # a glance from the worker
            dwa=lambda: self.settings.value.navigator.dwa,
        )
        ctx.subscribe(Goal, self._on_goal)
        ctx.subscribe(CancelGoal, self._on_cancel)
        ctx.subscribe(EmergencyStop, self._on_emergency_stop)
        ctx.subscribe(ManualCommand, self._on_manual)
        ctx.subscribe(ViewInterest, self._on_view_interest)
        ctx.subscribe(PoseEstimate, self._on_pose)
        ctx.subscribe(MapUpdate, self._on_map)
        ctx.subscribe(LaserScan, self._on_scan)
        ctx.subscribe(RangeReading, self._on_range)
        ctx.subscribe(DepthPoints, self._on_depth)
        ctx.subscribe(Contact, self._on_contact)
        ctx.subscribe(NearbyRobots, self._on_robots)
        ctx.subscribe(DriveCommand, self._on_drive)
        ctx.subscribe(DeviceLost, self._on_chassis)
        ctx.subscribe(DeviceConnected, self._on_chassis)
        ctx.subscribe(TrackingLost, self._on_tracking)

    async def on_activate(self) -> None:
        self.ctx.warm_up(warm_up, name="warm-up")
        self.ctx.every(lambda: self.settings.value.control_period_s, self._tick, name="control")

    def settings_in_use(self) -> tuple[object, ...]:
        with self.jobs.lock:  # a check's question (tests), not the running daemon's
            return (self.settings.value, *self.nav.settings_in_use())

    def _settings_changed(self, old: PlannerSettings, new: PlannerSettings) -> None:
        if new.navigator != old.navigator:

            def job() -> None:
                with self.jobs.lock:
                    self.nav.configure(new.navigator)

            self.ctx.submit("planning_settings", job)

    async def on_deactivate(self) -> None:
        with self.jobs.lock:  # the loop waits for the navigator once: the daemon is stopping
            active = self.nav.cancel()
        if active is not None:
            self.ctx.publish(self.reports.stop())
            self.ctx.publish(
                self.reports.status(active.goal_id, GoalState.CANCELED, "the daemon is stopping")
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
                self.ctx.publish(self.reports.plain(goal.goal_id, GoalState.FAILED, refusal))
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
            self.ctx.publish(self.reports.stop())  # stopping never waits for a worker
        self._post(cancel)

    def _on_emergency_stop(self, stop: EmergencyStop) -> None:
        """An emergency stop ends the goal: released, the robot does not set off again by
        itself (a mission waits, paused, for a person to resume it)."""
        if stop.engaged:
            self._on_cancel(CancelGoal(stamp=stop.stamp, received=stop.received))

    def _on_view_interest(self, interest: ViewInterest) -> None:
        self.jobs.watched = interest

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
                self.ctx.publish(
                    self.reports.status(goal.goal_id, GoalState.ACTIVE, why, shown=PAUSED)
                )
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
            self._post(Resume(goal.goal_id))

    def _post(self, request: Goal | CancelGoal | Resume) -> None:
        self.jobs.post(request)
        self.ctx.submit("planning_goals", self.jobs.take_requests)

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
            self.ctx.publish(self.reports.stop())
            goal = self.nav.goal if self.nav.state is GoalState.ACTIVE else None
            if goal is not None:
                why = f"waiting: {tracking.reason}"
                self.ctx.publish(
                    self.reports.status(goal.goal_id, GoalState.ACTIVE, why, shown=PAUSED)
                )
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
                self._post(Resume(goal.goal_id, "found again on the map"))

    def _on_map(self, update: MapUpdate) -> None:
        def job() -> None:
            with self.jobs.lock:
                self.nav.set_map(
                    np.asarray(update.occupancy),
                    update.resolution_m,
                    update.origin_x_m,
                    update.origin_y_m,
                )

        self.ctx.submit("planning_map", job)

    def _on_robots(self, nearby: NearbyRobots) -> None:
        def job() -> None:
            with self.jobs.lock:
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
            with self.jobs.lock:
                self.nav.add_scan(
                    pose, points.hits, points.misses, scan.stamp, points.view, source=scan.device_id
                )

        # one slot per lidar: a busy worker must not keep dropping one lidar's marks
        self.ctx.submit(f"planning_scan:{scan.device_id}", job)

    def _on_range(self, reading: RangeReading) -> None:
        settings = self.settings.value
        self._near(
            f"range:{reading.sensor}",
            reading.stamp,
            lambda: cone_points(
                reading.range_m,
                reading.field_of_view_rad,
                reading.max_range_m,
                settings.mounts.body.range_sensor(reading.sensor),
                settings.obstacle_range_m,
            ),
        )

    def _on_depth(self, depth: DepthPoints) -> None:
        mount = self.settings.value.mounts.body.depth_camera  # (checked when it arrived)
        self._near(
            f"depth:{depth.sensor}",
            depth.stamp,
            lambda: band_points(depth.points_m, mount(depth.sensor)),
        )

    def _near(self, source: str, stamp: float, points_of: Callable[[], ScanPoints]) -> None:
        """A proximity sensor's points, into the live points and the proximity layer."""
        pose = self._pose
        if pose is None:
            return

        def job() -> None:
            points = points_of()
            with self.jobs.lock:
                self.nav.add_scan(
                    pose, points.hits, points.misses, stamp, points.view, source=source,
                    proximity=True,
                )  # fmt: skip

        self.ctx.submit(f"planning_near:{source}", job)

    def _on_contact(self, contact: Contact) -> None:
        pose = self._pose
        if not contact.triggered or pose is None:
            return
        mount = self.settings.value.mounts.body.contacts.get(contact.sensor)
        spot = (0.0, 0.0) if mount is None else (mount.x_m, mount.y_m)

        def job() -> None:
            with self.jobs.lock:
                self.nav.map_layers.mark_spot(pose, spot, contact.stamp + CONTACT_MARK_S)

        self.ctx.submit(f"planning_contact:{contact.sensor}", job)

    # --- control (event loop; the jobs run in workers) ----------------------------------

    def _tick(self, now: float) -> None:
        """Event loop, cheap: submit this period's step, and A* if the last step asked."""
        broken, self.jobs.broken = self.jobs.broken, None
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
            self.ctx.publish(self.reports.stop())
            self.ctx.log.debug("planner_stop", reason="no fresh pose estimate")
            return
        reason = self.jobs.next_search()
        if reason is not None:
            self.ctx.submit("global_plan", lambda: self.jobs.plan(now, pose, reason))
        silent = now - self._drive_stamp > self.settings.value.reaction_timeout_s
        # From a standstill the ramp starts at zero, whatever the navigator last chose (the
        # gate held the robot, the chassis reopened, or stopped itself for want of commands).
        driven = (0.0, 0.0) if self._stopped or silent else None
        self._stopped = False
        self.ctx.submit("local_plan", lambda: self.jobs.step(now, pose, driven))

"""The navigator: one goal at a time, from A* route to DWA commands to arrival.

Plain computation with the time passed in, so the daemon drives it from worker threads and
tests drive it from a loop. The pieces:

- layers: the SLAM map (static), scan obstacles (marked and cleared), keep-out zones; the
  costmap built from them on every plan;
- ``plan_reason`` says when the route must be (re)planned: a new goal, the replan timer, the
  robot straying from the route, the route blocked by a scan obstacle, stuck recovery;
  ``plan`` runs A* (heavy: a worker job) and ``accept_plan`` / ``plan_failed`` take the result;
- ``step`` runs once per control period: goal checks, stuck handling, velocity profile, DWA.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from navd.geometry import ALL_AROUND, FieldOfView, Pose2, angle_between, wrap_angle
from navd.planning.costmap import Costmap, build_costmap
from navd.planning.dwa import LocalPlanner, Window
from navd.planning.errors import GoalRefusedError, PlanningError
from navd.planning.global_planner import GlobalPlanner, PlannedPath
from navd.planning.goal import GoalState, NavGoal, Step
from navd.planning.layers import Layers
from navd.planning.plan_request import PlanRequest, plan_request
from navd.planning.route import Route
from navd.planning.settings import NavigatorSettings
from navd.planning.spot_turns import SpotTurns
from navd.planning.stuck import StuckMonitor, StuckPhase

__all__ = ["Navigator", "PlanRequest"]

FloatArray = npt.NDArray[np.float64]

# How far ahead along the route a scan obstacle counts as blocking it [m].
BLOCK_LOOKAHEAD_M = 3.0
# Stuck recovery forgets scan obstacles this far around the robot [m].
STUCK_CLEAR_RADIUS_M = 1.5
# [rad] within approach_distance_m of a goal with a heading, the robot steers for that heading
# only while the goal lies within this angle of it, seen from the robot: ahead along it. A goal
# abeam or behind it is driven to facing the way, then turned on (steering for the goal's
# heading with the goal abeam had the robot creep sideways).
APPROACH_ALIGN_RAD = math.radians(45.0)


class Navigator:
    """Drives to one goal at a time.

    Args:
        settings: what the navigator and its parts run on; ``configure`` swaps them.
    """

    def __init__(self, settings: NavigatorSettings) -> None:
        self.goal: NavGoal | None = None
        self.state: GoalState | None = None
        self.path: PlannedPath | None = None
        self.route: Route | None = None
        self.settings = settings
        self.map_layers = Layers(settings.layers)
        self.stuck = StuckMonitor(settings.stuck)
        self.global_planner = GlobalPlanner()
        self.profile = settings.profile
        self.local = LocalPlanner(settings.dwa, settings.profile.yaw_rate_table)
        self._command = (0.0, 0.0)
        self._planned_at = -math.inf
        self._moving_since: float | None = None
        self._failing_since: float | None = None
        self._plan_reason: str | None = None
        self._stuck_replans = 0
        self.turns = SpotTurns()  # turning on the spot to face the route (see step)
        self._last_error = ""
        self._fail_reason = ""

    def configure(self, settings: NavigatorSettings) -> None:
        """Take new settings (a runtime change): each part gets its own; the goal, the
        route, the layers' contents and the stuck watch in progress all stay."""
        self.settings = settings
        self.map_layers.configure(settings.layers)
        self.stuck.configure(settings.stuck)
        if settings.dwa != self.local.settings or settings.profile != self.profile:
            self.profile = settings.profile
            self.local = LocalPlanner(settings.dwa, settings.profile.yaw_rate_table)

    def settings_in_use(self) -> tuple[object, ...]:
        """The settings each part holds now."""
        return (
            self.settings,
            self.map_layers.settings,
            self.stuck.settings,
            self.profile,
            self.local.settings,
        )

    # --- inputs ----------------------------------------------------------------------------

    def set_goal(self, goal: NavGoal) -> None:
        """Start driving to ``goal`` (replacing any other)."""
        self.goal = goal
        self.state = GoalState.ACTIVE
        self.path = None
        self.route = None
        self._moving_since = None
        self._failing_since = None
        self._stuck_replans = 0
        self.via_passed = 0  # the goal's via points passed, in order
        self.turns.reset()
        self._plan_reason = "new goal"
        self.stuck.reset()

    def cancel(self) -> NavGoal | None:
        """Stop pursuing the goal; returns it (None if there was none active)."""
        goal = self.goal if self.state is GoalState.ACTIVE else None
        if goal is not None:
            self.state = GoalState.CANCELED
        self.path = None
        self.route = None
        self._command = (0.0, 0.0)
        return goal

    def set_map(
        self,
        occupancy: npt.NDArray[np.int8],
        resolution_m: float,
        origin_x_m: float,
        origin_y_m: float,
    ) -> None:
        """Take the SLAM map (-1 unknown, 0..100 % occupied; row = y)."""
        self.map_layers.set_map(occupancy, resolution_m, origin_x_m, origin_y_m)

    def set_robots(self, robots: tuple[tuple[str, float, float, float, float, float], ...]) -> None:
        """The fleet's other robots (see ``Layers.set_robots``): kept clear of like obstacles."""
        self.map_layers.set_robots(robots)

    def add_scan(
        self,
        pose: Pose2,
        hits_robot_m: FloatArray,
        misses_robot_m: FloatArray,
        stamp: float,
        view: FieldOfView = ALL_AROUND,
        *,
        source: str = "",
        proximity: bool = False,
    ) -> None:
        """Take a scan of ``source`` in the robot frame: the DWA's live obstacles, and marks
        in its obstacle layer (``Layers.add_scan``)."""
        self.map_layers.add_scan(
            pose, hits_robot_m, misses_robot_m, stamp, view, source=source, proximity=proximity
        )

    # --- planning --------------------------------------------------------------------------

    def plan_reason(self, now: float, pose: Pose2) -> str | None:
        """Why the route must be planned now, or None."""
        if self.state is not GoalState.ACTIVE or self.goal is None:
            return None
        if self._plan_reason is not None:
            return self._plan_reason
        if self.route is None:
            return "no route yet"
        s = self.settings
        period = s.replan_period_s
        if period > 0.0 and now - self._planned_at >= period:
            return "replan timer"
        fine = self.path.fine_length_m if self.path is not None else None
        if fine is not None and self.route.station(pose) > fine - s.layers.window_m / 3.0:
            return "near the end of the planning window"
        deviation = self.route.distance_to(pose)
        if deviation > s.max_path_deviation_m:
            return f"strayed {deviation:.2f} m from the route"
        radius = s.footprint.inscribed_m + s.keep_clear_m
        if self.route.blocked(self.map_layers.scan_points, radius, BLOCK_LOOKAHEAD_M):
            return "route blocked by an obstacle"
        return None

    def plan(self, now: float, pose: Pose2) -> PlannedPath:
        """A* from ``pose`` to the goal on a costmap of the current layers (heavy).

        Raises:
            PlanningError: no goal, or GoalUnreachableError / StartBlockedError from A*.
        """
        return self.request(now, pose).solve(self.global_planner)

    def request(self, now: float, pose: Pose2) -> PlanRequest:
        """A snapshot of what A* needs (cheap): solve it without holding the navigator.

        Raises:
            PlanningError: there is no goal.
            GoalRefusedError: the goal is too far from the robot, or the area to plan over
                too large.
        """
        goal = self.goal
        if goal is None:
            raise PlanningError("no goal to plan for")
        end, ahead = (goal.x_m, goal.y_m), goal.via[self.via_passed :]  # ahead: not passed
        return plan_request(self.map_layers, self.settings, now, (pose.x, pose.y), end, via=ahead)

    def accept_plan(self, now: float, path: PlannedPath) -> None:
        """Follow ``path`` from now on."""
        self.path = path
        self.route = Route(path.points_m)
        self._planned_at = now
        self._failing_since = None
        self._plan_reason = None

    def plan_failed(self, now: float, error: PlanningError) -> None:
        """A* found no route: keep trying until max_stuck_time_s has passed, then fail; a
        goal refused outright (GoalRefusedError) fails at once."""
        if isinstance(error, GoalRefusedError):
            self.abort(str(error))
            return
        if self._failing_since is None:
            self._failing_since = now
        self._planned_at = now
        self._plan_reason = None
        self.path = None
        self.route = None
        self._last_error = str(error)
        if now - self._failing_since >= self.settings.max_stuck_time_s:
            self.state = GoalState.FAILED
            self._fail_reason = f"no route for {now - self._failing_since:.0f} s: {error}"

    def resume(self, why: str = "resumed after manual driving") -> None:
        """Take up the goal again after someone else drove (an operator by hand), or after
        the robot lost on its map was found: it is somewhere else and stood still, so the
        route is planned afresh, the stuck watch and the no-route clock start over, and the
        ramp starts from zero."""
        if self.state is not GoalState.ACTIVE:
            return
        self._command = (0.0, 0.0)
        self._moving_since = None
        self._failing_since = None
        self._plan_reason = why
        self.stuck.reset()

    def abort(self, reason: str) -> None:
        """Fail the goal now, for ``reason`` (a goal refused, or planning that broke)."""
        if self.state is not GoalState.ACTIVE:
            return
        self.state = GoalState.FAILED
        self._fail_reason = reason
        self._command = (0.0, 0.0)
        self.path = None
        self.route = None

    def costmap(self, now: float, pose: Pose2) -> Costmap:
        """The inflated costmap of all layers now."""
        points = [(pose.x, pose.y)]
        if self.goal is not None:
            points.append((self.goal.x_m, self.goal.y_m))
        return build_costmap(*self.map_layers.snapshot(now, points), self.settings.costmap)

    # --- control ---------------------------------------------------------------------------

    def step(self, now: float, pose: Pose2, driven: tuple[float, float] | None = None) -> Step:
        """One control period at ``now`` [s] with the robot at ``pose``.

        ``driven`` [m/s, rad/s] is what the robot was last told to do, if the caller knows
        better than this navigator's own last choice (a safety hold or a chassis outage
        stopped it meanwhile): the acceleration limits apply from there. The goal's via
        points within its pass distance are passed first, in order.
        """
        goal = self.goal
        if goal is not None and self.state is GoalState.ACTIVE:
            via, near = goal.via, goal.pass_within_m
            while self.via_passed < len(via) and math.dist(via[self.via_passed], pose[:2]) <= near:
                self.via_passed += 1
        step = self._step(now, pose, driven)
        if goal is not None and step.state is GoalState.REACHED:
            self.via_passed = len(goal.via)  # at the end: every point on the way is behind
        return dataclasses.replace(step, via_passed=self.via_passed) if goal is not None else step

    def _step(self, now: float, pose: Pose2, driven: tuple[float, float] | None) -> Step:
        if driven is not None:
            self._command = driven
        goal = self.goal
        if self.state is not GoalState.ACTIVE or goal is None:
            self._command = (0.0, 0.0)
            if self.state is GoalState.FAILED:
                return Step(0.0, 0.0, self.state, reason=self._fail_reason)
            return Step(0.0, 0.0, self.state)
        s = self.settings
        distance = math.hypot(goal.x_m - pose.x, goal.y_m - pose.y)
        aligning = distance <= s.goal_xy_tolerance_m
        if aligning and (
            goal.yaw_rad is None
            or angle_between(goal.yaw_rad, pose.yaw) <= s.goal_yaw_tolerance_rad
        ):
            self.state = GoalState.REACHED
            self._command = (0.0, 0.0)
            return Step(0.0, 0.0, self.state, remaining_m=distance, eta_s=0.0)
        route = self.route
        if route is None:
            self._command = (0.0, 0.0)
            waiting = self._last_error if self._failing_since is not None else ""
            return Step(0.0, 0.0, self.state, reason=waiting or "waiting for a route")
        if self._moving_since is None:
            self._moving_since = now
        remaining = route.remaining(pose)
        stuck = self.stuck.update(now, pose)
        if stuck.phase is StuckPhase.STUCK:
            return self._stuck(now, pose, remaining)
        if stuck.phase is StuckPhase.BACKED_OUT:
            self._plan_reason = "backed out"
        carrot = route.carrot(pose, s.lookahead_m)
        if aligning:
            error = 0.0 if goal.yaw_rad is None else wrap_angle(goal.yaw_rad - pose.yaw)
            target, window = self.turns.aim(
                self.local, self._command, pose, self.profile.turn_rate(error), (goal.x_m, goal.y_m)
            )
        else:
            # Near the goal, arrive facing its heading, but only if the goal lies ahead along
            # that heading: a goal behind it (reached facing away from the way in) would have
            # the robot turn its back to the goal and creep away; it drives there facing the
            # way and turns on the spot.
            bearing = math.atan2(goal.y_m - pose.y, goal.x_m - pose.x)
            near_goal = (
                distance <= s.approach_distance_m
                and goal.yaw_rad is not None
                and angle_between(goal.yaw_rad, bearing) <= APPROACH_ALIGN_RAD
            )
            heading = (
                goal.yaw_rad
                if near_goal and goal.yaw_rad is not None
                else math.atan2(carrot[1] - pose.y, carrot[0] - pose.x)
            )
            target = Pose2(carrot[0], carrot[1], heading)
            cap = self.profile.speed_cap(remaining, now - self._moving_since)
            if goal.max_speed_mps is not None:
                cap = min(cap, goal.max_speed_mps)
            zoned = self.map_layers.zones.speed_fraction_on((pose.x, pose.y), carrot)
            cap = min(cap, zoned * self.profile.max_speed_mps)
            window = Window(
                cap,
                min_speed_mps=min(stuck.min_speed_mps, cap),
                backward=stuck.phase is StuckPhase.BACKING,
            )
        obstacles = self.map_layers.local_points(pose, s.local_radius_m, now)
        choice, turns, command = None, self.turns, self._command
        if turns.faces_route_first(command, pose, carrot, stuck.phase, aligning=aligning):
            choice = turns.toward(  # None when it cannot turn there usefully
                self.local, self.profile, command, pose, carrot, obstacles=obstacles, route=route
            )
        if choice is None:  # (a turn on the spot that would touch something: not that way)
            choice = self.local.choose(pose, self._command, obstacles, route.field, target, window)
        if choice is None:
            self._command = (0.0, 0.0)
            return Step(
                0.0,
                0.0,
                self.state,
                remaining,
                reason="every trajectory collides",
                phase=stuck.phase,
            )
        self._command = (choice.linear_mps, choice.angular_radps)
        speed = max(abs(choice.linear_mps), s.min_linear_speed_mps, 1e-3)
        return Step(
            choice.linear_mps,
            choice.angular_radps,
            self.state,
            remaining,
            remaining / speed,
            phase=stuck.phase,
        )

    def _stuck(self, now: float, pose: Pose2, remaining: float) -> Step:
        """StuckDetected: forget nearby scan obstacles and replan, or give up."""
        self._command = (0.0, 0.0)
        self.stuck.reset()
        self._stuck_replans += 1
        limit = self.settings.max_stuck_replans
        if self._stuck_replans > limit:
            self.state = GoalState.FAILED
            self._fail_reason = (
                f"stuck: no progress after {limit} replans "
                f"(max_stuck_time_s {self.settings.max_stuck_time_s} s each)"
            )
            reason, phase = self._fail_reason, StuckPhase.MOVING
        else:
            self.map_layers.forget_around(pose.x, pose.y, STUCK_CLEAR_RADIUS_M)
            self._plan_reason = "stuck recovery"
            reason, phase = "stuck: replanning", StuckPhase.STUCK
        return Step(
            0.0, 0.0, self.state, remaining, reason=reason, stuck_detected=True, phase=phase
        )

    @property
    def failure(self) -> str:
        """Why the goal failed ("" unless it did)."""
        return self._fail_reason if self.state is GoalState.FAILED else ""

    @property
    def stuck_replans(self) -> int:
        """How many times the robot has been stuck on this goal."""
        return self._stuck_replans

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

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import ALL_AROUND, FieldOfView, Pose2, angle_between, wrap_angle
from navd.planning.costmap import Costmap, CostmapSettings, GridFrame, build_costmap
from navd.planning.dwa import DwaChoice, LocalPlanner, Window
from navd.planning.errors import GoalRefusedError, PlanningError
from navd.planning.global_planner import GlobalPlanner, PlannedPath, SearchSettings
from navd.planning.goal import GoalState, NavGoal, Step
from navd.planning.horizon import COARSE_CELL_M, COARSE_MAX_CELLS, CoarseLayers, plan_far
from navd.planning.layers import Layers
from navd.planning.route import Route
from navd.planning.settings import NavigatorSettings, goal_too_far
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


@dataclass(frozen=True, slots=True)
class PlanRequest:
    """Everything A* needs, copied out of the navigator so it can run in another thread."""

    frame: GridFrame
    obstacles: npt.NDArray[np.bool_]
    unknown: npt.NDArray[np.bool_]
    settings: CostmapSettings
    search: SearchSettings
    start_xy_m: tuple[float, float]
    goal_xy_m: tuple[float, float]
    coarse: CoarseLayers | None = None  # a far goal's whole area (the layers: the window)

    def costmap(self) -> Costmap:
        """The layers inflated, with the settings of when it was asked (heavy)."""
        return build_costmap(self.frame, self.obstacles, self.unknown, self.settings)

    def solve(self, planner: GlobalPlanner, costmap: Costmap | None = None) -> PlannedPath:
        """Run A* (heavy) on ``costmap``, or on the layers inflated now.

        Raises:
            GoalUnreachableError, StartBlockedError: from A*.
        """
        if costmap is None:
            costmap = self.costmap()
        if self.coarse is not None:
            settings = (self.settings, self.search)
            return plan_far(
                costmap,
                self.coarse,
                settings=settings,
                start_xy_m=self.start_xy_m,
                goal_xy_m=self.goal_xy_m,
                fine_planner=planner,
            )
        return planner.plan(costmap, self.start_xy_m, self.goal_xy_m, self.search)


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
        self._turning_first = False  # turning on the spot to face the route (see step)
        self._turn_refused = False  # ... and it could not: not again until the robot moved
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
        self._turning_first = False
        self._turn_refused = False
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
        lidar: str = "",
    ) -> None:
        """Take a scan of lidar ``lidar`` (points in the robot frame) seen from ``pose`` at
        ``stamp``, its rays covering ``view``: its hits are the DWA's live obstacles (with the
        other lidars' latest); it marks and clears the obstacle layer."""
        self.map_layers.add_scan(pose, hits_robot_m, misses_robot_m, stamp, view, lidar=lidar)

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
        if self.goal is None:
            raise PlanningError("no goal to plan for")
        start = (pose.x, pose.y)
        goal = (self.goal.x_m, self.goal.y_m)
        too_far = goal_too_far(self.settings, start, goal)
        if too_far is not None:
            raise GoalRefusedError(too_far)
        s = self.settings
        layers = self.map_layers
        if layers.needs_window(now, start, goal):
            coarse = CoarseLayers(
                *layers.coarse_snapshot(now, [start, goal], COARSE_MAX_CELLS, COARSE_CELL_M)
            )
            frame, obstacles, unknown = layers.window_snapshot(now, start)
            return PlanRequest(frame, obstacles, unknown, s.costmap, s.search, start, goal, coarse)
        frame, obstacles, unknown = layers.snapshot(now, [start, goal])
        return PlanRequest(frame, obstacles, unknown, s.costmap, s.search, start, goal)

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
        stopped it meanwhile): the acceleration limits apply from there.
        """
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
            target, window = self._turn_on_the_spot(
                pose, self.profile.turn_rate(error), (goal.x_m, goal.y_m)
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
            zones = self.map_layers.zones
            if zones.speed is not None:  # a speed zone here, or where the robot is heading
                fraction = min(
                    zones.speed_fraction_at(pose.x, pose.y),
                    zones.speed_fraction_at(carrot[0], carrot[1]),
                )
                cap = min(cap, fraction * self.profile.max_speed_mps)
            window = Window(
                cap,
                min_speed_mps=min(stuck.min_speed_mps, cap),
                backward=stuck.phase is StuckPhase.BACKING,
            )
        obstacles = self.map_layers.local_points(pose, s.local_radius_m, now)
        turning = self._faces_route_first(pose, carrot, stuck.phase, aligning=aligning)
        choice = self._turn_toward(pose, carrot, obstacles, route) if turning else None
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

    def _turn_on_the_spot(
        self, pose: Pose2, rate: float, at: tuple[float, float]
    ) -> tuple[Pose2, Window]:
        """The local planner's target and window for turning on the spot at ``rate`` [rad/s]
        (the profile's ``turn_rate``, signed).

        The local planner picks the turn whose horizon ends nearest the heading it is given:
        it is given the heading that rate reaches within the horizon.
        """
        horizon = self.local.settings.horizon_s
        # A robot still turning the other way ends its horizon that far round already: the
        # aim comes nearer, or it would read as a heading that way round.
        against = min(math.copysign(1.0, rate) * self._command[1], 0.0) * horizon
        reach = max(min(abs(rate) * horizon, MAX_TURN_AIM_RAD + against), 0.0)
        return Pose2(at[0], at[1], pose.yaw + math.copysign(reach, rate)), Window(
            0.0, rotate_only=True
        )

    def _turn_toward(
        self, pose: Pose2, point: tuple[float, float], obstacles: FloatArray, route: Route
    ) -> DwaChoice | None:
        """The local planner's turn on the spot toward ``point``; None, and no such turn again
        until the robot has moved, if it cannot turn there usefully (see TURN_USEFUL_SHARE)."""
        toward = math.atan2(point[1] - pose.y, point[0] - pose.x)
        wanted = self.profile.turn_rate(wrap_angle(toward - pose.yaw))
        target, window = self._turn_on_the_spot(pose, wanted, point)
        choice = self.local.choose(pose, self._command, obstacles, route.field, target, window)
        side = math.copysign(1.0, wanted)
        now_toward = side * self._command[1]  # [rad/s] negative: still turning the other way
        step = self.local.settings.angular_accel_radps2 * self.local.settings.period_s
        if now_toward < 0.0:  # still turning the other way: it must slow that turn
            useful = now_toward + TURN_USEFUL_SHARE * step
        else:
            useful = TURN_USEFUL_SHARE * min(abs(wanted), now_toward + step)
        if choice is None or side * choice.angular_radps < useful:
            self._turning_first = False
            self._turn_refused = True
            return None
        return choice

    def _faces_route_first(
        self, pose: Pose2, carrot: tuple[float, float], phase: StuckPhase, *, aligning: bool
    ) -> bool:
        """Whether to turn on the spot toward the route before driving on (see
        TURN_FIRST_RAD); never while stuck handling pushes or backs the robot, nor at the goal
        (turning to its heading)."""
        if aligning:
            self._turning_first = False
            return False
        off = angle_between(pose.yaw, math.atan2(carrot[1] - pose.y, carrot[0] - pose.x))
        standing = abs(self._command[0]) < STANDING_MPS
        self._turn_refused = self._turn_refused and standing
        if self._turn_refused:
            return False
        keep = off > ROUTE_FACED_RAD if self._turning_first else standing and off > TURN_FIRST_RAD
        self._turning_first = phase is StuckPhase.MOVING and keep
        return self._turning_first

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
            return Step(
                0.0, 0.0, self.state, remaining, reason=self._fail_reason, stuck_detected=True
            )
        self.map_layers.forget_around(pose.x, pose.y, STUCK_CLEAR_RADIUS_M)
        self._plan_reason = "stuck recovery"
        return Step(
            0.0,
            0.0,
            self.state,
            remaining,
            reason="stuck: replanning",
            stuck_detected=True,
            phase=StuckPhase.STUCK,
        )

    @property
    def failure(self) -> str:
        """Why the goal failed ("" unless it did)."""
        return self._fail_reason if self.state is GoalState.FAILED else ""

    @property
    def stuck_replans(self) -> int:
        """How many times the robot has been stuck on this goal."""
        return self._stuck_replans

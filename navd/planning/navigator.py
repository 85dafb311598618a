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
from enum import StrEnum

import numpy as np
import numpy.typing as npt

from navd.config import NavdConfig
from navd.planning.costmap import (
    Costmap,
    CostmapSettings,
    GridFrame,
    ObstacleLayer,
    build_costmap,
    keep_out_mask,
    static_layer,
)
from navd.planning.dwa import DwaSettings, LocalPlanner, PathField, Window, path_field
from navd.planning.errors import PlanningError
from navd.planning.footprint import Footprint, keep_clear_m
from navd.planning.global_planner import GlobalPlanner, PlannedPath
from navd.planning.profile import VelocityProfile
from navd.planning.stuck import StuckMonitor, StuckPhase

__all__ = ["GoalState", "NavGoal", "Navigator", "PlanRequest", "Step"]

FloatArray = npt.NDArray[np.float64]

# Unmapped space planned through around the robot and the goal [m].
FRAME_MARGIN_M = 3.0
# How far ahead along the route a scan obstacle counts as blocking it [m].
BLOCK_LOOKAHEAD_M = 3.0
# Stuck recovery forgets scan obstacles this far around the robot [m].
STUCK_CLEAR_RADIUS_M = 1.5


class GoalState(StrEnum):
    """Where a goal stands (GoalStatus.state)."""

    ACTIVE = "active"
    REACHED = "reached"
    FAILED = "failed"
    CANCELED = "canceled"


@dataclass(frozen=True, slots=True)
class NavGoal:
    """A goal in the map frame: [m, m], and [rad] or None for any heading."""

    goal_id: str
    x_m: float
    y_m: float
    yaw_rad: float | None = None


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
    """

    linear_mps: float
    angular_radps: float
    state: GoalState | None
    remaining_m: float = math.nan
    eta_s: float = math.nan
    reason: str = ""
    stuck_detected: bool = False
    phase: StuckPhase = StuckPhase.MOVING


@dataclass(frozen=True, slots=True)
class PlanRequest:
    """Everything A* needs, copied out of the navigator so it can run in another thread."""

    frame: GridFrame
    obstacles: npt.NDArray[np.bool_]
    unknown: npt.NDArray[np.bool_]
    settings: CostmapSettings
    start_xy_m: tuple[float, float]
    goal_xy_m: tuple[float, float]

    def solve(self, planner: GlobalPlanner) -> PlannedPath:
        """Inflate the layers and run A* (heavy).

        Raises:
            GoalUnreachableError, StartBlockedError: from A*.
        """
        costmap = build_costmap(self.frame, self.obstacles, self.unknown, self.settings)
        return planner.plan(costmap, self.start_xy_m, self.goal_xy_m)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class Navigator:
    """Drives to one goal at a time.

    Args:
        config: the whole config (robot, safety and planning sections).
    """

    def __init__(self, config: NavdConfig) -> None:
        self.goal: NavGoal | None = None
        self.state: GoalState | None = None
        self.path: PlannedPath | None = None
        self._field: PathField | None = None
        self._cumulative: FloatArray = np.zeros(1)
        self._progress = 0
        self._map: tuple[GridFrame, npt.NDArray[np.bool_], npt.NDArray[np.bool_]] | None = None
        self._obstacles: ObstacleLayer | None = None
        self._scan_points: FloatArray = np.empty((0, 2))
        self._command = (0.0, 0.0)
        self._planned_at = -math.inf
        self._moving_since: float | None = None
        self._failing_since: float | None = None
        self._plan_reason: str | None = None
        self._stuck_replans = 0
        self._last_error = ""
        self._fail_reason = ""
        self._keep_out_cache: (
            tuple[GridFrame, tuple[tuple[tuple[float, float], ...], ...], npt.NDArray[np.bool_]]
            | None
        ) = None
        self.configure(config)

    def configure(self, config: NavdConfig) -> None:
        """Take a new config (runtime changes); the route and goal stay."""
        self.config = config
        planning = config.planning
        self.footprint = Footprint.from_config(config.robot)
        self.costmap_settings = CostmapSettings.from_config(config)
        self.profile = VelocityProfile.from_config(config)
        self.local = LocalPlanner(DwaSettings.from_config(config), self.profile.yaw_rate_cap)
        self.global_planner = GlobalPlanner(
            cost_weight=planning.cost_weight, smooth=planning.smooth_path
        )
        self.stuck = StuckMonitor(config)
        # Map cells handed to DWA: everything its rollouts and their clearance can reach.
        self._local_radius_m = (
            max(config.robot.max_linear_speed_mps, config.robot.max_reverse_speed_mps)
            * planning.prediction_horizon_s
            + self.footprint.circumradius_m
            + max(planning.inflation_radius_m, keep_clear_m(config))
            + 0.5
        )
        if self._obstacles is not None:
            self._obstacles.persistence_s = planning.obstacle_persistence_s

    # --- inputs ----------------------------------------------------------------------------

    def set_goal(self, goal: NavGoal) -> None:
        """Start driving to ``goal`` (replacing any other)."""
        self.goal = goal
        self.state = GoalState.ACTIVE
        self.path = None
        self._field = None
        self._moving_since = None
        self._failing_since = None
        self._stuck_replans = 0
        self._plan_reason = "new goal"
        self.stuck.reset()

    def cancel(self) -> NavGoal | None:
        """Stop pursuing the goal; returns it (None if there was none active)."""
        goal = self.goal if self.state is GoalState.ACTIVE else None
        if goal is not None:
            self.state = GoalState.CANCELED
        self.path = None
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
        rows, cols = occupancy.shape
        frame = GridFrame(resolution_m, origin_x_m, origin_y_m, rows, cols)
        occupied, unknown = static_layer(occupancy, self.config.planning.occupied_threshold_pct)
        self._map = (frame, occupied, unknown)

    def add_scan(
        self,
        pose: tuple[float, float, float],
        hits_robot_m: FloatArray,
        misses_robot_m: FloatArray,
        stamp: float,
    ) -> None:
        """Take a scan (points in the robot frame) seen from ``pose`` [m, m, rad] at ``stamp``.

        Its hits are the DWA's live obstacles; it marks and clears the obstacle layer.
        """
        hits = _to_map(pose, hits_robot_m)
        self._scan_points = hits
        if self._obstacles is None:
            return
        self._obstacles.add_scan((pose[0], pose[1]), hits, _to_map(pose, misses_robot_m), stamp)

    # --- planning --------------------------------------------------------------------------

    def plan_reason(self, now: float, pose: tuple[float, float, float]) -> str | None:
        """Why the route must be planned now, or None."""
        if self.state is not GoalState.ACTIVE or self.goal is None:
            return None
        if self._plan_reason is not None:
            return self._plan_reason
        if self.path is None:
            return "no route yet"
        period = self.config.planning.replan_period_s
        if period > 0.0 and now - self._planned_at >= period:
            return "replan timer"
        deviation = self._distance_to_path(pose)
        if deviation > self.config.planning.max_path_deviation_m:
            return f"strayed {deviation:.2f} m from the route"
        if self._route_blocked():
            return "route blocked by an obstacle"
        return None

    def plan(self, now: float, pose: tuple[float, float, float]) -> PlannedPath:
        """A* from ``pose`` to the goal on a costmap of the current layers (heavy).

        Raises:
            PlanningError: no goal, or GoalUnreachableError / StartBlockedError from A*.
        """
        return self.request(now, pose).solve(self.global_planner)

    def request(self, now: float, pose: tuple[float, float, float]) -> PlanRequest:
        """A snapshot of what A* needs (cheap): solve it without holding the navigator.

        Raises:
            PlanningError: there is no goal.
        """
        if self.goal is None:
            raise PlanningError("no goal to plan for")
        frame, obstacles, unknown = self.layers(now, pose)
        return PlanRequest(
            frame,
            obstacles,
            unknown,
            self.costmap_settings,
            (pose[0], pose[1]),
            (self.goal.x_m, self.goal.y_m),
        )

    def accept_plan(self, now: float, path: PlannedPath) -> None:
        """Follow ``path`` from now on."""
        self.path = path
        self._field = path_field(path.points_m)
        steps = np.hypot(*np.diff(path.points_m, axis=0).T) if len(path.points_m) > 1 else []
        self._cumulative = np.concatenate([[0.0], np.cumsum(steps)])
        self._progress = 0
        self._planned_at = now
        self._failing_since = None
        self._plan_reason = None

    def plan_failed(self, now: float, error: PlanningError) -> None:
        """A* found no route: keep trying until max_stuck_time_s has passed, then fail."""
        if self._failing_since is None:
            self._failing_since = now
        self._planned_at = now
        self._plan_reason = None
        self.path = None
        self._last_error = str(error)
        if now - self._failing_since >= self.config.planning.max_stuck_time_s:
            self.state = GoalState.FAILED
            self._fail_reason = f"no route for {now - self._failing_since:.0f} s: {error}"

    def layers(
        self, now: float, pose: tuple[float, float, float]
    ) -> tuple[GridFrame, npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
        """(frame, obstacle cells, unknown cells) of all layers now, on a frame holding the
        map, the robot and the goal."""
        frame = self._frame(pose)
        obstacles = np.zeros(frame.shape, dtype=np.bool_)
        unknown = np.ones(frame.shape, dtype=np.bool_)
        if self._map is not None:
            map_frame, occupied, map_unknown = self._map
            window = _placement(frame, map_frame)
            obstacles[window] = occupied
            unknown[window] = map_unknown
        if self._obstacles is None:
            self._obstacles = ObstacleLayer(frame, self.config.planning.obstacle_persistence_s)
        self._obstacles.reframe(frame)
        obstacles |= self._obstacles.active(now)
        obstacles |= self._keep_out(frame)
        return frame, obstacles, unknown

    def _keep_out(self, frame: GridFrame) -> npt.NDArray[np.bool_]:
        """The keep-out cells of ``frame``, computed once per frame and set of zones."""
        zones = self.config.planning.keep_out_zones
        cached = self._keep_out_cache
        if cached is None or cached[0] != frame or cached[1] != zones:
            cached = (frame, zones, keep_out_mask(frame, zones))
            self._keep_out_cache = cached
        return cached[2]

    def costmap(self, now: float, pose: tuple[float, float, float]) -> Costmap:
        """The inflated costmap of all layers now."""
        return build_costmap(*self.layers(now, pose), self.costmap_settings)

    # --- control ---------------------------------------------------------------------------

    def step(self, now: float, pose: tuple[float, float, float]) -> Step:
        """One control period at ``now`` [s] with the robot at ``pose`` [m, m, rad]."""
        goal = self.goal
        if self.state is not GoalState.ACTIVE or goal is None:
            self._command = (0.0, 0.0)
            if self.state is GoalState.FAILED:
                return Step(0.0, 0.0, self.state, reason=self._fail_reason)
            return Step(0.0, 0.0, self.state)
        planning = self.config.planning
        distance = math.hypot(goal.x_m - pose[0], goal.y_m - pose[1])
        aligning = distance <= planning.goal_xy_tolerance_m
        if aligning and (
            goal.yaw_rad is None
            or abs(_wrap(goal.yaw_rad - pose[2])) <= planning.goal_yaw_tolerance_rad
        ):
            self.state = GoalState.REACHED
            self._command = (0.0, 0.0)
            return Step(0.0, 0.0, self.state, remaining_m=distance, eta_s=0.0)
        if self.path is None or self._field is None:
            self._command = (0.0, 0.0)
            waiting = self._last_error if self._failing_since is not None else ""
            return Step(0.0, 0.0, self.state, reason=waiting or "waiting for a route")
        if self._moving_since is None:
            self._moving_since = now
        remaining = self._remaining(pose)
        stuck = self.stuck.update(now, *pose)
        if stuck.phase is StuckPhase.STUCK:
            return self._stuck(now, pose, remaining)
        if stuck.phase is StuckPhase.BACKED_OUT:
            self._plan_reason = "backed out"
        carrot = self._carrot(pose)
        if aligning:
            target = (goal.x_m, goal.y_m, goal.yaw_rad if goal.yaw_rad is not None else pose[2])
            window = Window(0.0, rotate_only=True)
        else:
            near_goal = distance <= planning.approach_distance_m and goal.yaw_rad is not None
            heading = (
                goal.yaw_rad
                if near_goal and goal.yaw_rad is not None
                else math.atan2(carrot[1] - pose[1], carrot[0] - pose[0])
            )
            target = (carrot[0], carrot[1], heading)
            window = Window(
                self.profile.speed_cap(remaining, now - self._moving_since),
                min_speed_mps=stuck.min_speed_mps,
                backward=stuck.phase is StuckPhase.BACKING,
            )
        choice = self.local.choose(
            pose, self._command, self._local_obstacles(pose), self._field, target, window
        )
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
        speed = max(abs(choice.linear_mps), planning.min_linear_speed_mps, 1e-3)
        return Step(
            choice.linear_mps,
            choice.angular_radps,
            self.state,
            remaining,
            remaining / speed,
            phase=stuck.phase,
        )

    def _stuck(self, now: float, pose: tuple[float, float, float], remaining: float) -> Step:
        """StuckDetected: forget nearby scan obstacles and replan, or give up."""
        self._command = (0.0, 0.0)
        self.stuck.reset()
        self._stuck_replans += 1
        limit = self.config.planning.max_stuck_replans
        if self._stuck_replans > limit:
            self.state = GoalState.FAILED
            self._fail_reason = (
                f"stuck: no progress after {limit} replans "
                f"(max_stuck_time_s {self.config.planning.max_stuck_time_s} s each)"
            )
            return Step(
                0.0, 0.0, self.state, remaining, reason=self._fail_reason, stuck_detected=True
            )
        if self._obstacles is not None:
            self._obstacles.clear_disc(pose[0], pose[1], STUCK_CLEAR_RADIUS_M)
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
    def stuck_replans(self) -> int:
        """How many times the robot has been stuck on this goal."""
        return self._stuck_replans

    # --- geometry helpers ------------------------------------------------------------------

    def _frame(self, pose: tuple[float, float, float]) -> GridFrame:
        """The map's frame grown in whole cells to hold the robot and goal with a margin."""
        res = self._map[0].resolution_m if self._map is not None else 0.05
        xs = [pose[0]]
        ys = [pose[1]]
        if self.goal is not None:
            xs.append(self.goal.x_m)
            ys.append(self.goal.y_m)
        lo_x, hi_x = min(xs) - FRAME_MARGIN_M, max(xs) + FRAME_MARGIN_M
        lo_y, hi_y = min(ys) - FRAME_MARGIN_M, max(ys) + FRAME_MARGIN_M
        if self._map is not None:
            m = self._map[0]
            ax, ay = m.origin_x_m, m.origin_y_m
            lo_x, lo_y = min(lo_x, ax), min(lo_y, ay)
            hi_x, hi_y = max(hi_x, ax + m.cols * res), max(hi_y, ay + m.rows * res)
        elif self._obstacles is not None:
            ax, ay = self._obstacles.frame.origin_x_m, self._obstacles.frame.origin_y_m
        else:
            ax, ay = 0.0, 0.0
        # Snap to the anchor's cell lattice so layers can move between frames.
        ox = ax + math.floor((lo_x - ax) / res) * res
        oy = ay + math.floor((lo_y - ay) / res) * res
        cols = math.ceil((hi_x - ox) / res)
        rows = math.ceil((hi_y - oy) / res)
        if self._obstacles is not None:
            old = self._obstacles.frame
            if old.resolution_m == res:
                # Never shrink below the obstacle layer's frame: its marks stay.
                ox2 = min(ox, old.origin_x_m)
                oy2 = min(oy, old.origin_y_m)
                cols = round((max(ox + cols * res, old.origin_x_m + old.cols * res) - ox2) / res)
                rows = round((max(oy + rows * res, old.origin_y_m + old.rows * res) - oy2) / res)
                ox, oy = ox2, oy2
        return GridFrame(res, ox, oy, rows, cols)

    def _local_obstacles(self, pose: tuple[float, float, float]) -> FloatArray:
        """[m] obstacle points near the robot: live scan hits, map and keep-out cells."""
        parts = [self._scan_points]
        if self._map is not None:
            frame, occupied, _ = self._map
            parts.append(_cells_near(frame, occupied, pose, self._local_radius_m))
        if self.config.planning.keep_out_zones and self._obstacles is not None:
            frame = self._obstacles.frame
            mask = self._keep_out(frame)
            parts.append(_cells_near(frame, mask, pose, self._local_radius_m))
        return np.concatenate(parts) if len(parts) > 1 else parts[0]

    def _closest(self, pose: tuple[float, float, float]) -> tuple[int, float, float]:
        """(segment index, fraction along it, distance [m]) of the route point nearest the
        robot, searched forward from the last progress (progress never goes back)."""
        assert self.path is not None
        points = self.path.points_m
        if points.shape[0] == 1:
            return 0, 0.0, float(math.hypot(points[0, 0] - pose[0], points[0, 1] - pose[1]))
        a = points[self._progress : -1]
        b = points[self._progress + 1 :]
        ab = b - a
        p = np.array([pose[0], pose[1]])
        length2 = np.maximum((ab**2).sum(axis=1), 1e-12)
        t = np.clip(((p - a) * ab).sum(axis=1) / length2, 0.0, 1.0)
        nearest = a + t[:, None] * ab
        d = np.hypot(*(nearest - p).T)
        i = int(np.argmin(d))
        self._progress += i
        return self._progress, float(t[i]), float(d[i])

    def _distance_to_path(self, pose: tuple[float, float, float]) -> float:
        if self.path is None:
            return math.inf
        return self._closest(pose)[2]

    def _remaining(self, pose: tuple[float, float, float]) -> float:
        """[m] from the robot along the route to the goal."""
        seg, t, d = self._closest(pose)
        if self._cumulative.size < 2:
            return d
        here = self._cumulative[seg] + t * (self._cumulative[seg + 1] - self._cumulative[seg])
        return float(d + self._cumulative[-1] - here)

    def _carrot(self, pose: tuple[float, float, float]) -> tuple[float, float]:
        """The route point lookahead_m ahead of the robot's nearest route point."""
        assert self.path is not None
        seg, t, _ = self._closest(pose)
        points = self.path.points_m
        if points.shape[0] == 1:
            return float(points[0, 0]), float(points[0, 1])
        here = self._cumulative[seg] + t * (self._cumulative[seg + 1] - self._cumulative[seg])
        at = min(here + self.config.planning.lookahead_m, float(self._cumulative[-1]))
        x = float(np.interp(at, self._cumulative, points[:, 0]))
        y = float(np.interp(at, self._cumulative, points[:, 1]))
        return x, y

    def _route_blocked(self) -> bool:
        """True if a live scan hit lies on the route ahead, closer than the robot's radius."""
        if self.path is None or self._scan_points.shape[0] == 0:
            return False
        seg = self._progress
        ahead = self._cumulative[seg] + BLOCK_LOOKAHEAD_M
        stations = np.arange(self._cumulative[seg], min(ahead, self._cumulative[-1]), 0.1)
        if stations.size == 0:
            return False
        route = np.column_stack(
            [
                np.interp(stations, self._cumulative, self.path.points_m[:, 0]),
                np.interp(stations, self._cumulative, self.path.points_m[:, 1]),
            ]
        )
        radius = self.footprint.inscribed_m + keep_clear_m(self.config)
        diff = route[:, None, :] - self._scan_points[None, :, :]
        return bool((np.einsum("ijk,ijk->ij", diff, diff) < radius**2).any())


def _to_map(pose: tuple[float, float, float], points: FloatArray) -> FloatArray:
    """Robot-frame points [m] seen from ``pose`` in the map frame."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    pts = points.reshape(-1, 2)
    return np.column_stack(
        [pose[0] + c * pts[:, 0] - s * pts[:, 1], pose[1] + s * pts[:, 0] + c * pts[:, 1]]
    )


def _placement(outer: GridFrame, inner: GridFrame) -> tuple[slice, slice]:
    """The slices of ``outer`` covering ``inner`` (same lattice, inner inside outer)."""
    r = round((inner.origin_y_m - outer.origin_y_m) / outer.resolution_m)
    c = round((inner.origin_x_m - outer.origin_x_m) / outer.resolution_m)
    return slice(r, r + inner.rows), slice(c, c + inner.cols)


def _cells_near(
    frame: GridFrame, mask: npt.NDArray[np.bool_], pose: tuple[float, float, float], radius_m: float
) -> FloatArray:
    """[m] centres of the ``mask`` cells within a square of half-size radius_m around pose."""
    r0, c0 = frame.cell_of(pose[0] - radius_m, pose[1] - radius_m)
    r1, c1 = frame.cell_of(pose[0] + radius_m, pose[1] + radius_m)
    r0, c0 = max(r0, 0), max(c0, 0)
    r1, c1 = min(r1 + 1, frame.rows), min(c1 + 1, frame.cols)
    if r1 <= r0 or c1 <= c0:
        return np.empty((0, 2))
    cells = np.argwhere(mask[r0:r1, c0:c1]) + np.array([r0, c0])
    return frame.centers_of(cells.astype(np.int64))

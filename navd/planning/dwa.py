"""The DWA local planner (seed 001 §3.11): sample the dynamic window, roll out, score, choose."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import Footprint, Pose2
from navd.planning._distance_kernels import distance_to
from navd.planning._dwa_kernels import (
    METRICS,
    bucket_points,
    chamfer_distance,
    choose,
    rollouts,
    snap_near,
    window_samples,
)

__all__ = ["DwaChoice", "DwaSettings", "LocalPlanner", "PathField", "Window", "path_field"]

FloatArray = npt.NDArray[np.float64]

# The distance grid of the obstacles near the robot [m per cell].
LOCAL_CELL_M = 0.05
# Obstacle points are merged into cells this size [m] (a lidar 0.6 m from a wall puts several
# beams in each), each replaced by its cell's centre; the margin grows by the half diagonal so
# no test becomes less strict.
SNAP_M = 0.01
SNAP_SLACK_M = SNAP_M * math.sqrt(0.5)
# Path-field cells [m], and how far beyond the path it reaches [m].
PATH_CELL_M = 0.05
PATH_FIELD_MARGIN_M = 2.0


@dataclass(frozen=True, slots=True)
class DwaSettings:
    """The local planner's plain values.

    Attributes:
        footprint: the robot's shape.
        margin_m: [m] distance every rollout keeps from obstacles (collision_distance).
        clearance_cap_m: [m] clearance beyond this no longer scores better.
        horizon_s, step_s: [s] rollout length and step.
        period_s: [s] control period: the window is what the accelerations reach in it.
        linear_samples, angular_samples: samples across the window.
        max_speed_mps, max_reverse_mps, max_yaw_rate_radps: [m/s, m/s, rad/s] robot limits.
        linear_accel_mps2, angular_accel_radps2: [m/s^2, rad/s^2] acceleration limits.
        weights: goal, path, clearance, oscillation and heading weights.
    """

    footprint: Footprint
    margin_m: float
    clearance_cap_m: float
    horizon_s: float
    step_s: float
    period_s: float
    linear_samples: int
    angular_samples: int
    max_speed_mps: float
    max_reverse_mps: float
    max_yaw_rate_radps: float
    linear_accel_mps2: float
    angular_accel_radps2: float
    weights: tuple[float, float, float, float, float]


@dataclass(frozen=True, slots=True)
class PathField:
    """[m] distance to the global path on a grid around it; ``far_m`` outside the grid."""

    distance_m: npt.NDArray[np.float32]
    origin_x_m: float
    origin_y_m: float
    cell_m: float
    far_m: float


def path_field(points_m: FloatArray, cell_m: float = PATH_CELL_M) -> PathField:
    """The distance-to-path grid of a polyline (seed: closeness to the global path as a
    look-up), covering the path's bounding box plus PATH_FIELD_MARGIN_M."""
    lo = points_m.min(axis=0) - PATH_FIELD_MARGIN_M
    hi = points_m.max(axis=0) + PATH_FIELD_MARGIN_M
    cols, rows = (np.ceil((hi - lo) / cell_m).astype(int) + 1).tolist()
    on_path = np.zeros((rows, cols), dtype=np.bool_)
    for a, b in itertools.pairwise(points_m):
        n = max(int(np.ceil(np.hypot(*(b - a)) / (0.5 * cell_m))), 1)
        t = np.linspace(0.0, 1.0, n + 1)[:, None]
        cells = np.floor((a + t * (b - a) - lo) / cell_m).astype(int)
        on_path[cells[:, 1], cells[:, 0]] = True
    if points_m.shape[0] == 1:
        c, r = np.floor((points_m[0] - lo) / cell_m).astype(int)
        on_path[r, c] = True
    distance = (distance_to(on_path) * cell_m).astype(np.float32)
    return PathField(distance, float(lo[0]), float(lo[1]), cell_m, PATH_FIELD_MARGIN_M)


@dataclass(frozen=True, slots=True)
class Window:
    """What the caller allows this cycle (velocity profile and stuck handling).

    Attributes:
        max_speed_mps: [m/s] forward cap (the profile's).
        min_speed_mps: [m/s] smallest |v| allowed (0: any; stuck handling raises it).
        backward: only reversing trajectories (stuck handling); otherwise only forward ones.
        rotate_only: only turning on the spot (aligning with the goal's heading).
    """

    max_speed_mps: float
    min_speed_mps: float = 0.0
    backward: bool = False
    rotate_only: bool = False


@dataclass(frozen=True, slots=True)
class DwaChoice:
    """The chosen command and what it was chosen from.

    Attributes:
        linear_mps, angular_radps: the command.
        trajectory: [m, m, rad] N x 3 poses the command would follow.
        rollouts: how many (v, ω) pairs were scored.
        valid: how many of them do not collide.
    """

    linear_mps: float
    angular_radps: float
    trajectory: FloatArray
    rollouts: int
    valid: int


class LocalPlanner:
    """DWA over the robot's dynamic window.

    Args:
        settings: limits, footprint, sampling and weights.
        yaw_rate_table: (speeds [m/s], top yaw rates [rad/s]) of the profile's table, read
            by linear interpolation of |v|; None: ``max_yaw_rate_radps`` at every speed.
    """

    def __init__(
        self,
        settings: DwaSettings,
        yaw_rate_table: tuple[Sequence[float], Sequence[float]] | None = None,
    ) -> None:
        self.settings = settings
        speeds, rates = yaw_rate_table if yaw_rate_table is not None else ((), ())
        self._table_speeds = np.array(speeds, dtype=np.float64)
        self._table_rates = np.array(rates, dtype=np.float64)
        self.steps = max(round(settings.horizon_s / settings.step_s), 1)
        fp = settings.footprint
        self._footprint = np.array(
            [
                fp.kind,
                fp.half_length_m,
                fp.half_width_m,
                fp.circumradius_m,
                settings.margin_m + SNAP_SLACK_M,
                settings.clearance_cap_m,
                fp.inscribed_m,
            ]
        )
        self._weights = np.array(settings.weights, dtype=np.float64)

    def velocities(self, current: tuple[float, float], window: Window) -> FloatArray:
        """K x 2 (v, ω) samples of the dynamic window around the ``current`` command."""
        s = self.settings
        if window.backward:
            lo, hi = -s.max_reverse_mps, -min(window.min_speed_mps, s.max_reverse_mps)
        else:
            lo, hi = 0.0, window.max_speed_mps  # reversing is for stuck recovery only
        return window_samples(  # (one type per argument: the kernel is compiled once)
            float(current[0]),
            float(current[1]),
            float(s.linear_accel_mps2 * s.period_s),
            float(s.angular_accel_radps2 * s.period_s),
            float(lo),
            float(hi),
            int(s.linear_samples),
            int(s.angular_samples),
            float(window.min_speed_mps),
            bool(window.rotate_only),
            bool(window.backward),
            float(s.max_yaw_rate_radps),
            self._table_speeds,
            self._table_rates,
        )

    def choose(  # noqa: PLR0917 - the inputs of one cycle, each named in the docstring
        self,
        pose: Pose2,
        current: tuple[float, float],
        obstacles_m: FloatArray,
        path: PathField,
        target: Pose2,
        window: Window,
    ) -> DwaChoice | None:
        """The best command for the next period, or None when every rollout collides.

        Args:
            pose: the robot in the map frame.
            current: [m/s, rad/s] the command now in force (the window's centre).
            obstacles_m: [m] M x 2 obstacle points near the robot (map frame).
            path: the global path's distance field.
            target: the point to head for and the heading wanted there.
            window: the profile's and stuck handling's limits.
        """
        s = self.settings
        velocities = self.velocities(current, window)
        fp = s.footprint
        reach = max(s.max_speed_mps, s.max_reverse_mps) * s.horizon_s
        half = reach + fp.circumradius_m + max(s.margin_m, s.clearance_cap_m) + 2 * LOCAL_CELL_M
        ox, oy = pose.x - half, pose.y - half
        n = math.ceil(2 * half / LOCAL_CELL_M)
        near = snap_near(  # (a read-only or strided array would be a type of its own)
            np.require(obstacles_m, np.float64, ("C", "W")),
            float(pose.x),
            float(pose.y),
            float(half),
            SNAP_M,
        )
        distance = chamfer_distance(near, ox, oy, LOCAL_CELL_M, n, n)
        bucket = fp.circumradius_m + s.margin_m + SNAP_SLACK_M
        nb = math.ceil(2 * half / bucket)
        start, order = bucket_points(near, ox, oy, bucket, nb, nb)
        local = np.array([ox, oy, LOCAL_CELL_M, n, n, bucket, nb, nb], dtype=np.float64)
        k = velocities.shape[0]
        metrics = np.empty((k, METRICS))
        colliding = np.empty(k, dtype=np.bool_)
        v_span = max(s.max_speed_mps + s.max_reverse_mps, 1e-6)
        targets = np.array(
            [
                target.x,
                target.y,
                target.yaw,
                current[0],
                current[1],
                v_span,
                2 * s.max_yaw_rate_radps,
            ]
        )
        rollouts(
            np.array(pose, dtype=np.float64),
            velocities,
            s.step_s,
            self.steps,
            self._footprint,
            near,
            local,
            distance,
            start,
            order,
            path.distance_m,
            np.array([path.origin_x_m, path.origin_y_m, path.cell_m, path.far_m]),
            targets,
            metrics,
            colliding,
        )
        best, _ = choose(metrics, colliding, self._weights)
        if best < 0:
            return None
        v, w = velocities[best]
        return DwaChoice(
            float(v),
            float(w),
            arc(pose, float(v), float(w), s.step_s, self.steps),
            k,
            int(k - colliding.sum()),
        )


def arc(pose: Pose2, v: float, w: float, dt: float, steps: int) -> FloatArray:
    """[m, m, rad] N x 3 poses after 1..steps steps of dt [s] at constant (v, ω) from ``pose``."""
    x0, y0, yaw0 = pose
    t = dt * np.arange(1, steps + 1)
    yaw = yaw0 + w * t
    if abs(w) < 1e-9:
        x = x0 + v * t * math.cos(yaw0)
        y = y0 + v * t * math.sin(yaw0)
    else:
        x = x0 + v / w * (np.sin(yaw) - math.sin(yaw0))
        y = y0 - v / w * (np.cos(yaw) - math.cos(yaw0))
    return np.column_stack([x, y, yaw])

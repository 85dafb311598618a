"""``navd barn``: the BARN benchmark (Perille et al. 2020) on navd's planner.

Each world is a field of 0.075 m cylinders (``barn_cylinders.csv.gz``); the robot, a
Jackal-sized rectangle with a 270° lidar, starts at (-2.25, 3) facing +y and must get within
1 m of (-2.25, 13) without touching anything, within 100 s. The score of a run (the official
one) is success · T* / clip(t, 2 T*, 8 T*), with T* the reference path's length (from
``path_files/path_<i>.npy``, start and goal added) over 2 m/s; the best possible is 0.5.

As in the challenge, the robot knows its odometry (here exact) and sees the world through its
lidar only: no map is given. The runs use navd's navigator (the same costmap, A*, DWA,
velocity profile and stuck handling the daemon runs), the collision guard the safety gate
asks about every command, a body that follows its commands within the acceleration limits,
and simulated time, as fast as the CPU allows.
"""

from __future__ import annotations

import csv
import gzip
import math
import statistics
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from navd.config import NavdConfig
from navd.geometry import Pose2, scan_points
from navd.planning import (
    GUARD_REACH_M,
    GoalState,
    NavGoal,
    Navigator,
    NavigatorSettings,
    PlanningError,
    guard_scale,
    guard_settings,
    warm_up_guard,
)
from navd.sim._sim_kernels import cast_rays
from navd.sim.body import Body
from navd.sim.errors import SimError
from navd.sim.world import World, from_shapes

__all__ = ["BarnRun", "jackal_config", "load_cylinders", "run_barn", "run_world"]

FloatArray = npt.NDArray[np.float64]

START = (-2.25, 3.0, math.pi / 2)
GOAL = (-2.25, 13.0)
SUCCESS_RADIUS_M = 1.0
TIME_LIMIT_S = 100.0
CYLINDER_RADIUS_M = 0.075
CONTROL_DT_S = 0.05
PHYSICS_SUBSTEPS = 5
SCAN_EVERY = 2  # control periods per scan: 10 Hz
LIDAR_FOV_RAD = math.radians(270.0)
LIDAR_BEAMS = 720
LIDAR_RANGE_M = 10.0
LIDAR_X_M = -0.065  # the challenge's UST-10 mount
LIDAR_MOUNT = Pose2(LIDAR_X_M, 0.0, 0.0)


def jackal_config() -> NavdConfig:
    """navd tuned for a Clearpath Jackal in BARN's tight fields."""
    return NavdConfig.model_validate(
        {
            "robot": {
                "footprint": "rectangle",
                "length_m": 0.508,
                "width_m": 0.430,
                "track_width_m": 0.37,
                "max_linear_speed_mps": 1.5,
                "max_reverse_speed_mps": 0.5,
                "max_angular_speed_radps": 2.0,
                "max_linear_accel_mps2": 2.0,
                "max_angular_accel_radps2": 4.0,
            },
            # BARN's fields leave a few centimetres on either side: no slow-down band, the
            # guard stops what would come within DWA's own margin
            "safety": {
                "collision_distance_m": 0.03,
                "stop_distance_m": 0.03,
                "slowdown_distance_m": 0.03,
            },
            "lidar": {"x_m": LIDAR_X_M},
            "planning": {
                "angular_limit_table": [[0.0, 2.0], [1.5, 1.0]],
                "inflation_radius_m": 0.4,
                "cost_decay": 6.0,
                "lookahead_m": 1.2,
                "prediction_horizon_s": 1.5,
                "approach_distance_m": 0.5,
                "goal_xy_tolerance_m": 0.5,
                "replan_period_s": 1.0,
                "obstacle_persistence_s": 30.0,
                "stuck_time_s": 2.0,
                "stuck_time_force_backward_s": 3.0,
                "max_stuck_time_s": 8.0,
                "backup_distance_m": 0.3,
                "max_stuck_replans": 5,
            },
        }
    )


def load_cylinders(dataset: Path) -> dict[int, FloatArray]:
    """World index -> N x 2 cylinder centres [m] from ``barn_cylinders.csv.gz``.

    Raises:
        SimError: the file is missing or malformed.
    """
    path = dataset / "barn_cylinders.csv.gz"
    if not path.is_file():
        raise SimError(f"{path} not found: point --dataset at a BARN folder (see its README)")
    worlds: dict[int, list[tuple[float, float]]] = {}
    try:
        with gzip.open(path, "rt", encoding="utf-8") as f:
            for row in csv.DictReader(f):
                worlds.setdefault(int(row["world_idx"]), []).append(
                    (float(row["x_m"]), float(row["y_m"]))
                )
    except (OSError, KeyError, ValueError) as err:
        raise SimError(f"{path}: {err}") from err
    return {i: np.array(c) for i, c in worlds.items()}


def reference_length_m(dataset: Path, index: int) -> float:
    """[m] the official path length L: start, the path file's cells, goal.

    Raises:
        SimError: the path file is missing.
    """
    path = dataset / "path_files" / f"path_{index}.npy"
    if not path.is_file():
        raise SimError(f"{path} not found")
    cells = np.load(path)
    points = np.column_stack([0.15 * cells[:, 0] - 4.575, 0.15 * cells[:, 1] + 5.075])
    points = np.vstack([[START[0], START[1]], points, [GOAL[0], GOAL[1]]])
    return float(np.hypot(*np.diff(points, axis=0).T).sum())


@dataclass(frozen=True, slots=True)
class BarnRun:
    """One run's outcome."""

    world: int
    success: bool
    collided: bool
    timeout: bool
    time_s: float
    score: float


def barn_world(cylinders: FloatArray) -> World:
    """The cylinders as a simulator world."""
    circles = [[float(x), float(y), CYLINDER_RADIUS_M] for x, y in cylinders]
    return from_shapes({"resolution_m": 0.01, "circles": circles, "start": list(START)}, "barn")


def run_world(
    index: int, cylinders: FloatArray, optimal_length_m: float, config: NavdConfig
) -> BarnRun:
    """Drive one BARN world with navd's navigator in simulated time."""
    guard = guard_settings(config)
    warm_up_guard(guard)  # the guard stops the robot while its kernel is not loaded
    world = barn_world(cylinders)
    nav = Navigator(NavigatorSettings.from_config(config))
    nav.set_goal(NavGoal("barn", GOAL[0], GOAL[1]))
    near = np.empty((0, 2))  # [m] the latest scan's hits within the guard's reach
    driven: tuple[float, float] | None = None
    body = Body(*START)
    no_discs = np.empty((0, 3))
    beams = -LIDAR_FOV_RAD / 2 + LIDAR_FOV_RAD * np.arange(LIDAR_BEAMS) / (LIDAR_BEAMS - 1)
    increment = LIDAR_FOV_RAD / (LIDAR_BEAMS - 1)
    t = 0.0
    step = 0
    while t < TIME_LIMIT_S:
        pose = Pose2(body.x_m, body.y_m, body.yaw_rad)
        if math.hypot(GOAL[0] - pose.x, GOAL[1] - pose.y) <= SUCCESS_RADIUS_M:
            return _run(index, True, False, False, t, optimal_length_m)
        if step % SCAN_EVERY == 0:
            lidar = pose.compose(LIDAR_MOUNT)
            ranges = cast_rays(
                world.grid,
                world.origin_x_m,
                world.origin_y_m,
                world.resolution_m,
                lidar.x,
                lidar.y,
                (beams + pose.yaw).astype(np.float64),
                LIDAR_RANGE_M,
                no_discs,
            )
            points = scan_points(
                ranges,
                float(beams[0]),
                increment,
                range_min=0.05,
                range_max=LIDAR_RANGE_M,
                mount=LIDAR_MOUNT,
            )
            nav.add_scan(pose, points.hits, points.misses, t, points.view)
            near = points.hits[np.hypot(*points.hits.T) <= GUARD_REACH_M]
        if nav.plan_reason(t, pose) is not None:
            try:
                nav.accept_plan(t, nav.plan(t, pose))
            except PlanningError as err:
                nav.plan_failed(t, err)
        result = nav.step(t, pose, driven)
        if result.state is GoalState.FAILED:
            break  # the navigator gave up: the run times out, still and safe
        # the safety gate's guard, as in the daemon; after a stop the ramp starts at zero
        scale, _ = guard_scale(near, result.linear_mps, result.angular_radps, guard)
        command = (result.linear_mps * scale, result.angular_radps * scale)
        driven = (0.0, 0.0) if command == (0.0, 0.0) else None
        for _ in range(PHYSICS_SUBSTEPS):
            body.step(CONTROL_DT_S / PHYSICS_SUBSTEPS, command, config, world, no_discs)
            if body.collisions:
                return _run(index, False, True, False, t, optimal_length_m)
        t += CONTROL_DT_S
        step += 1
    return _run(index, False, False, True, TIME_LIMIT_S, optimal_length_m)


def _run(  # noqa: PLR0917 - one positional per BarnRun field
    index: int, success: bool, collided: bool, timeout: bool, t: float, length: float
) -> BarnRun:
    """The run's record with its official score (T* = length / 2 m/s)."""
    optimal = length / 2.0
    score = optimal / min(max(t, 2 * optimal), 8 * optimal) if success else 0.0
    return BarnRun(index, success, collided, timeout, t, score)


def run_barn(
    dataset: Path, *, worlds: list[int] | None = None, config: NavdConfig | None = None
) -> dict[str, Any]:
    """Run the worlds given (default: every world in the dataset) and summarize.

    Raises:
        SimError: the dataset is missing or a world is not in it.
    """
    cylinders = load_cylinders(dataset)
    chosen = sorted(cylinders) if worlds is None else worlds
    missing = [w for w in chosen if w not in cylinders]
    if missing:
        raise SimError(f"worlds {missing} are not in {dataset}")
    config = config or jackal_config()
    runs = [run_world(w, cylinders[w], reference_length_m(dataset, w), config) for w in chosen]
    n = len(runs)
    return {
        "worlds": n,
        "success": round(sum(r.success for r in runs) / n, 4),
        "collision": round(sum(r.collided for r in runs) / n, 4),
        "timeout": round(sum(r.timeout for r in runs) / n, 4),
        "mean_score": round(statistics.fmean(r.score for r in runs), 4),
        "mean_time_success_s": round(statistics.fmean(r.time_s for r in runs if r.success), 2)
        if any(r.success for r in runs)
        else None,
        "failed_worlds": [r.world for r in runs if not r.success],
    }

"""A kinematic robot driven by the Navigator in a world of wall segments, for tests.

The robot executes each command exactly for one control period (a perfect chassis), sees the
walls through a 360-beam lidar every period, and plans synchronously when the navigator asks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from navd.bench.synthetic_room import cast
from navd.config import NavdConfig
from navd.geometry import Footprint, Pose2, scan_points, wrap_angle
from navd.planning.errors import PlanningError
from navd.planning.goal import GoalState, NavGoal, Step
from navd.planning.navigator import Navigator
from navd.planning.settings import NavigatorSettings

FloatArray = npt.NDArray[np.float64]


@dataclass
class Drive:
    """What happened on a drive."""

    state: GoalState | None
    poses: list[Pose2] = field(default_factory=list)
    commands: list[tuple[float, float]] = field(default_factory=list)
    plan_reasons: list[str] = field(default_factory=list)
    steps: list[Step] = field(default_factory=list)
    min_clearance_m: float = math.inf
    time_s: float = 0.0


def rasterize(
    walls: FloatArray, resolution_m: float, lo: tuple[float, float], shape: tuple[int, int]
) -> npt.NDArray[np.int8]:
    """An occupancy grid (0 free, 100 occupied) of wall segments."""
    grid = np.zeros(shape, dtype=np.int8)
    for x0, y0, x1, y1 in walls:
        n = math.ceil(math.hypot(x1 - x0, y1 - y0) / (0.25 * resolution_m)) + 1
        t = np.linspace(0.0, 1.0, n)
        cols = np.floor((x0 + t * (x1 - x0) - lo[0]) / resolution_m).astype(int)
        rows = np.floor((y0 + t * (y1 - y0) - lo[1]) / resolution_m).astype(int)
        ok = (rows >= 0) & (rows < shape[0]) & (cols >= 0) & (cols < shape[1])
        grid[rows[ok], cols[ok]] = 100
    return grid


def footprint_clearance(walls: FloatArray, fp: Footprint, pose: Pose2) -> float:
    """[m] distance from the footprint at ``pose`` to the nearest wall (sampled walls)."""
    if walls.shape[0] == 0:
        return math.inf
    pts = []
    for x0, y0, x1, y1 in walls:
        n = math.ceil(math.hypot(x1 - x0, y1 - y0) / 0.01) + 1
        t = np.linspace(0.0, 1.0, n)
        pts.append(np.column_stack([x0 + t * (x1 - x0), y0 + t * (y1 - y0)]))
    p = np.concatenate(pts) - np.array(pose[:2])
    c, s = math.cos(pose[2]), math.sin(pose[2])
    lx = np.abs(c * p[:, 0] + s * p[:, 1])
    ly = np.abs(-s * p[:, 0] + c * p[:, 1])
    if fp.kind == 0:
        return float(np.hypot(lx, ly).min() - fp.half_length_m)
    qx, qy = lx - fp.half_length_m, ly - fp.half_width_m
    d = np.hypot(np.maximum(qx, 0), np.maximum(qy, 0)) + np.minimum(np.maximum(qx, qy), 0)
    return float(d.min())


def drive(
    config: NavdConfig,
    walls: FloatArray,
    start: Pose2,
    goal: NavGoal,
    *,
    max_time_s: float = 60.0,
    known_map: bool = True,
    map_box: tuple[float, float, float, float] = (-6.0, -4.0, 6.0, 4.0),
    turning_radps: float = 0.0,
) -> Drive:
    """Drive from ``start`` to ``goal`` among ``walls``; the map shows them if ``known_map``.
    The robot is turning on the spot at ``turning_radps`` when the goal comes."""
    nav = Navigator(NavigatorSettings.from_config(config))
    res = 0.05
    if known_map:
        lo = (map_box[0], map_box[1])
        shape = (
            round((map_box[3] - map_box[1]) / res),
            round((map_box[2] - map_box[0]) / res),
        )
        nav.set_map(rasterize(walls, res, lo, shape), res, lo[0], lo[1])
    nav.set_goal(goal)
    fp = Footprint.of(config.robot)
    dt = 1.0 / config.planning.control_rate_hz
    pose = start
    result = Drive(GoalState.ACTIVE)
    t = 0.0
    while t < max_time_s:
        if walls.shape[0]:
            angle_min, increment, ranges = cast(pose, 360, walls)
        else:
            angle_min, increment, ranges = -math.pi, 2 * math.pi / 360, np.full(360, np.inf)
        pts = scan_points(ranges, angle_min - 0.0, increment, range_min=0.05, range_max=8.0)
        nav.add_scan(pose, pts.hits, pts.misses, t)
        reason = nav.plan_reason(t, pose)
        if reason is not None:
            result.plan_reasons.append(reason)
            try:
                nav.accept_plan(t, nav.plan(t, pose))
            except PlanningError as err:
                nav.plan_failed(t, err)
        step = nav.step(t, pose, (0.0, turning_radps) if t == 0.0 else None)
        result.steps.append(step)
        result.state = step.state
        if step.state is not GoalState.ACTIVE:
            break
        v, w = step.linear_mps, step.angular_radps
        x, y, yaw = pose
        if abs(w) < 1e-9:
            pose = Pose2(x + v * dt * math.cos(yaw), y + v * dt * math.sin(yaw), yaw)
        else:
            pose = Pose2(
                x + v / w * (math.sin(yaw + w * dt) - math.sin(yaw)),
                y - v / w * (math.cos(yaw + w * dt) - math.cos(yaw)),
                wrap_angle(yaw + w * dt),
            )
        result.poses.append(pose)
        result.commands.append((v, w))
        result.min_clearance_m = min(result.min_clearance_m, footprint_clearance(walls, fp, pose))
        t += dt
    result.time_s = t
    if result.poses:
        result.poses.append(pose)
    else:
        result.poses.append(start)
    return result

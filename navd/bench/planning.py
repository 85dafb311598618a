"""Planning benchmark: A* on large random grids and one DWA cycle with a rectangular robot.

A*: grids of 1000 x 1000 and 2000 x 2000 cells with random rectangles until 25 % of the cells
are occupied, start and goal in opposite corners (cleared), no inflation costs: the same
problem pyastar2d solves. Printed: ms per search (median of several), cells expanded (jump
points count as one; on the inflated grid, cells taken out of buckets, not those a pass along
floor went over) and the route cost against the straight-line distance. Then the 2000 x 2000
grid as the daemon plans on it: 5 cm cells, inflated with the default configuration and
searched with the default cost weight, cell by cell with the open list in buckets; building
that costmap from its obstacle cells, and its distance transform beside scipy.ndimage's exact
one (timed in turn, the time ratio); and a replan on it toward the same goal from a third of
the way along, which continues the route instead of searching while nothing changed that could
make the route wrong.

DWA: one control cycle as the navigator runs it (dynamic window of 20 x 21 = 420 rollouts of
2 s at 0.1 s steps, 0.4 x 0.3 m rectangle, 1440 scan points of a cluttered surrounding,
distance grid and buckets built inside the cycle). Printed: ms per cycle p50/p95.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import numpy.typing as npt

from navd.bench.timing import median_ms, paired_ms
from navd.config import NavdConfig
from navd.geometry import IDENTITY, Pose2
from navd.lifecycle import percentile
from navd.planning import (
    Costmap,
    GlobalPlanner,
    GridFrame,
    LocalPlanner,
    PlannedPath,
    SearchSettings,
    Window,
    build_costmap,
    costmap_settings,
    distance_to,
    dwa_settings,
    path_field,
    velocity_profile,
)

__all__ = ["random_rectangles", "run", "uniform_costmap"]


def random_rectangles(cells: int, fill: float, seed: int) -> npt.NDArray[np.bool_]:
    """A cells x cells grid with random rectangles (2 to cells/20 on a side) until ``fill``
    of it is occupied; the 20 x 20 corners stay free for the start and goal."""
    rng = np.random.default_rng(seed)
    occupied = np.zeros((cells, cells), dtype=np.bool_)
    side = max(cells // 20, 3)
    while occupied.mean() < fill:
        for _ in range(64):
            h, w = rng.integers(2, side, size=2)
            r, c = rng.integers(0, cells - h), rng.integers(0, cells - w)
            occupied[r : r + h, c : c + w] = True
    occupied[:20, :20] = False
    occupied[-20:, -20:] = False
    return occupied


def uniform_costmap(cells: int) -> Costmap:
    """A cells x cells costmap of 1 m cells: a quarter in random rectangles (impassable),
    the rest free at no cost, nothing unknown (the uniform-cost A* benchmarks)."""
    occupied = random_rectangles(cells, 0.25, seed=cells)
    cost = np.where(occupied, np.inf, 0.0).astype(np.float32)
    frame = GridFrame(1.0, 0.0, 0.0, cells, cells)
    no_clearance = np.zeros(cost.shape, np.float32)
    return Costmap(
        frame,
        obstacles=occupied,
        clearance_m=no_clearance,
        cost=cost,
        blocked=occupied,
        unknown=np.zeros_like(occupied),
        unknown_blocks=False,
    )


def _timed_plans(  # noqa: PLR0917 - one search's inputs, named in the docstring
    planner: GlobalPlanner,
    search: SearchSettings,
    costmap: Costmap,
    start: tuple[float, float],
    goal: tuple[float, float],
    repeats: int,
) -> tuple[float, PlannedPath]:
    """Median ms of ``repeats`` searches (after one that compiles and sizes the working
    arrays), and the route found."""
    path = planner.plan(costmap, start, goal, search)
    times = []
    for _ in range(repeats):
        planner.forget_last_route()  # a search every time (the replan figures time reuse)
        t0 = time.perf_counter()
        path = planner.plan(costmap, start, goal, search)
        times.append(time.perf_counter() - t0)
    return round(1e3 * percentile(times, 50), 2), path


def _astar(cells: int, repeats: int) -> dict[str, object]:
    costmap = uniform_costmap(cells)
    search = SearchSettings(cost_weight=0.0, smooth=False)
    start, goal = (5.5, 5.5), (cells - 5.5, cells - 5.5)
    ms, path = _timed_plans(GlobalPlanner(), search, costmap, start, goal, repeats)
    return {
        f"astar_{cells}_ms": ms,
        f"astar_{cells}_expanded": path.cells_expanded,
        f"astar_{cells}_cost_over_straight": round(path.cost / math.dist(start, goal), 4),
    }


def _astar_inflated(cells: int, repeats: int) -> dict[str, object]:
    """The same grid as the daemon plans on it: 5 cm cells (a 100 m square at 2000 cells),
    obstacles inflated with the default configuration, the default cost weight."""
    config = NavdConfig()
    occupied = random_rectangles(cells, 0.25, seed=cells)
    frame = GridFrame(0.05, 0.0, 0.0, cells, cells)
    settings = costmap_settings(config.planning, config.robot, config.safety)
    costmap = build_costmap(frame, occupied, np.zeros_like(occupied), settings)
    search = SearchSettings(cost_weight=config.planning.cost_weight, smooth=False)
    start, goal = (0.2, 0.2), (0.05 * cells - 0.2, 0.05 * cells - 0.2)
    ms, path = _timed_plans(GlobalPlanner(), search, costmap, start, goal, repeats)
    costly = np.isfinite(costmap.cost) & (costmap.cost > 0.0)
    nothing = np.zeros_like(occupied)
    return {
        f"costmap_{cells}_build_ms": round(
            median_ms(lambda: build_costmap(frame, occupied, nothing, settings), repeats), 2
        ),
        **_distance_transform(occupied, repeats),
        f"astar_{cells}_inflated_ms": ms,
        f"astar_{cells}_inflated_expanded": path.cells_expanded,
        f"astar_{cells}_inflated_costly_cells_pct": round(100.0 * float(costly.mean()), 1),
        **_replan(costmap, search, path, goal, repeats),
    }


def _distance_transform(occupied: npt.NDArray[np.bool_], repeats: int) -> dict[str, object]:
    """The costmap's clearance (navd's exact distance transform, most of a build) beside
    scipy.ndimage's exact one on the same cells, timed in turn."""
    from scipy import ndimage  # noqa: PLC0415 - the peer; the daemon does not load ndimage

    cells = occupied.shape[0]
    free = ~occupied
    ours, peer = paired_ms(
        lambda: distance_to(occupied), lambda: ndimage.distance_transform_edt(free), repeats
    )
    return {
        f"distance_transform_{cells}_navd_ms": round(ours, 2),
        f"distance_transform_{cells}_scipy_ms": round(peer, 2),
        f"distance_transform_{cells}_ratio": round(ours / peer, 3),
    }


def _replan(
    costmap: Costmap,
    search: SearchSettings,
    path: PlannedPath,
    goal: tuple[float, float],
    repeats: int,
) -> dict[str, object]:
    """Replanning toward the same goal from a third of the way along the route, as the
    replan timer asks while the robot drives: on a costmap rebuilt with the same cells (the
    daemon builds one for every plan), and with a cell far off the route cleared."""
    cells = costmap.frame.rows
    along = path.points_m[path.points_m.shape[0] // 3]
    robot = (float(along[0]), float(along[1]))
    planner = GlobalPlanner()
    planner.plan(costmap, tuple(path.points_m[0]), goal, search)
    figures: dict[str, object] = {}
    far = costmap.cost.copy()
    corner = far[cells - 40 : cells - 5, 5:40]  # the corner the route goes nowhere near
    corner[corner > 0.0] = 0.0  # cheaper (an obstacle gone), yet too far to shorten it
    for name, cost in (("same", costmap.cost.copy()), ("far_change", far)):
        rebuilt = dataclasses.replace(costmap, cost=cost)
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            replanned = planner.plan(rebuilt, robot, goal, search)
            times.append(time.perf_counter() - t0)
        figures[f"replan_{cells}_inflated_{name}_ms"] = round(1e3 * percentile(times, 50), 2)
        figures[f"replan_{cells}_inflated_{name}_reused"] = replanned.reused
    return figures


def _dwa(cycles: int) -> dict[str, object]:
    config = NavdConfig.model_validate({"robot": {"footprint": "rectangle"}})
    profile = velocity_profile(config.planning, config.robot)
    dwa = dwa_settings(config.planning, config.robot, config.safety)
    local = LocalPlanner(dwa, profile.yaw_rate_table)
    rng = np.random.default_rng(7)
    path = path_field(np.array([[0.0, 0.0], [6.0, 0.0]]))
    times = []
    rollouts = valid = 0
    for i in range(cycles + 5):
        # 1440 beams in a cluttered place: ranges from 0.6 to 4 m, in patches like furniture.
        angles = np.linspace(-math.pi, math.pi, 1440, endpoint=False)
        base = 0.6 + 3.4 * rng.random(24)
        ranges = np.repeat(base, 60) + rng.normal(0.0, 0.01, 1440)
        points = np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])
        t0 = time.perf_counter()
        choice = local.choose(IDENTITY, (0.3, 0.1), points, path, Pose2(1.0, 0.0, 0.0), Window(0.5))
        if i >= 5:  # the first cycles compile or load the kernels
            times.append(time.perf_counter() - t0)
            if choice is not None:
                rollouts, valid = choice.rollouts, choice.valid
    ms = sorted(1e3 * t for t in times)
    return {
        "dwa_rollouts": rollouts,
        "dwa_valid_rollouts_last": valid,
        "dwa_steps_per_rollout": local.steps,
        "dwa_scan_points": 1440,
        "dwa_ms_p50": round(percentile(ms, 50), 3),
        "dwa_ms_p95": round(percentile(ms, 95), 3),
    }


def run(repeats: int = 5, cycles: int = 200) -> dict[str, object]:
    """A* on 1000² and 2000² grids (median of ``repeats``), DWA over ``cycles`` cycles."""
    figures: dict[str, object] = {}
    figures.update(_astar(1000, repeats))
    figures.update(_astar(2000, repeats))
    figures.update(_astar_inflated(2000, repeats))
    figures.update(_dwa(cycles))
    return figures

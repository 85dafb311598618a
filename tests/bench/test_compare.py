"""The side-by-side benchmark prices both planners' routes in one metric; navd's search is
exact in it, so no other route, pyastar2d's included, may cost less."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from navd.bench.compare import _route_cost_m
from navd.config import NavdConfig
from navd.planning import (
    Costmap,
    GlobalPlanner,
    GridFrame,
    SearchSettings,
    build_costmap,
    costmap_settings,
)


def _costmap(cells: int, seed: int) -> Costmap:
    # A dozen boxes of 0.25 to 1.25 m in an open room: routes weave between inflated bands.
    rng = np.random.default_rng(seed)
    occupied = np.zeros((cells, cells), dtype=np.bool_)
    for _ in range(12):
        h, w = rng.integers(5, 25, size=2)
        r, c = rng.integers(15, cells - 40, size=2)
        occupied[r : r + h, c : c + w] = True
    frame = GridFrame(0.05, 0.0, 0.0, cells, cells)
    settings = costmap_settings(NavdConfig().planning, NavdConfig().robot, NavdConfig().safety)
    return build_costmap(frame, occupied, np.zeros_like(occupied), settings)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_route_priced_by_the_benchmark_costs_what_the_planner_says(seed: int) -> None:
    costmap = _costmap(120, seed)
    weight = NavdConfig().planning.cost_weight
    route = GlobalPlanner().plan(
        costmap, (0.2, 0.2), (5.8, 5.8), SearchSettings(cost_weight=weight, smooth=False)
    )
    cells = np.array([costmap.frame.cell_of(x, y) for x, y in route.points_m])
    assert _route_cost_m(costmap, cells, weight) == pytest.approx(route.cost, rel=1e-6)


@pytest.mark.skipif(
    importlib.util.find_spec("pyastar2d") is None, reason="pyastar2d (a dev dependency) missing"
)
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_no_pyastar2d_route_is_cheaper_than_navds_in_navds_metric(seed: int) -> None:
    import pyastar2d

    costmap = _costmap(150, seed)
    weight = NavdConfig().planning.cost_weight
    frame = costmap.frame
    start, goal = (4, 4), (145, 145)
    start_m, goal_m = frame.centers_of(np.array([start, goal]))
    route = GlobalPlanner().plan(
        costmap,
        tuple(start_m),
        tuple(goal_m),
        SearchSettings(cost_weight=weight, smooth=False),
    )
    weights = np.where(np.isfinite(costmap.cost), 1.0 + weight * costmap.cost, np.inf)
    path = pyastar2d.astar_path(weights.astype(np.float32), start, goal, allow_diagonal=True)
    assert path is not None
    assert _route_cost_m(costmap, path, weight) >= route.cost - 1e-9

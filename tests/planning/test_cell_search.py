"""Replanning toward the same goal reads the route off the last search while nothing makes it
wrong, and searches afresh when something does."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.planning._bucket_kernels import BUCKETS_PER_CELL
from navd.planning.costmap import Costmap, CostmapSettings, GridFrame, build_costmap
from navd.planning.global_planner import GlobalPlanner, PlannedPath, SearchSettings

FRAME = GridFrame(0.05, 0.0, 0.0, 120, 160)
SEARCH = SearchSettings(cost_weight=3.0, smooth=False)
GOAL = (7.5, 5.0)


def _costmap(walls: list[tuple[slice, slice]]) -> Costmap:
    obstacles = np.zeros(FRAME.shape, dtype=np.bool_)
    for rows, cols in walls:
        obstacles[rows, cols] = True
    settings = CostmapSettings.from_config(NavdConfig())
    return build_costmap(FRAME, obstacles, np.zeros_like(obstacles), settings)


ROOM = [(slice(20, 100), slice(60, 64)), (slice(0, 50), slice(110, 114))]


def _fresh(costmap: Costmap, start: tuple[float, float]) -> PlannedPath:
    return GlobalPlanner().plan(costmap, start, GOAL, SEARCH)


def _along(path: PlannedPath, share: float) -> tuple[float, float]:
    x, y = path.points_m[int(len(path.points_m) * share)]
    return (float(x), float(y))


def _within_bound(got: PlannedPath, fresh: PlannedPath) -> bool:
    """Both routes lie in [C, (1 + d) C + d] (C the optimum, d a bucket's width), so each is
    within that bound of the other."""
    slip, cell = 1.0 / BUCKETS_PER_CELL, 0.05
    low = (fresh.cost - slip * cell) / (1 + slip)
    return bool(low * (1 - 1e-9) <= got.cost <= fresh.cost * (1 + slip) + slip * cell)


def test_a_replan_on_the_same_grid_is_read_off_the_last_search() -> None:
    costmap = _costmap(ROOM)
    planner = GlobalPlanner()
    first = planner.plan(costmap, (0.5, 0.5), GOAL, SEARCH)
    assert not first.reused and first.cells_expanded > 0
    for share in (0.2, 0.5, 0.8):
        here = _along(first, share)
        again = planner.plan(costmap, here, GOAL, SEARCH)
        assert again.reused and again.cells_expanded == 0
        assert _within_bound(again, _fresh(costmap, here))
        # The same way on from here: every point of the replan lies on the first route.
        on_route = {tuple(np.round(p, 6)) for p in first.points_m[1:-1]}
        assert all(tuple(np.round(p, 6)) in on_route for p in again.points_m[1:-1])


def test_a_rebuilt_grid_with_costs_risen_off_the_route_is_still_read_off() -> None:
    planner = GlobalPlanner()
    first = planner.plan(_costmap(ROOM), (0.5, 0.5), GOAL, SEARCH)
    # A box far from the route, in a rebuilt costmap (a new array with the same values
    # elsewhere): costs only rose, and not where the robot goes.
    away = _costmap([*ROOM, (slice(100, 115), slice(5, 20))])
    touched = away.cost[
        np.round(first.points_m[:, 1] / 0.05 - 0.5).astype(int),
        np.round(first.points_m[:, 0] / 0.05 - 0.5).astype(int),
    ]
    assert np.isfinite(touched).all()
    here = _along(first, 0.3)
    again = planner.plan(away, here, GOAL, SEARCH)
    assert again.reused
    assert _within_bound(again, _fresh(away, here))


def test_an_obstacle_on_the_route_makes_a_new_search_around_it() -> None:
    planner = GlobalPlanner()
    first = planner.plan(_costmap(ROOM), (0.5, 0.5), GOAL, SEARCH)
    x, y = _along(first, 0.6)
    row, col = int(y / 0.05), int(x / 0.05)
    blocked = _costmap([*ROOM, (slice(row - 3, row + 4), slice(col - 3, col + 4))])
    here = _along(first, 0.3)
    again = planner.plan(blocked, here, GOAL, SEARCH)
    assert not again.reused and again.cells_expanded > 0
    assert _within_bound(again, _fresh(blocked, here))


def test_a_cheaper_grid_makes_a_new_search() -> None:
    planner = GlobalPlanner()
    first = planner.plan(_costmap(ROOM), (0.5, 0.5), GOAL, SEARCH)
    opened = _costmap(ROOM[1:])  # the first wall is gone: a shorter way may exist
    here = _along(first, 0.1)
    again = planner.plan(opened, here, GOAL, SEARCH)
    assert not again.reused
    assert _within_bound(again, _fresh(opened, here))


def test_a_cell_blocked_beside_a_diagonal_step_makes_a_new_search() -> None:
    # Cost 0.5 everywhere (a weighted grid), corner to corner: the route is all diagonal.
    # Blocking one cell beside its first diagonal step leaves the route's own cells as they
    # were, but the step is no longer allowed (no squeezing past a blocked cell).
    frame = GridFrame(0.05, 0.0, 0.0, 10, 10)
    cost = np.full((10, 10), 0.5, dtype=np.float32)
    free = np.zeros((10, 10), dtype=np.bool_)
    clearance = np.full((10, 10), 1.0, dtype=np.float32)
    planner = GlobalPlanner()
    start, goal = (0.025, 0.025), (0.475, 0.475)
    first = planner.plan(Costmap(frame, free, clearance, cost, free), start, goal, SEARCH)
    cells = np.floor(first.points_m[:, ::-1] / 0.05).astype(int)
    step = cells[1] - cells[0]
    assert np.all(step != 0), "the first step should be diagonal"
    side = (cells[0][0], cells[1][1])
    blocked_cost = cost.copy()
    blocked_cost[side] = np.inf
    blocked = Costmap(frame, free, clearance, blocked_cost, free)
    again = planner.plan(blocked, start, goal, SEARCH)
    assert not again.reused
    route = np.floor(again.points_m[:, ::-1] / 0.05).astype(int)
    for a, b in itertools.pairwise(route):
        if np.all(b != a):  # a diagonal: both cells beside it free
            assert np.isfinite(blocked_cost[a[0], b[1]]) and np.isfinite(blocked_cost[b[0], a[1]])


@pytest.mark.parametrize("change", ["goal", "weight", "far start", "forgotten"])
def test_anything_else_new_makes_a_new_search(change: str) -> None:
    costmap = _costmap(ROOM)
    planner = GlobalPlanner()
    first = planner.plan(costmap, (0.5, 0.5), GOAL, SEARCH)
    start, goal, search = _along(first, 0.5), GOAL, SEARCH
    if change == "goal":
        goal = (7.0, 5.5)
    elif change == "weight":
        search = SearchSettings(cost_weight=5.0, smooth=False)
    elif change == "far start":
        start = (7.8, 0.3)  # beyond the second wall, off everything the search closed
    else:
        planner.forget_last_search()
    again = planner.plan(costmap, start, goal, search)
    assert not again.reused and again.cells_expanded > 0

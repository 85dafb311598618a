"""Replanning toward the same goal: the rest of the last route while it is still the best,
a search whenever a change could make it wrong (checked against scipy's Dijkstra)."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest

from navd.planning._astar_kernels import segment_max_cost
from navd.planning._bucket_kernels import BUCKETS_PER_CELL
from navd.planning.costmap import Costmap
from navd.planning.errors import PlanningError
from navd.planning.global_planner import (
    REUSE_OFFSET_M,
    GlobalPlanner,
    PlannedPath,
    SearchSettings,
)
from navd.planning.route_reuse import route_costs
from tests.planning.test_global_planner import RES, costmap_of, dijkstra_cost

D = 1.0 / BUCKETS_PER_CELL  # the bucket search's bound: (1 + D) * C + D


def center(cell: tuple[int, int]) -> tuple[float, float]:
    return ((cell[1] + 0.5) * RES, (cell[0] + 0.5) * RES)


def rebuilt(costmap: Costmap, cost: np.ndarray) -> Costmap:
    """The costmap built anew, as the daemon does for every plan (never changed in place)."""
    return dataclasses.replace(costmap, cost=cost.astype(np.float32))


def room() -> np.ndarray:
    """40 x 60 cells: a wall across the middle with a gap near its top end, an inflated band
    of cost along it."""
    cost = np.zeros((40, 60), np.float32)
    cost[:34, 29:31] = np.inf
    cost[:34, 27:29] = 0.5
    cost[:34, 31:33] = 0.5
    return cost


START, GOAL = (2, 2), (2, 57)
SEARCH = SearchSettings(cost_weight=2.0, smooth=True)


def planned() -> tuple[GlobalPlanner, Costmap, np.ndarray]:
    costmap = costmap_of(room())
    planner = GlobalPlanner()
    first = planner.plan(costmap, center(START), center(GOAL), SEARCH)
    assert not first.reused and first.cells_expanded > 0
    return planner, costmap, first.points_m


def along(points: np.ndarray, fraction: float) -> tuple[float, float]:
    """The point ``fraction`` of the way along a polyline [m]."""
    steps = np.hypot(*np.diff(points, axis=0).T)
    target = fraction * steps.sum()
    i = int(np.searchsorted(np.cumsum(steps), target))
    before = float(np.cumsum(steps)[i - 1]) if i else 0.0
    t = (target - before) / steps[i]
    p = points[i] + t * (points[i + 1] - points[i])
    return (float(p[0]), float(p[1]))


def test_an_unchanged_grid_continues_the_route_from_the_robot() -> None:
    planner, costmap, first = planned()
    robot = along(first, 0.4)
    again = planner.plan(rebuilt(costmap, room()), robot, center(GOAL), SEARCH)
    assert again.reused and again.cells_expanded == 0
    assert again.points_m[0] == pytest.approx(robot)
    assert again.points_m[-1] == pytest.approx(center(GOAL))
    # Every later point is one of the first route's, in order.
    tail = first[-(again.points_m.shape[0] - 1) :]
    assert np.allclose(again.points_m[1:], tail)
    fresh = GlobalPlanner().plan(rebuilt(costmap, room()), robot, center(GOAL), SEARCH)
    assert fresh.cells_expanded > 0
    assert again.cost == pytest.approx(fresh.cost, rel=0.05)


def test_an_obstacle_on_the_rest_of_the_route_means_a_new_search() -> None:
    planner, costmap, first = planned()
    robot = along(first, 0.2)
    cost = room()
    ahead = costmap.frame.cell_of(*along(first, 0.7))
    cost[ahead[0] - 1 : ahead[0] + 2, ahead[1] - 1 : ahead[1] + 2] = np.inf
    again = planner.plan(rebuilt(costmap, cost), robot, center(GOAL), SEARCH)
    assert not again.reused and again.cells_expanded > 0
    cells = costmap.frame.cells_of(again.points_m)
    assert np.all(np.isfinite(cost[cells[:, 0], cells[:, 1]]))


def test_a_shortcut_opening_means_a_new_search_that_takes_it() -> None:
    planner, costmap, first = planned()
    robot = along(first, 0.05)
    cost = room()
    cost[2:6, 27:33] = 0.0  # a door opens in the wall near the robot
    again = planner.plan(rebuilt(costmap, cost), robot, center(GOAL), SEARCH)
    assert not again.reused
    length = float(np.hypot(*np.diff(again.points_m, axis=0).T).sum())
    assert length < 0.7 * float(np.hypot(*np.diff(first, axis=0).T).sum())


def test_a_cheaper_cell_too_far_to_help_keeps_the_route() -> None:
    planner, costmap, first = planned()
    robot = along(first, 0.5)
    cost = room()
    cost[0:2, 27:29] = 0.0  # cheaper, at the far end of the wall from the gap: no route gains
    again = planner.plan(rebuilt(costmap, cost), robot, center(GOAL), SEARCH)
    assert again.reused


@pytest.mark.parametrize(
    ("robot_offset_m", "goal"),
    [(REUSE_OFFSET_M + 0.1, GOAL), (0.0, (8, 57))],
    ids=["robot far off the route", "another goal"],
)
def test_off_the_route_or_another_goal_means_a_new_search(
    robot_offset_m: float, goal: tuple[int, int]
) -> None:
    planner, costmap, first = planned()
    x, y = along(first, 0.3)
    again = planner.plan(rebuilt(costmap, room()), (x, y - robot_offset_m), center(goal), SEARCH)
    assert not again.reused and again.cells_expanded > 0


def planned_on_random_grid(
    rng: np.random.Generator, side: int, costs: list[float], search: SearchSettings
) -> tuple[GlobalPlanner, np.ndarray, PlannedPath] | None:
    """A side x side grid of cells drawn from ``costs`` (corners free), and a planner that
    has just planned corner to corner on it; None when no route crosses it."""
    cost = rng.choice(costs, size=(side, side)).astype(np.float32)
    start, goal = (0, 0), (side - 1, side - 1)
    cost[start], cost[goal] = 0.0, 0.0
    planner = GlobalPlanner()
    try:
        first = planner.plan(costmap_of(cost), center(start), center(goal), search)
    except PlanningError:
        return None
    return planner, cost, first


def test_a_reused_route_is_as_good_as_dijkstra_finds_after_random_changes() -> None:
    """Seeded random grids; after each plan some cells get costlier and some cheaper, the
    robot stands on a cell of the route, and whenever the route is reused it must cost what
    it says on the new grid and be within the search's bound of the cheapest route there."""
    rng = np.random.default_rng(2024)
    search = SearchSettings(cost_weight=3.0, smooth=False)
    reused = fresh = 0
    for _ in range(100):
        planned = planned_on_random_grid(rng, 24, [0.0, 0.0, 0.0, 0.3, 0.8, np.inf], search)
        if planned is None:  # no route on this grid: draw another
            continue
        planner, cost, first = planned
        start, goal = (0, 0), (23, 23)
        changed = cost.copy()
        for _ in range(int(rng.integers(0, 12))):
            r, c = rng.integers(0, 24, size=2)
            changed[r, c] = rng.choice([np.inf, 0.9, 0.0])
        changed[start], changed[goal] = 0.0, 0.0
        cells = costmap_of(cost).frame.cells_of(first.points_m)
        at = tuple(int(v) for v in cells[int(rng.integers(0, cells.shape[0] - 1))])
        if not math.isfinite(changed[at]):
            continue
        try:
            again = planner.plan(costmap_of(changed), center(at), center(goal), search)
        except PlanningError:  # the change cut every route: a search said so
            fresh += 1
            continue
        if not again.reused:
            fresh += 1
            continue
        reused += 1
        route = costmap_of(changed).frame.cells_of(again.points_m)
        assert np.all(np.isfinite(changed[route[:, 0], route[:, 1]]))
        diagonal = np.flatnonzero(np.all(np.diff(route, axis=0) != 0, axis=1))
        a, b = route[diagonal], route[diagonal + 1]
        assert np.all(np.isfinite(changed[a[:, 0], b[:, 1]]))  # no corner cut
        assert np.all(np.isfinite(changed[b[:, 0], a[:, 1]]))
        real = float(route_costs(changed, route, search.cost_weight)[0])
        assert again.cost / RES == pytest.approx(real, abs=1e-6)
        best = dijkstra_cost(changed, at, goal, search.cost_weight)
        assert best <= real + 1e-6
        assert real <= (1.0 + D) * best + D + 1e-6
    assert reused >= 20 and fresh >= 20, (reused, fresh)  # both ways were tried


def test_a_reused_smoothed_route_never_crosses_a_blocked_cell() -> None:
    """Smoothing on, the robot anywhere within the reuse offset of the route: whenever the
    route is reused after random blockings, every segment of it, the step from the robot
    included, is free on the new grid as the smoothing walks segments (corners included)."""
    rng = np.random.default_rng(7)
    search = SearchSettings(cost_weight=3.0, smooth=True)
    reused = fresh = 0
    for _ in range(150):
        planned = planned_on_random_grid(rng, 30, [0.0, 0.0, 0.0, 0.0, 0.5, np.inf], search)
        if planned is None:
            continue
        planner, cost, first = planned
        start, goal = (0, 0), (29, 29)
        changed = cost.copy()
        for _ in range(int(rng.integers(1, 25))):
            r, c = rng.integers(0, 30, size=2)
            changed[r, c] = np.inf
        changed[start], changed[goal] = 0.0, 0.0
        x, y = along(first.points_m, float(rng.uniform(0.0, 0.9)))
        heading = rng.uniform(0.0, 2.0 * np.pi)
        offset = float(rng.uniform(0.0, REUSE_OFFSET_M))
        robot = (x + offset * np.cos(heading), y + offset * np.sin(heading))
        try:
            again = planner.plan(costmap_of(changed), robot, center(goal), search)
        except PlanningError:
            fresh += 1
            continue
        if not again.reused:
            fresh += 1
            continue
        reused += 1
        cells = costmap_of(changed).frame.cells_of(again.points_m)
        for a, b in itertools.pairwise(cells):
            assert np.isfinite(segment_max_cost(changed, a[0], a[1], b[0], b[1]))
    assert reused >= 10 and fresh >= 10, (reused, fresh)


def route_costs_reference(cost: np.ndarray, cells: np.ndarray, w: float) -> np.ndarray:
    """The costs to the goal in NumPy, step by step as the kernel should add them."""
    if cells.shape[0] < 2:
        return np.zeros(cells.shape[0])
    steps = np.diff(cells, axis=0)
    lengths = np.where(np.all(steps != 0, axis=1), math.sqrt(2.0), 1.0)
    c = cost[cells[:, 0], cells[:, 1]].astype(np.float64)
    step_costs = lengths * (1.0 + w * 0.5 * (c[:-1] + c[1:]))
    return np.concatenate([np.cumsum(step_costs[::-1])[::-1], [0.0]])


@pytest.mark.parametrize("cells", [0, 1, 2, 3, 200])
@pytest.mark.parametrize("w", [0.0, 3.0])
def test_route_costs_match_numpy_step_by_step(cells: int, w: float) -> None:
    rng = np.random.default_rng(cells)
    cost = rng.random((40, 40)).astype(np.float32)
    steps = rng.integers(-1, 2, size=(max(cells - 1, 0), 2))
    steps[np.all(steps == 0, axis=1)] = (1, 1)  # every step moves, some of them diagonally
    route = (np.vstack([[[20, 20]], 20 + np.cumsum(steps, axis=0)])[:cells]) % 40
    np.testing.assert_allclose(
        route_costs(cost, route, w), route_costs_reference(cost, route, w), rtol=1e-12
    )

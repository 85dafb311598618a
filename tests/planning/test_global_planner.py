"""A* against scipy's Dijkstra on random grids, and its documented errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import dijkstra

from navd.planning._bucket_kernels import BUCKETS_PER_CELL, bucket_astar
from navd.planning.costmap import Costmap, CostmapSettings, GridFrame, build_costmap
from navd.planning.errors import GoalUnreachableError, StartBlockedError
from navd.planning.global_planner import GlobalPlanner, SearchSettings

RES = 0.1


def step_graph(cost: np.ndarray, w: float) -> csr_matrix:
    """The 8-connected graph A* searches, built independently: a step of length L between
    free cells costs L * (1 + w * mean of their costs), a diagonal only past two free cells."""
    rows, cols = cost.shape
    free = np.isfinite(cost)
    c = np.where(free, cost, 0.0).astype(np.float64)
    index = np.arange(rows * cols).reshape(rows, cols)
    src, dst, weight = [], [], []
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == dc == 0:
                continue
            rs, cs = slice(max(0, -dr), rows - max(0, dr)), slice(max(0, -dc), cols - max(0, dc))
            rn = slice(rs.start + dr, rs.stop + dr)
            cn = slice(cs.start + dc, cs.stop + dc)
            ok = free[rs, cs] & free[rn, cn]
            if dr and dc:
                ok &= free[rs, cn] & free[rn, cs]
            src.append(index[rs, cs][ok])
            dst.append(index[rn, cn][ok])
            mean = 0.5 * (c[rs, cs][ok] + c[rn, cn][ok])
            weight.append(math.hypot(dr, dc) * (1.0 + w * mean))
    shape = (rows * cols, rows * cols)
    edges = (np.concatenate(weight), (np.concatenate(src), np.concatenate(dst)))
    return coo_matrix(edges, shape=shape).tocsr()


def dijkstra_cost(
    cost: np.ndarray, start: tuple[int, int], goal: tuple[int, int], w: float
) -> float:
    """The route cost [cells] by scipy's Dijkstra on the same graph, built independently."""
    cols = cost.shape[1]
    d = dijkstra(step_graph(cost, w), indices=start[0] * cols + start[1])
    return float(d[goal[0] * cols + goal[1]])


def costmap_of(cost: np.ndarray) -> Costmap:
    rows, cols = cost.shape
    frame = GridFrame(RES, 0.0, 0.0, rows, cols)
    blocked = ~np.isfinite(cost)
    return Costmap(
        frame,
        obstacles=blocked,
        clearance_m=np.zeros(cost.shape, np.float32),
        cost=cost.astype(np.float32),
        blocked=blocked,
        unknown=np.zeros(cost.shape, bool),
        unknown_blocks=False,
    )


def center(cell: tuple[int, int]) -> tuple[float, float]:
    return ((cell[1] + 0.5) * RES, (cell[0] + 0.5) * RES)


@st.composite
def grids(draw: st.DrawFn) -> tuple[np.ndarray, tuple[int, int], tuple[int, int], float]:
    rows = draw(st.integers(2, 14))
    cols = draw(st.integers(2, 14))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    cost = rng.random((rows, cols)).astype(np.float32)
    cost[rng.random((rows, cols)) < draw(st.floats(0.0, 0.45))] = np.inf
    start = (draw(st.integers(0, rows - 1)), draw(st.integers(0, cols - 1)))
    goal = (draw(st.integers(0, rows - 1)), draw(st.integers(0, cols - 1)))
    cost[start] = cost[start] if np.isfinite(cost[start]) else 0.0
    cost[goal] = cost[goal] if np.isfinite(cost[goal]) else 0.0
    return cost, start, goal, draw(st.sampled_from([0.0, 1.0, 5.0]))


def assert_route_matches_dijkstra(case) -> None:
    """The planner's route on ``case`` costs what Dijkstra's does (within the bucket
    search's bound where cells have costs) and is a chain of allowed
    steps from the start to the goal, or the planner says "no route" where Dijkstra finds none."""
    cost, start, goal, w = case
    expected = dijkstra_cost(cost, start, goal, w)
    planner, search = GlobalPlanner(), SearchSettings(cost_weight=w, smooth=False)
    if math.isinf(expected):
        with pytest.raises(GoalUnreachableError, match="no route") as info:
            planner.plan(costmap_of(cost), center(start), center(goal), search)
        assert info.value.reason == "no route"
        return
    path = planner.plan(costmap_of(cost), center(start), center(goal), search)
    if w == 0.0:  # jump point search: exact
        assert path.cost / RES == pytest.approx(expected, rel=1e-7, abs=1e-9)
    else:  # the bucket search: within its documented bound, never below the optimum
        slip = 1.0 / BUCKETS_PER_CELL
        assert expected - 1e-4 <= path.cost / RES <= (1 + slip) * expected + slip + 1e-4
    cells = np.floor(path.points_m[:, ::-1] / RES).astype(int)
    assert np.isfinite(cost[cells[:, 0], cells[:, 1]]).all()
    steps = np.diff(cells, axis=0)
    assert (np.abs(steps) <= 1).all() and (np.abs(steps).sum(axis=1) > 0).all()
    # Every diagonal step has both side cells free (no squeezing past a corner).
    for (r, c), (dr, dc) in zip(cells[:-1], steps, strict=False):
        if dr and dc:
            assert np.isfinite(cost[r + dr, c]) and np.isfinite(cost[r, c + dc])
    assert tuple(cells[0]) == start and tuple(cells[-1]) == goal


@settings(max_examples=300, deadline=None)
@given(grids())
def test_astar_cost_equals_dijkstra_and_never_crosses_a_blocked_cell(case) -> None:
    assert_route_matches_dijkstra(case)


@pytest.mark.parametrize(("w", "scale"), [(3.0, 1.0), (100.0, 1.0), (3.0, 40.0)])
@pytest.mark.parametrize("seed", range(6))
def test_the_bucket_search_stays_within_its_bound_of_dijkstra_on_larger_grids(
    seed: int, w: float, scale: float
) -> None:
    # 90 x 90 cells of random costs, a fifth blocked: routes of a hundred steps and more,
    # where slips within a bucket could add up. w = 100 is the largest weight config allows;
    # costs up to 40 (the costmap's stop at 1) make the search widen its ring of buckets.
    rng = np.random.default_rng(seed)
    cost = (scale * rng.random((90, 90))).astype(np.float32)
    cost[rng.random((90, 90)) < 0.2] = np.inf
    cost[0, 0] = cost[89, 89] = 0.0
    expected = dijkstra_cost(cost, (0, 0), (89, 89), w)
    assert math.isfinite(expected), f"seed {seed} walls the goal off: pick another"
    search = SearchSettings(cost_weight=w, smooth=False)
    path = GlobalPlanner().plan(costmap_of(cost), center((0, 0)), center((89, 89)), search)
    slip = 1.0 / BUCKETS_PER_CELL
    assert expected * (1 - 1e-6) <= path.cost / RES <= (1 + slip) * expected + slip


def test_a_goal_cell_costlier_than_the_ring_was_sized_for_keeps_the_bound() -> None:
    # The search starts from the goal: a goal cell above the costmap's 0..1 scale must widen
    # the ring of buckets like any costly cell, or its first steps would wrap around it.
    rng = np.random.default_rng(7)
    cost = rng.random((60, 60)).astype(np.float32)
    cost[0, 0] = 0.0
    cost[59, 59] = 40.0
    expected = dijkstra_cost(cost, (0, 0), (59, 59), 3.0)
    search = SearchSettings(cost_weight=3.0, smooth=False)
    path = GlobalPlanner().plan(costmap_of(cost), center((0, 0)), center((59, 59)), search)
    slip = 1.0 / BUCKETS_PER_CELL
    assert expected * (1 - 1e-6) <= path.cost / RES <= (1 + slip) * expected + slip


@st.composite
def floor_plans(draw: st.DrawFn) -> tuple[np.ndarray, tuple[int, int], tuple[int, int], float]:
    """Floor of cost 0 with blocked rectangles, some with a costly band around them: a uniform
    grid (no band, or w = 0) is searched by jumping, the others cell by cell."""
    rows = draw(st.integers(3, 40))
    cols = draw(st.integers(3, 40))
    rng = np.random.default_rng(draw(st.integers(0, 2**31 - 1)))
    cost = np.zeros((rows, cols), np.float32)
    for _ in range(draw(st.integers(0, 12))):
        r, c = rng.integers(0, rows), rng.integers(0, cols)
        h, w = rng.integers(1, max(rows // 3, 2) + 1), rng.integers(1, max(cols // 3, 2) + 1)
        if rng.random() < 0.4:  # a costly band, as inflation leaves around walls
            band = cost[max(r - 1, 0) : r + h + 1, max(c - 1, 0) : c + w + 1]
            band[np.isfinite(band)] = rng.random() + 0.1
        cost[r : r + h, c : c + w] = np.inf
    # Some floor reads -0.0 (a costmap computed by subtraction can leave it): still floor.
    cost[(cost == 0.0) & (rng.random((rows, cols)) < 0.1)] = -0.0
    free = np.argwhere(np.isfinite(cost))
    if free.shape[0] == 0:
        cost[0, 0] = 0.0
        free = np.argwhere(np.isfinite(cost))
    start = tuple(int(v) for v in free[draw(st.integers(0, free.shape[0] - 1))])
    goal = tuple(int(v) for v in free[draw(st.integers(0, free.shape[0] - 1))])
    return cost, start, goal, draw(st.sampled_from([0.0, 1.0, 5.0]))


@settings(max_examples=400, deadline=None)
@given(floor_plans())
def test_astar_on_floor_plans_keeps_dijkstras_cost_jumping_or_not(case) -> None:
    assert_route_matches_dijkstra(case)


def test_floor_that_reads_minus_zero_is_searched_as_floor() -> None:
    # The bucket search tells open floor by the costs' bit patterns (+0.0 is all zeros);
    # -0.0 is floor too: the same grid with it gives the same route and the same work.
    rng = np.random.default_rng(7)
    cost = np.zeros((60, 60), np.float32)
    cost[rng.random((60, 60)) < 0.05] = np.inf
    cost[20:24, 10:50] = 0.5  # a costly band, so the grid is searched cell by cell
    cost[0, 0] = cost[59, 59] = 0.0
    signed = cost.copy()
    signed[(cost == 0.0) & (rng.random((60, 60)) < 0.5)] = -0.0
    search = SearchSettings(cost_weight=2.0, smooth=False)
    plain = GlobalPlanner().plan(costmap_of(cost), center((0, 0)), center((59, 59)), search)
    minus = GlobalPlanner().plan(costmap_of(signed), center((0, 0)), center((59, 59)), search)
    assert minus.cost == plain.cost
    assert minus.cells_expanded == plain.cells_expanded
    np.testing.assert_array_equal(minus.points_m, plain.points_m)


@pytest.mark.parametrize("seed", range(12))
def test_passes_along_wide_floor_keep_dijkstras_cost_and_the_rings_room(seed: int) -> None:
    # 200 x 200 cells of inflated rooms (the daemon's costmap, w = 3), ten routes each: rays
    # of floor run away from the goal for tens of cells, past the room the ring of buckets
    # keeps for a pass, so passes must stop short and leave their last cell in a bucket.
    # (With no such stop, 6 of these 12 rooms had a route dearer than Dijkstra's.)
    rng = np.random.default_rng(seed)
    obstacles = np.zeros((200, 200), bool)
    for _ in range(rng.integers(3, 25)):
        r, c = rng.integers(0, 195, 2)
        obstacles[r : r + rng.integers(1, 30), c : c + rng.integers(1, 30)] = True
    frame = GridFrame(RES, 0.0, 0.0, 200, 200)
    settings_ = CostmapSettings(0.1, 0.4, 3.0, True, 0.5, 65)
    costmap = build_costmap(frame, obstacles, np.zeros_like(obstacles), settings_)
    free = np.argwhere(np.isfinite(costmap.cost))
    graph = step_graph(costmap.cost, 3.0)
    search = SearchSettings(cost_weight=3.0, smooth=False)
    slip = 1.0 / BUCKETS_PER_CELL
    for _ in range(10):
        start = tuple(int(v) for v in free[rng.integers(len(free))])
        goal = tuple(int(v) for v in free[rng.integers(len(free))])
        costs = dijkstra(graph, indices=start[0] * 200 + start[1])
        expected = float(costs[goal[0] * 200 + goal[1]])
        if math.isinf(expected):
            continue
        path = GlobalPlanner().plan(costmap, center(start), center(goal), search)
        assert expected * (1 - 1e-6) <= path.cost / RES <= (1 + slip) * expected + slip


@pytest.mark.parametrize("buckets_per_cell", [10.0, 10.9, 1.9, 0.75])
def test_passes_keep_the_bound_at_any_bucket_width(buckets_per_cell: float) -> None:
    # The kernel on its own with a bucket width that is not a whole fraction of a cell: a
    # pass must count a step's growth of the key in whole buckets rounded up, or its last
    # cell's key wraps around the ring (the route came out at 60.7 against an optimum of
    # 14.4 with 10.9 buckets a cell when the count was rounded down).
    cost = np.zeros((10, 42), np.float32)
    cost[0:5, 13:17] = 0.5
    cost[1:4, 14:16] = np.inf
    start, goal = 1 * 42 + 17, 5 * 42 + 6
    optimum = float(dijkstra(step_graph(cost, 3.0), indices=start)[goal])
    cells = cost.size
    found, _ = bucket_astar(
        cost,
        start,
        goal,
        3.0,
        np.empty(cells),
        np.zeros(cells, np.int32),
        np.empty(cells, np.int32),
        np.empty(cells, np.int32),
        1,
        buckets_per_cell,
        1.0,
    )
    slip = 1.0 / buckets_per_cell
    assert optimum * (1 - 1e-6) <= found <= (1 + slip) * optimum + slip


def test_open_floor_is_passed_over_not_put_in_buckets() -> None:
    # A hall of floor 40 x 400 with one costly cell far off (so the bucket search runs): the
    # route along it is 380 straight steps, found by passing along the row, not by taking
    # each cell out of a bucket.
    cost = np.zeros((40, 400), np.float32)
    cost[2, 2] = 0.5
    search = SearchSettings(cost_weight=3.0, smooth=False)
    path = GlobalPlanner().plan(costmap_of(cost), center((20, 10)), center((20, 390)), search)
    assert path.cost / RES == pytest.approx(380.0)
    assert path.cells_expanded < 380 / 10
    # Passes stop for the ring's room and go on from their last cell: same cost backwards.
    back = GlobalPlanner().plan(costmap_of(cost), center((20, 390)), center((20, 10)), search)
    assert back.cost / RES == pytest.approx(380.0)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_smoothed_path_never_crosses_an_inflated_cell(seed: int) -> None:
    rng = np.random.default_rng(seed)
    rows, cols = 60, 60
    obstacles = np.zeros((rows, cols), bool)
    for _ in range(8):
        r, c = rng.integers(0, rows - 8), rng.integers(0, cols - 8)
        obstacles[r : r + rng.integers(2, 8), c : c + rng.integers(2, 8)] = True
    frame = GridFrame(RES, 0.0, 0.0, rows, cols)
    settings_ = CostmapSettings(0.25, 0.6, 3.0, True, 0.5, 65)
    costmap = build_costmap(frame, obstacles, np.zeros_like(obstacles), settings_)
    free = np.argwhere(np.isfinite(costmap.cost))
    start, goal = free[rng.integers(len(free))], free[rng.integers(len(free))]
    planner, search = GlobalPlanner(), SearchSettings(cost_weight=3.0, smooth=True)
    try:
        path = planner.plan(costmap, center(tuple(start)), center(tuple(goal)), search)
    except GoalUnreachableError:
        return
    # Sample every segment densely: every point lies in a cell the robot's centre may use.
    for a, b in zip(path.points_m[:-1], path.points_m[1:], strict=True):
        t = np.linspace(0, 1, int(np.hypot(*(b - a)) / (0.1 * RES)) + 2)[:, None]
        cells = np.floor((a + t * (b - a))[:, ::-1] / RES).astype(int)
        assert np.isfinite(costmap.cost[cells[:, 0], cells[:, 1]]).all()
    assert costmap.clearance_m[tuple(start)] >= 0.25


def test_inflation_keeps_routes_off_walls() -> None:
    # A 3 m wide corridor: with a cost weight the route runs along its middle.
    rows, cols = 30, 80
    obstacles = np.zeros((rows, cols), bool)
    obstacles[0, :] = obstacles[-1, :] = True
    frame = GridFrame(RES, 0.0, 0.0, rows, cols)
    costmap = build_costmap(
        frame, obstacles, np.zeros_like(obstacles), CostmapSettings(0.2, 1.5, 3.0, True, 0.5, 65)
    )
    path = GlobalPlanner().plan(
        costmap, (0.5, 0.6), (7.5, 0.6), SearchSettings(cost_weight=5.0, smooth=False)
    )
    assert path.points_m[:, 1].max() > 1.3  # it moves out towards the middle (y = 1.5)


@pytest.mark.parametrize(
    ("goal", "reason", "match"),
    [
        ((50.0, 0.5), "off the map", "off the map"),
        ((1.05, 1.05), "occupied", "occupied"),
        ((2.55, 2.55), "no route", "no route"),
    ],
)
def test_unreachable_goals_raise_with_the_reason(goal, reason, match) -> None:
    cost = np.zeros((40, 40), np.float32)
    cost[10, 10] = np.inf  # the goal cell itself
    cost[20:31, 20] = cost[20:31, 30] = cost[20, 20:31] = cost[30, 20:31] = np.inf  # a closed box
    with pytest.raises(GoalUnreachableError, match=match) as info:
        GlobalPlanner().plan(
            costmap_of(cost), (0.5, 0.5), goal, SearchSettings(cost_weight=1.0, smooth=True)
        )
    assert info.value.reason == reason


def test_unknown_goal_is_refused_when_unknown_space_is_forbidden() -> None:
    frame = GridFrame(RES, 0.0, 0.0, 20, 20)
    unknown = np.zeros((20, 20), bool)
    unknown[15:, 15:] = True
    costmap = build_costmap(
        frame, np.zeros((20, 20), bool), unknown, CostmapSettings(0.1, 0.3, 3.0, False, 0.5, 65)
    )
    with pytest.raises(GoalUnreachableError, match="unexplored") as info:
        GlobalPlanner().plan(
            costmap, (0.5, 0.5), (1.75, 1.75), SearchSettings(cost_weight=1.0, smooth=True)
        )
    assert info.value.reason == "unknown"


def test_an_unseen_goal_beside_an_obstacle_is_named_occupied_when_unknown_space_is_allowed() -> (
    None
):
    # another robot's body: an obstacle with the shadow it casts (unknown) around it
    frame = GridFrame(RES, 0.0, 0.0, 20, 20)
    obstacles = np.zeros((20, 20), bool)
    obstacles[15, 15] = True
    unknown = np.zeros((20, 20), bool)
    unknown[14:17, 14:20] = True
    costmap = build_costmap(
        frame, obstacles, unknown, CostmapSettings(0.2, 0.3, 3.0, True, 0.5, 65)
    )
    with pytest.raises(GoalUnreachableError, match="occupied") as info:
        GlobalPlanner().plan(
            costmap, (0.5, 0.5), (1.65, 1.55), SearchSettings(cost_weight=1.0, smooth=True)
        )
    assert info.value.reason == "occupied"


def test_a_robot_too_close_to_a_wall_plans_from_the_nearest_free_cell() -> None:
    cost = np.zeros((20, 20), np.float32)
    cost[:, :3] = np.inf
    path = GlobalPlanner().plan(
        costmap_of(cost), (0.15, 1.0), (1.5, 1.0), SearchSettings(cost_weight=1.0, smooth=False)
    )
    assert tuple(path.points_m[0]) == (0.15, 1.0)
    assert path.points_m[1][0] == pytest.approx(0.35)  # first free column


def test_start_off_the_map_or_walled_in_is_refused() -> None:
    cost = np.full((20, 20), np.inf, np.float32)
    planner, search = GlobalPlanner(), SearchSettings(cost_weight=1.0, smooth=False)
    with pytest.raises(StartBlockedError, match="off the map"):
        planner.plan(costmap_of(cost), (-1.0, 0.5), (0.5, 0.5), search)
    with pytest.raises(StartBlockedError, match="no free cell"):
        planner.plan(costmap_of(cost), (1.0, 1.0), (0.5, 0.5), search)

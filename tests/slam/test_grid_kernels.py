"""Every grid kernel against its NumPy twin (tests/slam/grid_reference.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.slam import _grid_kernels as k
from navd.slam.likelihood_field import gaussian_kernel
from navd.slam.tiles import TILE, TiledArray
from tests.slam import grid_reference as ref


def _tie_free(x0: int, y0: int, x1: int, y1: int) -> bool:
    """True if the ideal line never passes exactly half-way between two cells."""
    n = max(abs(x1 - x0), abs(y1 - y0))
    minor = abs(y1 - y0) if abs(x1 - x0) >= abs(y1 - y0) else abs(x1 - x0)
    return all((2 * i * minor) % (2 * n) != n for i in range(n))


def _grown_store(rows: int, cols: int) -> TiledArray:
    """An empty tiled array of rows x cols whose cells are off its tiles' boundaries (grown
    at its low edges by cells that are not whole tiles), with room reserved everywhere."""
    store = TiledArray(rows - 30, cols - 45)
    store.grow(rows, cols, 30, 45)
    assert (store.off_r % TILE, store.off_c % TILE) != (0, 0)
    store.reserve(0, rows - 1, 0, cols - 1)
    return store


@pytest.mark.parametrize(("seed", "keep"), [(1, 0), (2, 0), (3, 0), (4, 1), (5, 2)])
def test_ray_update_matches_the_reference(seed: int, keep: int) -> None:
    # rays from the middle of a grid of 4 x 4 tiles to ends in and around it: they cross
    # tile boundaries and the grid's edges
    rng = np.random.default_rng(seed)
    rays = []
    while len(rays) < 60:
        x1, y1 = (int(v) for v in rng.integers(-5, 205, 2))
        if (x1, y1) != (100, 100) and _tie_free(100, 100, x1, y1):
            rays.append((x1, y1))
    ends = np.array(rays, dtype=np.int64)
    hits = rng.random(len(rays)) < 0.7
    got = _grown_store(200, 200)
    want = np.zeros((200, 200), dtype=np.float32)
    ends_x, ends_y = ends[:, 0].copy(), ends[:, 1].copy()
    k.ray_update(*got.parts(), 100, 100, ends_x, ends_y, hits, -0.4, 0.85, -2.0, 3.5, keep)
    ref.ray_update(want, 100, 100, ends[:, 0], ends[:, 1], hits, -0.4, 0.85, -2.0, 3.5, keep)
    dense = got.window(0, 200, 0, 200)
    np.testing.assert_allclose(dense, want, atol=1e-6)
    assert dense.min() >= -2.0 and dense.max() <= 3.5
    # a tile is allocated where a ray wrote, and nowhere else
    written = np.zeros(got.index.shape, dtype=bool)
    rows, cols = np.nonzero(want)
    written[(rows + got.off_r) // TILE, (cols + got.off_c) // TILE] = True
    np.testing.assert_array_equal(got.index >= 0, written)


def _scattered(seed: int) -> tuple[np.ndarray, TiledArray]:
    """A 150 x 170 log-odds grid with 2 % of its cells occupied, the rest free but for a
    column of tiles never written; and its tiled store."""
    rng = np.random.default_rng(seed)
    grid = np.where(rng.random((150, 170)) < 0.02, 1.0, -1.0).astype(np.float32)
    grid[:, 64:128] = 0.0
    store = TiledArray.from_dense(grid)
    assert (store.index < 0).any()
    return grid, store


def test_smear_matches_the_reference_including_window_edges() -> None:
    grid, store = _scattered(4)
    kernel = gaussian_kernel(0.05, 0.05)
    field = np.zeros((130, 135), dtype=np.float32)
    k.smear(*store.parts(), 0.0, 25, -5, kernel, field)  # hangs over the left and top edges
    np.testing.assert_allclose(field, ref.smear(grid, 0.0, 25, -5, kernel, (130, 135)))


def test_smear_of_listed_cells_is_smear_of_the_occupied_ones_among_them() -> None:
    grid, store = _scattered(5)
    rng = np.random.default_rng(5)
    kernel = gaussian_kernel(0.05, 0.05)
    rows, cols = np.mgrid[-3:153, -3:173]  # every cell, and some off the grid
    cells = np.column_stack([cols.ravel(), rows.ravel()]).astype(np.int64)
    field = np.zeros((130, 135), dtype=np.float32)
    k.smear_cells(*store.parts(), 0.0, cells[rng.permutation(len(cells))], 25, -5, kernel, field)
    np.testing.assert_array_equal(field, ref.smear(grid, 0.0, 25, -5, kernel, (130, 135)))
    # half the occupied cells listed: the field of a grid holding only those
    rows, cols = np.nonzero(grid > 0.0)
    occupied = np.column_stack([cols, rows]).astype(np.int64)
    half = occupied[rng.random(len(occupied)) < 0.5]
    only = np.full_like(grid, -1.0)
    only[half[:, 1], half[:, 0]] = 1.0
    field[:] = 0.0
    k.smear_cells(*store.parts(), 0.0, half, 25, -5, kernel, field)
    np.testing.assert_array_equal(field, ref.smear(only, 0.0, 25, -5, kernel, (130, 135)))


@pytest.mark.parametrize("f", [1, 2, 4, 5])
def test_doubled_max_matches_the_reference(f: int) -> None:
    field = np.random.default_rng(f).random((23, 31)).astype(np.float32)
    half = field if f == 1 else ref.sliding_max(field, f)
    np.testing.assert_array_equal(k.doubled_max(half, f), ref.sliding_max(field, 2 * f))


def test_scores_match_the_reference_and_blocks_bound_their_translations() -> None:
    rng = np.random.default_rng(5)
    field = rng.random((80, 80)).astype(np.float32)
    px = rng.uniform(-20, 20, 50)
    py = rng.uniform(-20, 20, 50)
    angles = np.array([-0.1, 0.0, 0.07])
    tx, ty, f = 40.3, 38.8, 4
    fine = k.fine_scores(field, px, py, np.cos(0.07), np.sin(0.07), tx, ty, -3, -2, 5, 4)
    for j in range(4):
        for i in range(5):
            want = ref.score(field, px, py, np.cos(0.07), np.sin(0.07), tx, ty, -3 + i, -2 + j)
            assert fine[j, i] == pytest.approx(want, rel=1e-5)
    starts = np.array([(dx, dy) for dy in (-8, -4, 0, 4) for dx in (-8, -4, 0, 4)])
    bound = ref.sliding_max(field, f)
    for angle in angles:
        c, s = np.cos(angle), np.sin(angle)
        for dx0, dy0 in starts:
            block = k.fine_scores(field, px, py, c, s, tx, ty, dx0, dy0, f, f)
            assert ref.score(bound, px, py, c, s, tx, ty, dx0, dy0) >= block.max() - 1e-3


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_the_four_quarters_of_a_block_are_bounded_as_each_alone(seed: int) -> None:
    rng = np.random.default_rng(seed)
    field = rng.random((40, 50)).astype(np.float32)
    # Points near the field's low corner, so some quarters start before it and reach in.
    cols = rng.integers(-12, 20, 60)
    rows = rng.integers(-12, 20, 60)
    for half in (1, 2, 4, 8):
        bound = ref.sliding_max(field, half)
        for dx, dy in rng.integers(-10, 40, (12, 2)):
            quarters = k._quarter_bounds(bound, cols, rows, int(dx), int(dy), half)
            alone = [
                k._block_bound(bound, cols, rows, int(dx) + i, int(dy) + j, half)
                for j in (0, half)
                for i in (0, half)
            ]
            assert list(quarters) == alone  # to the bit: the search's order does not move


@pytest.mark.parametrize("seed", [14, 15, 16])
def test_best_among_is_the_best_score_of_the_translations_allowed(seed: int) -> None:
    rng = np.random.default_rng(seed)
    field = rng.random((60, 70)).astype(np.float32) ** 4
    px, py = rng.uniform(-15, 15, 40), rng.uniform(-15, 15, 40)
    c, s = math.cos(0.3), math.sin(0.3)
    tx, ty, limit = 12.4, 50.6, 13  # some translations move points off the field
    # The field peaks under the points at the pose itself (as at a match), inside the disc
    # the ring leaves out: a search that ignored the mask would return that peak.
    for i in range(px.size):
        col, row = _cell_of(px[i], py[i], c, s, tx, ty)
        if 0 <= col < field.shape[1] and 0 <= row < field.shape[0]:
            field[row, col] = 1.0
    bounds = tuple(ref.sliding_max(field, 2**level) for level in range(4))
    every = k.fine_scores(field, px, py, c, s, tx, ty, -limit, -limit, 2 * limit + 1, 2 * limit + 1)
    offsets = np.arange(-limit, limit + 1)
    distance = np.hypot(offsets[None, :], offsets[:, None])
    ring = (distance > 4) & (distance <= limit)
    assert every.max() > every[ring].max()  # the peak is left out
    scattered = rng.random(ring.shape) < 0.05
    for allowed in (ring, scattered, np.ones_like(ring)):
        best = k.best_among(bounds, px, py, c, s, tx, ty, allowed)
        assert best == every[allowed].max()  # exact, as the window scored cell by cell
        twin = ref.best_among(field, px, py, c, s, tx, ty, allowed)
        assert best == pytest.approx(twin, rel=1e-5)
    assert k.best_among(bounds, px, py, c, s, tx, ty, np.zeros_like(ring)) == 0.0


def _cell_of(px: float, py: float, c: float, s: float, tx: float, ty: float) -> tuple[int, int]:
    """The cell a point falls in, as the kernels project it (rounded to the nearest)."""
    return math.floor(c * px - s * py + tx + 0.5), math.floor(s * px + c * py + ty + 0.5)


@pytest.mark.parametrize("seed", [17, 18])
def test_a_scans_cells_and_box_match_the_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    points = rng.uniform(-7.0, 9.0, (200, 2))
    origin_x, origin_y, res = -3.21, 1.7, 0.05
    for col, row in ((500, -600), (0, 0)):  # a start cell outside the points' box, and inside
        got = k.cells_and_box(points, origin_x, origin_y, res, col, row)
        want = ref.cells_and_box(points, origin_x, origin_y, res, col, row)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
        assert got[2:] == want[2:]
    for x, y in ((12.0, -0.5), (1.0, 1.0)):
        assert k.extent(points, x, y) == ref.extent(points, x, y)
    assert k.extent(points[:0], 1.5, -2.5) == (1.5, -2.5, 1.5, -2.5)
    broken = points.copy()
    broken[3, 1] = np.nan
    assert all(math.isnan(v) for v in k.extent(broken, 0.0, 0.0))
    assert all(math.isnan(v) for v in k.extent(points, math.inf, 0.0))


@pytest.mark.parametrize("seed", [6, 7, 8])
def test_branch_and_bound_matches_the_reference_and_the_exhaustive_optimum(seed: int) -> None:
    rng = np.random.default_rng(seed)
    field = rng.random((60, 70)).astype(np.float32) ** 4  # a few strong cells
    px, py = rng.uniform(-15, 15, 40), rng.uniform(-15, 15, 40)
    angles = np.array([-0.2, -0.1, 0.0, 0.1, 0.2])
    tx, ty, limit = 35.2, 29.7, 6
    bounds = tuple(ref.sliding_max(field, 2**level) for level in range(3))
    no_pull = np.zeros(angles.size)
    a, dx, dy, total, _ = k.branch_and_bound(
        bounds,
        px,
        py,
        np.cos(angles),
        np.sin(angles),
        tx,
        ty,
        limit,
        no_pull,
        0.0,
        -math.inf,
        1.0,
        1.0,
        0.0,
        0.0,
    )
    assert (a, dx, dy) == ref.branch_and_bound(bounds, px, py, angles, tx, ty, limit)[:3]
    exhaustive = {
        (b, x, y): ref.score(field, px, py, np.cos(angle), np.sin(angle), tx, ty, x, y)
        for b, angle in enumerate(angles)
        for y in range(-limit, limit + 1)
        for x in range(-limit, limit + 1)
    }
    assert total == pytest.approx(max(exhaustive.values()), rel=1e-5)
    assert total == pytest.approx(exhaustive[a, dx, dy], rel=1e-5)


@pytest.mark.parametrize("seed", [6, 7, 8])
def test_a_floor_gives_up_a_search_below_it_early_and_leaves_one_above_it_unchanged(
    seed: int,
) -> None:
    rng = np.random.default_rng(seed)
    field = rng.random((60, 70)).astype(np.float32) ** 4
    px, py = rng.uniform(-15, 15, 40), rng.uniform(-15, 15, 40)
    angles = np.array([-0.2, -0.1, 0.0, 0.1, 0.2])
    tx, ty, limit = 35.2, 29.7, 6
    bounds = tuple(ref.sliding_max(field, 2**level) for level in range(3))
    no_pull = np.zeros(angles.size)
    c, s = np.cos(angles), np.sin(angles)

    def search(floor: float) -> tuple[int, int, int, float, int]:
        return k.branch_and_bound(
            bounds, px, py, c, s, tx, ty, limit, no_pull, 0.0, floor, 1.0, 1.0, 0.0, 0.0
        )

    free = search(-math.inf)
    best = free[3]
    # at or below the optimum: the same answer, with no more work
    for floor in (best, 0.9 * best):
        kept = search(floor)
        assert kept[:4] == free[:4] and kept[4] <= free[4]
    # above it: nothing is found, and the search stops sooner
    above = search(best * 1.5)
    assert above[0] == -1 and above[4] < free[4]
    assert search(float(np.nextafter(best, math.inf)))[0] == -1  # the least bit above


@pytest.mark.parametrize("seed", [6, 7, 8])
def test_a_floor_with_a_pull_keeps_the_pulled_optimum(seed: int) -> None:
    rng = np.random.default_rng(seed)
    field = rng.random((60, 70)).astype(np.float32) ** 4
    px, py = rng.uniform(-15, 15, 40), rng.uniform(-15, 15, 40)
    angles = np.array([-0.2, -0.1, 0.0, 0.1, 0.2])
    turn_cost = 5.0 * angles**2 * 40
    tx, ty, limit, per_cell2 = 35.2, 29.7, 6, 0.3
    bounds = tuple(ref.sliding_max(field, 2**level) for level in range(4))
    c, s = np.cos(angles), np.sin(angles)

    def search(floor: float) -> tuple[int, int, int, float, int]:
        return k.branch_and_bound(
            bounds, px, py, c, s, tx, ty, limit, turn_cost, per_cell2, floor, 1.0, 1.0, 0.0, 0.0
        )

    free = search(-math.inf)
    a, dx, dy, total, _ = free
    pulled = total - (turn_cost[a] + per_cell2 * (dx * dx + dy * dy))  # what the search ranks
    assert search(pulled)[:4] == free[:4]
    assert search(float(np.nextafter(pulled, math.inf)))[0] == -1


@pytest.mark.parametrize("seed", [6, 7, 8])
@pytest.mark.parametrize(
    ("per_cell2", "weak_angle", "weak_cell2"),
    # (the weak-axis cases fail if a block's pull along the axis is taken at its first corner,
    # not at its least)
    [(0.02, 0.0, 0.0), (0.3, 0.0, 0.0), (0.02, 0.5, 0.5), (0.02, -2.5, 0.5), (0.0, 3.0, 3.0)],
)
def test_branch_and_bound_with_a_pull_finds_the_exhaustive_optimum_less_the_pull(
    seed: int, per_cell2: float, weak_angle: float, weak_cell2: float
) -> None:
    rng = np.random.default_rng(seed)
    field = rng.random((60, 70)).astype(np.float32) ** 4
    px, py = rng.uniform(-15, 15, 40), rng.uniform(-15, 15, 40)
    angles = np.array([-0.2, -0.1, 0.0, 0.1, 0.2])
    turn_cost = 5.0 * angles**2 * 40
    tx, ty, limit = 35.2, 29.7, 6
    bounds = tuple(ref.sliding_max(field, 2**level) for level in range(4))
    a, dx, dy, total, _ = k.branch_and_bound(
        bounds,
        px,
        py,
        np.cos(angles),
        np.sin(angles),
        tx,
        ty,
        limit,
        turn_cost,
        per_cell2,
        -math.inf,
        1.0,
        math.cos(weak_angle),
        math.sin(weak_angle),
        weak_cell2,
    )
    # The translation's pull: per_cell2 per squared cell, and weak_cell2 more per squared
    # cell along the direction at weak_angle.
    pulled = {
        (b, x, y): ref.score(field, px, py, np.cos(angle), np.sin(angle), tx, ty, x, y)
        - turn_cost[b]
        - per_cell2 * (x * x + y * y)
        - weak_cell2 * (x * math.cos(weak_angle) + y * math.sin(weak_angle)) ** 2
        for b, angle in enumerate(angles)
        for y in range(-limit, limit + 1)
        for x in range(-limit, limit + 1)
    }
    best = max(pulled.values())
    assert pulled[a, dx, dy] == pytest.approx(best, rel=1e-5, abs=1e-4)
    raw = ref.score(field, px, py, np.cos(angles[a]), np.sin(angles[a]), tx, ty, dx, dy)
    assert total == pytest.approx(raw, rel=1e-5)


@pytest.mark.parametrize("angle", [0.0, 0.5, 0.9273, math.pi / 2, 2.2, -2.5, 3.0])
def test_the_pull_along_an_axis_is_bounded_from_below_over_every_block(angle: float) -> None:
    # Over every block the search may queue (sizes 1 to 8, any side of the prior): never
    # more than the least of its translations' pulls along the axis (or the search would
    # drop the optimum), and that least where the block does not straddle the line through
    # the prior across the axis. (0.9273 rad: (0.6, 0.8), where the block [2..5] x [-5..-2]
    # straddles the line through (4, -3) while its translation nearest the prior does not.)
    ux, uy = math.cos(angle), math.sin(angle)
    for size in (1, 2, 4, 8):
        for dy in range(-12, 8):
            for dx in range(-12, 8):
                along = [
                    ux * x + uy * y for y in range(dy, dy + size) for x in range(dx, dx + size)
                ]
                least = min(a * a for a in along)
                bound = k._nearest_along2(dx, dy, size, ux, uy)
                assert bound <= least + 1e-9
                if min(along) > 0.0 or max(along) < 0.0:
                    assert bound == pytest.approx(least)
    assert k._nearest_along2(2, -5, 4, 0.6, 0.8) == 0.0


@pytest.mark.parametrize("block", [2, 4, 8, 64])
def test_field_bounds_built_by_doubling_equal_the_reference(block: int) -> None:
    from navd.slam.likelihood_field import LikelihoodField

    values = np.random.default_rng(block).random((97, 130)).astype(np.float32)
    field = LikelihoodField(values, 0.0, 0.0, 0.05)
    np.testing.assert_array_equal(field.bound(block), ref.sliding_max(values, block))
    assert field.bound(1) is field.values  # the bound over one cell is the field, uncopied
    with pytest.raises(ValueError, match="power of two cells, not 3"):
        field.bound(3)


def test_a_field_given_in_another_layout_is_kept_c_ordered_float32() -> None:
    from navd.slam.likelihood_field import LikelihoodField

    values = np.random.default_rng(3).random((40, 60))[:, ::2]  # float64, strided
    field = LikelihoodField(values, 0.0, 0.0, 0.05)
    assert field.values.dtype == np.float32 and field.values.flags.c_contiguous
    np.testing.assert_array_equal(field.bound(4), ref.sliding_max(values.astype(np.float32), 4))


def test_count_known_matches_the_reference_on_and_off_the_grid() -> None:
    rng = np.random.default_rng(9)
    logodds = np.where(rng.random((130, 140)) < 0.01, rng.normal(0, 1, (130, 140)), 0.0).astype(
        np.float32
    )
    logodds[64:128, :] = 0.0  # a row of tiles never written
    cols_x = rng.integers(-4, 144, 3000)
    rows_y = rng.integers(-4, 134, 3000)
    got = k.count_known(*TiledArray.from_dense(logodds).parts(), cols_x, rows_y)
    assert got == ref.count_known(logodds, cols_x, rows_y)
    assert 0 < got < 3000


def test_a_tie_between_rotations_goes_to_the_first_as_when_every_rotation_is_queued_at_once() -> (
    None
):
    # One point, two rotations: the first sees a full cell but turns away from the prior
    # (cost 0.5), the second sees a half cell straight ahead: both score 0.5. A rotation's
    # points are projected only when its entry comes first; the second's entry (bound 1 - 0)
    # comes before the first's (1 - 0.5), and still the first wins the tie, as it does when
    # all rotations are projected up front.
    field = np.zeros((5, 5), dtype=np.float32)
    field[2, 3] = 1.0  # the point (1, 0) not turned, from the prior at cell (2, 2)
    field[3, 2] = 0.5  # the same point turned a quarter
    angles = np.array([0.0, math.pi / 2])
    a, dx, dy, total, _ = k.branch_and_bound(
        (field,),
        np.array([1.0]),
        np.array([0.0]),
        np.cos(angles),
        np.sin(angles),
        2.0,
        2.0,
        0,
        np.array([0.5, 0.0]),
        0.0,
        -math.inf,
        1.0,
        1.0,
        0.0,
        0.0,
    )
    assert (a, dx, dy, total) == (0, 0, 0, 1.0)

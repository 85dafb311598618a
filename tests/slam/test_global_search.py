"""Global search: the exhaustive optimum without exhausting, and relocalization in the room."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2, scan_points
from navd.slam import _grid_kernels as k
from navd.slam import global_search as global_search_module
from navd.slam.global_search import COARSE_MAX_CELLS, _coarse_factor, global_search, relocalize
from navd.slam.occupancy import OccupancyGrid
from navd.slam.voxel import voxel_downsample


def _room() -> OccupancyGrid:
    grid = OccupancyGrid(0.05)
    for pose in (Pose2(0, 0, 0), Pose2(-3, -1, 1.0), Pose2(4, 2.5, -2.0), Pose2(-4, 2, 0.5)):
        a0, inc, r = cast(pose)
        grid.insert(pose, scan_points(r, a0, inc, range_min=0.1, range_max=30.0))
    return grid


GRID = _room()


def _points(pose: Pose2) -> np.ndarray:
    a0, inc, r = cast(pose)
    return voxel_downsample(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits, 0.1)


def test_branch_and_bound_equals_brute_force_on_a_small_window() -> None:
    truth = Pose2(1.3, -0.6, 0.4)
    points = _points(truth)
    center = Pose2(1.0, -0.5, 0.3)
    field = GRID.likelihood_field(center, 12.0, 0.05)
    pose, score, expanded = global_search(
        field,
        points,
        center=center,
        half_width_m=0.5,
        yaw_window_rad=0.2,
        angle_step_rad=0.02,
        levels=3,
    )
    res = field.resolution
    px, py = points[:, 0] / res, points[:, 1] / res
    tx = (center.x - field.origin_x) / res - 0.5
    ty = (center.y - field.origin_y) / res - 0.5
    best = max(
        float(
            k.fine_scores(
                field.values, px, py, math.cos(a), math.sin(a), tx, ty, -10, -10, 21, 21
            ).max()
        )
        for a in center.yaw - 0.2 + 0.02 * np.arange(20)
    )
    assert score * points.shape[0] == pytest.approx(best, rel=1e-5)
    assert expanded < 20 * 4 * 4  # far fewer than the candidates of the top level alone
    assert math.hypot(pose.x - truth.x, pose.y - truth.y) < 0.1


def test_a_coarsened_grid_holds_the_largest_log_odds_of_each_block() -> None:
    values = (np.arange(35, dtype=np.float32).reshape(5, 7) - 20.0) * np.float32(0.1)
    grid = OccupancyGrid.from_array(values, 1.0, -2.0, 0.05)
    coarse = grid.coarsened(2)
    assert coarse.shape == (3, 4)  # the last row and column cover one cell each
    assert (coarse.origin_x, coarse.origin_y, coarse.resolution) == (1.0, -2.0, 0.1)
    for r in range(3):
        for c in range(4):
            block = values[2 * r : 2 * r + 2, 2 * c : 2 * c + 2]
            assert coarse.to_array()[r, c] == block.max()


def test_a_cropped_grid_is_the_part_around_a_pose_where_it_was() -> None:
    part = GRID.cropped(Pose2(1.0, -0.5, 0.3), 2.0)
    assert part.shape == (81, 81)
    # the same cells at the same places
    col, row = GRID.cells(np.array([[part.origin_x + 0.01, part.origin_y + 0.01]]))[0]
    np.testing.assert_array_equal(part.to_array(), GRID.to_array()[row : row + 81, col : col + 81])
    edge = GRID.cropped(Pose2(GRID.origin_x, GRID.origin_y, 0.0), 1.0)  # clipped at the corner
    assert edge.shape == (21, 21) and (edge.origin_x, edge.origin_y) == (
        GRID.origin_x,
        GRID.origin_y,
    )


def test_branch_and_bound_is_exact_with_blocks_as_large_as_the_field() -> None:
    # The room coarsened to 20 cm cells is 110 cells wide: the search's top blocks (64 cells)
    # start far before the field's edge. A bound that counted a block starting outside the
    # field as nothing missed the robot (found 7 m off at 0.56 where it scores 0.96).
    coarse = GRID.coarsened(4)
    center, half = coarse.whole()
    field = coarse.likelihood_field(center, half, coarse.resolution)
    for truth in (Pose2(-4.5, 0.5, -1.0), Pose2(2.0, -2.5, 2.5)):
        pose, score, _ = global_search(field, _points(truth), center=center, half_width_m=half)
        assert math.hypot(pose.x - truth.x, pose.y - truth.y) < 0.25
        assert score > 0.85


@pytest.mark.parametrize(
    "truth", [Pose2(2.0, -2.5, 2.5), Pose2(-4.5, 0.5, -1.0), Pose2(0.5, 2.5, 0.0)]
)
def test_the_robot_is_found_anywhere_in_the_room(truth: Pose2) -> None:
    found = relocalize(GRID, _points(truth))
    assert math.hypot(found.pose.x - truth.x, found.pose.y - truth.y) < 0.05
    assert abs(math.remainder(found.pose.yaw - truth.yaw, 2 * math.pi)) < math.radians(2.0)
    near = relocalize(GRID, _points(truth), guess=truth.compose(Pose2(0.4, -0.3, 0.26)))
    assert math.hypot(near.pose.x - truth.x, near.pose.y - truth.y) < 0.05


@pytest.mark.parametrize(
    ("half_cells", "factor"),
    [
        (621.0, 2),  # the Intel lab's whole map at 5 cm
        (math.sqrt(COARSE_MAX_CELLS * 4) / 2 - 0.5, 2),  # just within the cap, coarsened 2 times
        (math.sqrt(COARSE_MAX_CELLS * 4) / 2 + 0.5, 4),  # just over it
        (4320.0, 4),  # fr-clinic's whole map: 4 times, so it stays within memory
    ],
)
def test_a_wide_search_is_coarsened_as_little_as_its_memory_allows(
    half_cells: float, factor: int
) -> None:
    # Coarsened 2 times if the field (and so each of its bounds) then holds at most
    # COARSE_MAX_CELLS cells: finer cells tell look-alike places apart.
    assert _coarse_factor(half_cells) == factor


@pytest.mark.parametrize(("max_cells", "factor"), [(COARSE_MAX_CELLS, 2), (40_000, 4)])
def test_the_whole_room_is_searched_as_finely_as_the_cap_allows(
    monkeypatch: pytest.MonkeyPatch, max_cells: int, factor: int
) -> None:
    # The room searched whole: a field 22 m across, 440 x 440 cells at 5 cm, so 48 400 cells
    # coarsened 2 times; over a cap of 40 000 it is coarsened 4 times. Found either way.
    monkeypatch.setattr(global_search_module, "COARSE_MAX_CELLS", max_cells)
    factors: list[int] = []
    coarsened = OccupancyGrid.coarsened

    def spy(grid: OccupancyGrid, by: int) -> OccupancyGrid:
        factors.append(by)
        return coarsened(grid, by)

    monkeypatch.setattr(OccupancyGrid, "coarsened", spy)
    truth = Pose2(2.0, -2.5, 2.5)
    found = relocalize(GRID, _points(truth))
    assert factors == [factor]
    assert math.hypot(found.pose.x - truth.x, found.pose.y - truth.y) < 0.05

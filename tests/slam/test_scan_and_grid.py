"""Scan intake and the occupancy grid."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.geometry import Pose2, ScanPoints, scan_points
from navd.slam.occupancy import OccupancyGrid
from navd.slam.tiles import TILE
from navd.slam.voxel import voxel_downsample


def test_voxel_downsample_keeps_one_point_per_cell_in_order() -> None:
    points = np.array([[0.01, 0.01], [0.02, 0.03], [0.5, 0.5], [0.04, 0.0], [0.52, 0.51]])
    np.testing.assert_array_equal(voxel_downsample(points, 0.1), points[[0, 2]])


@pytest.mark.parametrize("seed", range(5))
def test_voxel_downsample_agrees_with_a_first_point_per_cell_reference(seed: int) -> None:
    # Points on both sides of both axes, far out and near cell borders.
    rng = np.random.default_rng(seed)
    points = rng.normal(0.0, 40.0, (2000, 2))
    points[:200] = np.round(points[:200], 1)  # exactly on cell borders
    voxel = 0.1
    first: dict[tuple[int, int], int] = {}
    for i, (x, y) in enumerate(points):
        first.setdefault((math.floor(x / voxel), math.floor(y / voxel)), i)
    expected = points[sorted(first.values())]
    np.testing.assert_array_equal(voxel_downsample(points, voxel), expected)


def test_ray_casting_marks_free_and_occupied_and_the_grid_grows() -> None:
    grid = OccupancyGrid(0.1, chunk_m=2.0)
    scan = scan_points([3.0], 0.0, 0.1, range_min=0.1, range_max=10.0)
    grid.insert(Pose2(0, 0, 0), scan)
    col, row = grid.cells(np.array([[3.05, 0.05]]))[0]
    assert grid.to_array()[row, col] > 0
    free_col, free_row = grid.cells(np.array([[1.5, 0.05]]))[0]
    assert grid.to_array()[free_row, free_col] < 0
    before = grid.to_array(), grid.origin_x, grid.origin_y
    grid.insert(Pose2(0, 0, math.pi), scan)  # a wall 3 m behind: the grid grows to the left
    assert grid.origin_x < before[1]
    col, row = grid.cells(np.array([[3.05, 0.05]]))[0]
    assert grid.to_array()[row, col] == pytest.approx(before[0].max())  # old content kept in place
    occupancy = grid.occupancy_percent()
    assert occupancy.min() == -1 and occupancy.max() > 65


def test_a_grid_stores_the_tiles_its_rays_crossed_not_its_whole_extent() -> None:
    # two round rooms (3 m radius) 150 m apart: the extent spans both, the tiles only what
    # the rays crossed
    grid = OccupancyGrid(0.05)
    circle = scan_points(np.full(360, 3.0), -math.pi, math.pi / 180, range_min=0.1, range_max=10.0)
    for pose in (Pose2(0.0, 0.0, 0.0), Pose2(150.0, 40.0, 0.5)):
        grid.insert(pose, circle)
    rows, cols = grid.shape
    assert cols * 0.05 > 150.0
    # a room's 6 m square spans at most 3 x 3 tiles of 64 cells (3.2 m)
    assert grid.stored_bytes <= 2 * 9 * TILE * TILE * 4 < 0.02 * rows * cols * 4
    dense = grid.to_array()
    for x, y in ((0.0, 3.0), (150.0, 37.0)):  # each room's wall is in it
        col, row = grid.cells(np.array([[x, y]]))[0]
        assert (dense[row - 2 : row + 3, col - 2 : col + 3] > 0).any()


def test_occupancy_percent_of_a_large_grid_is_the_probability_of_each_cell() -> None:
    # more rows than one band of the conversion; unknown (0) cells scattered among them
    rng = np.random.default_rng(3)
    cells = rng.uniform(-2.0, 3.5, (700, 90)).astype(np.float32)
    cells[rng.random((700, 90)) < 0.2] = 0.0
    grid = OccupancyGrid.from_array(cells, 0.0, 0.0, 0.05)
    occupancy = grid.occupancy_percent()
    assert occupancy.shape == (700, 90) and occupancy.dtype == np.int8
    logodds = grid.to_array().astype(np.float64)
    probability = np.exp(logodds) / (1.0 + np.exp(logodds))  # the odds' definition
    known = grid.to_array() != 0.0
    assert np.all(occupancy[~known] == -1)
    assert np.abs(occupancy[known] - probability[known] * 100.0).max() <= 0.5 + 1e-9


def test_a_scan_that_saw_nothing_is_inserted_without_marking_a_cell() -> None:
    # (a keyframe of a blind sweep, drawn again when a loop closure rebuilds the map)
    grid = OccupancyGrid(0.05)
    blind = scan_points(np.zeros(90), -math.pi, math.pi / 45, range_min=0.1, range_max=10.0)
    grid.insert(Pose2(3.0, -2.0, 0.0), blind)
    assert not grid.empty and grid.revision == 1
    assert not grid.to_array().any()
    col, row = grid.cells(np.array([[3.0, -2.0]]))[0]
    assert 0 <= row < grid.shape[0] and 0 <= col < grid.shape[1]


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
def test_a_scan_with_a_point_that_is_not_finite_is_refused_and_the_grid_kept() -> None:
    grid = OccupancyGrid(0.05)
    room = scan_points(np.full(90, 2.0), -math.pi, math.pi / 45, range_min=0.1, range_max=10.0)
    grid.insert(Pose2(0.0, 0.0, 0.0), room)
    before = grid.to_array()
    hits = room.hits.copy()
    hits[5] = (np.nan, 1.0)
    for scan, pose in (
        (ScanPoints(hits, room.misses), Pose2(0.0, 0.0, 0.0)),
        (ScanPoints(room.hits, np.array([[np.inf, 0.0]])), Pose2(0.0, 0.0, 0.0)),
        (room, Pose2(float("nan"), 0.0, 0.0)),
    ):
        with pytest.raises(ValueError, match="not finite"):
            grid.insert(pose, scan)
    np.testing.assert_array_equal(grid.to_array(), before)
    assert grid.revision == 1

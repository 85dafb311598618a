"""Costmap layers: inflation, keep-out polygons, the obstacle layer's marking and clearing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.planning._costmap_kernels import mark_and_clear
from navd.planning.costmap import (
    CostmapSettings,
    GridFrame,
    ObstacleLayer,
    build_costmap,
    keep_out_mask,
    static_layer,
)

FRAME = GridFrame(0.1, -2.0, -2.0, 40, 40)


def test_inflation_follows_the_distance_to_the_nearest_obstacle() -> None:
    obstacles = np.zeros(FRAME.shape, bool)
    obstacles[20, 20] = True
    settings = CostmapSettings(0.25, 1.0, 3.0, True, 0.5, 65)
    costmap = build_costmap(FRAME, obstacles, np.zeros_like(obstacles), settings)
    for row, col in [(20, 22), (20, 23), (23, 24), (20, 29), (20, 35)]:
        d = 0.1 * math.hypot(row - 20, col - 20)
        assert costmap.clearance_m[row, col] == pytest.approx(d, rel=1e-6)
        if d < 0.25:
            assert math.isinf(costmap.cost[row, col])
        elif d < 1.0:
            assert costmap.cost[row, col] == pytest.approx(math.exp(-3.0 * (d - 0.25)), rel=1e-5)
        else:
            assert costmap.cost[row, col] == 0.0


def test_unknown_cells_cost_or_block_as_configured() -> None:
    unknown = np.zeros(FRAME.shape, bool)
    unknown[:, :10] = True
    none = np.zeros(FRAME.shape, bool)
    allowed = build_costmap(FRAME, none, unknown, CostmapSettings(0.2, 0.5, 3.0, True, 0.4, 65))
    assert (allowed.cost[:, :10] == np.float32(0.4)).all() and (allowed.cost[:, 10:] == 0).all()
    forbidden = build_costmap(FRAME, none, unknown, CostmapSettings(0.2, 0.5, 3.0, False, 0.4, 65))
    assert np.isinf(forbidden.cost[:, :10]).all()
    assert np.isinf(forbidden.clearance_m).all()  # nothing is an obstacle


@pytest.mark.parametrize("allow_unknown", [True, False])
def test_the_blocked_cells_are_those_of_infinite_cost(allow_unknown: bool) -> None:
    rng = np.random.default_rng(7)
    obstacles = rng.random(FRAME.shape) < 0.02
    unknown = np.zeros(FRAME.shape, bool)
    unknown[25:, 5:30] = True
    settings = CostmapSettings(0.25, 0.8, 3.0, allow_unknown, 0.5, 65)
    costmap = build_costmap(FRAME, obstacles, unknown, settings)
    np.testing.assert_array_equal(costmap.blocked, ~np.isfinite(costmap.cost))
    assert costmap.blocked.any() and not costmap.blocked.all()
    # unexplored cells are all blocked when they cannot be crossed, else only near obstacles
    assert costmap.blocked[unknown].all() == (not allow_unknown)


def test_static_layer_thresholds_occupancy() -> None:
    occupancy = np.array([[-1, 0, 64, 65, 100]], dtype=np.int8)
    occupied, unknown = static_layer(occupancy, 65)
    assert occupied.tolist() == [[False, False, False, True, True]]
    assert unknown.tolist() == [[True, False, False, False, False]]


def test_keep_out_polygons_cover_the_cells_whose_centres_are_inside() -> None:
    triangle = ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0))
    mask = keep_out_mask(FRAME, [triangle])
    centres = FRAME.centers_of(np.argwhere(np.ones(FRAME.shape, bool)).astype(np.int64))
    inside = (centres[:, 0] > 0) & (centres[:, 1] > 0) & (centres[:, 0] + centres[:, 1] < 1.0)
    assert mask.ravel().tolist() == inside.tolist()


def test_obstacle_layer_marks_hits_and_clears_along_rays_and_forgets_old_marks() -> None:
    layer = ObstacleLayer(FRAME, persistence_s=1.0)
    layer.add_scan((0.05, 0.05), np.array([[1.05, 0.05]]), np.empty((0, 2)), stamp=0.0)
    hit = FRAME.cell_of(1.05, 0.05)
    assert layer.active(0.5)[hit] and layer.active(0.5).sum() == 1
    assert not layer.active(1.5).any()  # not seen again for longer than the persistence
    # The obstacle moved away: a ray now passes through its cell to a farther wall.
    layer.add_scan((0.05, 0.05), np.array([[1.55, 0.05]]), np.empty((0, 2)), stamp=0.6)
    assert not layer.active(0.7)[hit] and layer.active(0.7)[FRAME.cell_of(1.55, 0.05)]
    # A ray with no return clears all the way to its end.
    layer.add_scan((0.05, 0.05), np.empty((0, 2)), np.array([[1.95, 0.05]]), stamp=0.8)
    assert not layer.active(0.9).any()


def test_rays_ending_in_the_cell_of_the_ray_before_clear_and_mark_as_if_each_were_traced() -> None:
    # A dense scan of a room: neighbouring beams end in the same cell, and the kernel skips
    # them; traced in a shuffled order (no neighbours), every ray is traced: the same layer.
    rng = np.random.default_rng(11)
    angles = np.linspace(-math.pi, math.pi, 1440, endpoint=False)
    ranges = rng.uniform(0.5, 3.0) + 0.4 * np.sin(3 * angles)
    ends = np.column_stack([1.0 + ranges * np.cos(angles), 0.5 + ranges * np.sin(angles)])
    frame = GridFrame(0.05, -3.0, -3.0, 120, 120)
    cells = frame.cells_of(ends)
    is_hit = rng.random(cells.shape[0]) < 0.8
    is_hit[200:400] = False  # a stretch of misses
    origin = frame.cell_of(1.0, 0.5)
    in_order = np.full((120, 120), 5.0)  # every cell seen occupied at 5 s
    mark_and_clear(in_order, origin[0], origin[1], cells, is_hit, 7.0)
    shuffled = np.full((120, 120), 5.0)
    order = rng.permutation(cells.shape[0])
    mark_and_clear(shuffled, origin[0], origin[1], cells[order], is_hit[order], 7.0)
    repeats = (np.diff(cells, axis=0) == 0).all(axis=1) & (is_hit[1:] == is_hit[:-1])
    assert repeats.sum() > 500  # the case is the one meant
    np.testing.assert_array_equal(in_order, shuffled)
    assert (in_order == 7.0).any() and (in_order == -np.inf).any() and (in_order == 5.0).any()


def test_obstacle_layer_keeps_its_marks_when_the_frame_grows() -> None:
    layer = ObstacleLayer(FRAME, persistence_s=5.0)
    layer.add_scan((0.05, 0.05), np.array([[1.05, -1.05]]), np.empty((0, 2)), stamp=0.0)
    bigger = GridFrame(0.1, -3.0, -2.5, 60, 60)
    layer.reframe(bigger)
    assert np.argwhere(layer.active(0.0)).tolist() == [list(bigger.cell_of(1.05, -1.05))]
    layer.clear_disc(1.0, -1.0, 0.2)
    assert not layer.active(0.0).any()
    with pytest.raises(ValueError, match="do not line up"):
        layer.reframe(GridFrame(0.1, -3.05, -2.5, 60, 60))

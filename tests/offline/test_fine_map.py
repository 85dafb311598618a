"""The fine map: a match's position refined on the keyframes drawn at a finer cell, and
the keyframes it draws (only those near, within its budget of tiles)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navd.bench.synthetic_room import WALLS, cast
from navd.config import ConfigError, parse_config
from navd.geometry import Pose2, ScanPoints, scan_points
from navd.offline.fine_map import (
    REFINE_YAW_RAD,
    THIN_CELL_M,
    FineMap,
    fine_keep_cells,
    fine_refiner,
    refine_pose,
)
from navd.offline.refinement import FineRefinement
from navd.slam import (
    Keyframe,
    LikelihoodField,
    MapperSettings,
    OccupancyGrid,
    ScanMapper,
    voxel_downsample,
)

SETTINGS = MapperSettings.defaults()
FINE_M = SETTINGS.resolution_m / 2  # a replay's fine cell by default


def _scan(pose: Pose2, walls: np.ndarray = WALLS) -> ScanPoints:
    angle_min, increment, ranges = cast(pose, beams=720, walls=walls)
    return scan_points(ranges, angle_min, increment, range_min=0.1, range_max=12.0)


def _keyframes(poses: list[Pose2]) -> list[Keyframe]:
    return [Keyframe(float(i), p, _scan(p)) for i, p in enumerate(poses)]


def test_half_the_map_s_cell_keeps_one_fine_cell_short_of_a_hit() -> None:
    assert fine_keep_cells(0.05, 0.025) == 1
    assert fine_keep_cells(0.05, 0.05) == 0
    assert fine_keep_cells(0.05, 0.0125) == 3
    assert ScanMapper(SETTINGS).fine is None  # the daemon's mapper is given none


def test_the_retired_config_key_names_where_it_went() -> None:
    with pytest.raises(ConfigError, match=r"slam.match_resolution_m: .*navd replay --fine-res"):
        parse_config({"slam": {"match_resolution_m": 0.025}})


def test_a_position_refined_on_the_fine_map_is_nearer_than_on_the_map() -> None:
    # A scan drawn with two others into a grid, then placed up to 2.5 cm off its pose and
    # refined: on 2.5 cm cells it comes back nearer its pose than on 5 cm cells.
    rng = np.random.default_rng(3)
    errors: dict[float, list[float]] = {0.05: [], 0.025: []}
    for _ in range(20):
        x, y = rng.uniform(-1.0, 1.0, 2)
        truth = Pose2(float(x), float(y), float(rng.uniform(-0.5, 0.5)))
        off = rng.uniform(-0.025, 0.025, 2)
        start = Pose2(truth.x + off[0], truth.y + off[1], truth.yaw)
        points = voxel_downsample(_scan(truth).hits, SETTINGS.voxel_size_m)
        for cell, keep in ((0.05, 0), (0.025, 1)):
            grid = OccupancyGrid(cell, keep_cells=keep)
            for dx, dy, dyaw in ((0.0, 0.0, 0.0), (0.4, 0.2, 0.3), (-0.3, -0.4, -0.2)):
                p = Pose2(truth.x + dx, truth.y + dy, truth.yaw + dyaw)
                grid.insert(p, _scan(p))
            field = grid.likelihood_field(start, 12.0, SETTINGS.blur_sigma_m)
            refined = refine_pose(fine_refiner(SETTINGS), field, points, start)
            assert abs(refined.yaw - start.yaw) <= REFINE_YAW_RAD + 1e-9
            errors[cell].append(math.hypot(refined.x - truth.x, refined.y - truth.y))
    assert np.mean(errors[0.025]) < 0.015
    assert np.mean(errors[0.025]) < 0.6 * np.mean(errors[0.05])


def test_the_refinement_moves_no_farther_than_a_map_cell() -> None:
    truth = Pose2(0.0, 0.0, 0.0)
    fine = OccupancyGrid(FINE_M)
    fine.insert(truth, _scan(truth))
    points = voxel_downsample(_scan(truth).hits, SETTINGS.voxel_size_m)
    start = Pose2(0.15, 0.0, 0.0)  # three map cells off
    field = fine.likelihood_field(start, 12.0, SETTINGS.blur_sigma_m)
    refined = refine_pose(fine_refiner(SETTINGS), field, points, start)
    # one map cell, and the parabola's half cell of the fine map at most
    assert abs(refined.x - start.x) <= SETTINGS.resolution_m + FINE_M
    assert refined.x < start.x  # toward the truth


def test_a_fine_map_draws_the_keyframes_near_the_window_only() -> None:
    near = [Pose2(0.6 * i, 0.0, 0.0) for i in range(3)]  # each in a place of its own
    far = Pose2(200.0, 0.0, 0.0)  # its scan cannot reach the window
    frames = _keyframes([*near, far])
    fine = FineMap(0.025, 6.0, 1)
    fine.field(frames, Pose2(0.0, 0.0, 0.0), 5.0, 0.05)
    want = OccupancyGrid(0.025, keep_cells=1)
    for p in near:
        want.insert(p, _scan(p))
    np.testing.assert_array_equal(fine.grid.to_array(), want.to_array())
    assert fine.grid.shape == want.shape  # the far keyframe grew nothing


def test_a_fine_map_grown_past_its_budget_is_drawn_anew_with_what_is_near() -> None:
    frames = _keyframes([Pose2(0.0, 0.0, 0.0), Pose2(60.0, 0.0, 0.0)])
    fine = FineMap(0.025, 6.0, 1, max_tiles=10)
    fine.field(frames[:1], Pose2(0.0, 0.0, 0.0), 5.0, 0.05)
    assert fine.grid.cells_store.used[0] > 10
    fine.field(frames, Pose2(60.0, 0.0, 0.0), 5.0, 0.05)
    assert fine.redraws == 1
    want = OccupancyGrid(0.025, keep_cells=1)
    want.insert(frames[1].pose, frames[1].scan)  # type: ignore[arg-type]
    assert fine.grid.stored_bytes == want.stored_bytes  # the first keyframe's tiles gone
    # back at the first: drawn again (and the second dropped)
    fine.field(frames, Pose2(0.0, 0.0, 0.0), 5.0, 0.05)
    assert fine.redraws == 2


def test_a_cleared_fine_map_is_drawn_again_at_the_keyframes_new_poses() -> None:
    frames = _keyframes([Pose2(0.0, 0.0, 0.0)])
    fine = FineMap(0.025, 6.0, 1)
    first = fine.field(frames, Pose2(0.0, 0.0, 0.0), 5.0, 0.05).values.copy()
    moved = [Keyframe(0.0, Pose2(0.3, 0.0, 0.0), frames[0].scan)]  # as a re-solve moves it
    fine.clear()
    again = fine.field(moved, Pose2(0.0, 0.0, 0.0), 5.0, 0.05)
    want = OccupancyGrid(0.025, keep_cells=1)
    want.insert(moved[0].pose, frames[0].scan)  # type: ignore[arg-type]
    np.testing.assert_array_equal(
        again.values, want.likelihood_field(Pose2(0.0, 0.0, 0.0), 5.0, 0.05).values
    )
    assert not np.array_equal(again.values, first)


def test_the_refined_pose_is_reported_and_tracking_goes_on_from_the_match() -> None:
    # The same 40 scans (a robot driving through the bench room, ranges noisy) through a
    # mapper with the fine map and one without: the tracked poses and the keyframes are the
    # same to the bit; the reported poses differ by less than a map cell and a refinement's
    # turn, and are the trajectory the mapper keeps.
    rng = np.random.default_rng(7)
    replay = dataclasses.replace(SETTINGS, keep_trajectory=True)
    with_fine = ScanMapper(replay, fine=FineRefinement.of(replay, FINE_M))
    without = ScanMapper(replay)
    reported, tracked = [], []
    for i in range(40):
        truth = Pose2(-2.0 + 0.1 * i, -1.0 + 0.03 * i, 0.02 * i)
        angle_min, increment, ranges = cast(truth, beams=720)
        ranges = ranges + rng.normal(0.0, 0.01, ranges.size)
        scan = scan_points(ranges, angle_min, increment, range_min=0.1, range_max=12.0)
        odom = Pose2(truth.x + 0.01 * i, truth.y, truth.yaw)  # wheels 10 % long
        a = with_fine.add(float(i), scan, odom)
        b = without.add(float(i), scan, odom)
        assert with_fine.pose == without.pose == b.pose
        reported.append(a.pose)
        tracked.append(b.pose)
    assert [k.pose for k in with_fine.keyframes] == [k.pose for k in without.keyframes]
    moved = [p.between(r) for p, r in zip(tracked, reported, strict=True)]
    assert max(math.hypot(m.x, m.y) for m in moved) <= 1.5 * SETTINGS.resolution_m
    assert max(abs(m.yaw) for m in moved) <= REFINE_YAW_RAD + 1e-9
    assert sum(math.hypot(m.x, m.y) > 1e-6 for m in moved) >= 20  # refined, mostly
    np.testing.assert_allclose(
        [tuple(p) for p in with_fine.trajectory()], [tuple(p) for p in reported], atol=1e-9
    )


def _occupied(grid: OccupancyGrid) -> set[tuple[int, int]]:
    """The occupied cells of a grid, as (col, row) of the world's lattice of its cells."""
    res = grid.resolution
    rows, cols = np.nonzero(grid.to_array() > 0.0)
    c0, r0 = round(grid.origin_x / res), round(grid.origin_y / res)
    return set(zip((cols + c0).tolist(), (rows + r0).tolist(), strict=True))


def test_a_field_brought_up_to_date_is_the_field_drawn_anew_but_near_cells_freed() -> None:
    # A keyframe drawn after the field: its hits stamped in give the field a redraw gives,
    # except within the kernel's reach of a cell the new keyframe freed (still stamped
    # there until the field is drawn anew).
    # The first keyframe sees a person (a short wall) who has gone when the others look.
    person = np.array([(0.6, -1.0, 0.9, -1.0)])
    first_pose = Pose2(0.0, 0.0, 0.0)
    frames = [Keyframe(0.0, first_pose, _scan(first_pose, np.vstack([WALLS, person])))]
    for i, p in enumerate((Pose2(0.75, -0.6, 0.5), Pose2(0.7, -1.5, 2.0)), start=1):
        frames.append(Keyframe(float(i), p, _scan(p)))
    center = Pose2(0.2, 0.1, 0.0)
    fine = FineMap(0.025, 6.0, 1)
    before = fine.field(frames[:1], center, 5.0, 0.05)
    first = before.values.copy()
    occupied_before = _occupied(fine.grid)
    fine.add(frames[:2])
    fine.add(frames)
    updated = fine.update(frames, center, before, 0.05)

    want_grid = OccupancyGrid(0.025, keep_cells=1)
    for f in frames:
        want_grid.insert(f.pose, f.scan)  # type: ignore[arg-type]
    np.testing.assert_array_equal(fine.grid.to_array(), want_grid.to_array())
    want = want_grid.likelihood_field(center, 5.0, 0.05)
    assert (updated.origin_x, updated.origin_y) == (want.origin_x, want.origin_y)
    assert not np.array_equal(updated.values, first)  # the new walls are in

    near_freed = _near(occupied_before - _occupied(want_grid), want)
    assert 0 < near_freed.mean() < 0.05
    np.testing.assert_array_equal(updated.values[~near_freed], want.values[~near_freed])
    assert (updated.values >= want.values).all()


def _near(cells: set[tuple[int, int]], field: LikelihoodField, reach: int = 4) -> np.ndarray:
    """Which cells of ``field`` lie within ``reach`` cells (the kernel's half-width at
    2.5 cm and a 5 cm blur) of any of ``cells`` ((col, row) of the world's lattice)."""
    res = field.resolution
    near = np.zeros(field.values.shape, dtype=bool)
    c0, r0 = round(field.origin_x / res), round(field.origin_y / res)
    for col, row in cells:
        r, c = row - r0, col - c0
        near[max(r - reach, 0) : r + reach + 1, max(c - reach, 0) : c + reach + 1] = True
    return near


def test_an_update_after_the_grid_grew_and_a_keyframe_came_into_reach_is_the_redraw() -> None:
    # The second keyframe lies beyond the fine map's reach of the first field's centre and
    # sees through a door opened in the west wall down a corridor 7 m long (the grid grows
    # west: its origin moves); the update is asked from nearer it, so it is drawn then, and
    # stamped where its hits are.
    west = np.flatnonzero((WALLS[:, 0] == -6) & (WALLS[:, 2] == -6))
    door = np.array(
        [(-6, -4, -6, -1), (-6, 1, -6, 4), (-6, -1, -13, -1), (-6, 1, -13, 1), (-13, -1, -13, 1)]
    )
    far_wall = np.vstack([np.delete(WALLS, west, axis=0), door])
    a, b = Pose2(2.0, -2.0, 0.0), Pose2(-5.5, 0.0, 0.0)
    frames = [Keyframe(0.0, a, _scan(a)), Keyframe(1.0, b, _scan(b, far_wall))]
    fine = FineMap(0.025, 5.0, 1)
    center = Pose2(0.0, -1.0, 0.0)  # b 5.6 m off
    before = fine.field(frames, center, 14.0, 0.05)
    first = before.values.copy()
    origin = (fine.grid.origin_x, fine.grid.origin_y)
    assert fine.update(frames, center, before, 0.05) is before  # b is out of reach
    occupied_before = _occupied(fine.grid)
    updated = fine.update(frames, Pose2(-1.0, 0.0, 0.0), before, 0.05)  # b 4.5 m off
    assert fine.grid.origin_x < origin[0]
    want_grid = OccupancyGrid(0.025, keep_cells=1)
    for f in frames:
        want_grid.insert(f.pose, f.scan)  # type: ignore[arg-type]
    want = want_grid.likelihood_field(center, 14.0, 0.05)
    assert (updated.origin_x, updated.origin_y) == (want.origin_x, want.origin_y)
    assert not np.array_equal(updated.values, first)  # b's walls are in
    near_freed = _near(occupied_before - _occupied(want_grid), want)
    assert near_freed.mean() < 0.05
    np.testing.assert_array_equal(updated.values[~near_freed], want.values[~near_freed])
    assert (updated.values >= want.values).all()


def test_a_field_with_nothing_drawn_since_is_kept() -> None:
    frames = _keyframes([Pose2(0.0, 0.0, 0.0)])
    fine = FineMap(0.025, 6.0, 1)
    field = fine.field(frames, Pose2(0.0, 0.0, 0.0), 5.0, 0.05)
    assert fine.update(frames, Pose2(0.0, 0.0, 0.0), field, 0.05) is field


def test_a_map_drawn_anew_draws_the_newest_keyframe_of_each_place() -> None:
    # Three passes by the same place (within THIN_CELL_M, the same heading), one by it the
    # other way round and one elsewhere: drawn anew, the map holds the newest of the three,
    # the one turned round and the one elsewhere, drawn in the order they were made.
    same = [Pose2(0.05 + 0.1 * i, 0.05, 0.1) for i in range(3)]
    assert all(p.x < THIN_CELL_M for p in same)
    turned = Pose2(0.1, 0.1, 0.1 + math.pi)
    elsewhere = Pose2(2.2, 0.0, 0.1)
    frames = _keyframes([same[0], turned, same[1], elsewhere, same[2]])
    fine = FineMap(0.025, 6.0, 1)
    fine.clear()  # as after a re-solve
    fine.field(frames, Pose2(0.0, 0.0, 0.0), 5.0, 0.05)
    want = OccupancyGrid(0.025, keep_cells=1)
    for i in (1, 3, 4):
        want.insert(frames[i].pose, frames[i].scan)  # type: ignore[arg-type]
    np.testing.assert_array_equal(fine.grid.to_array(), want.to_array())
    # the skipped ones stay skipped while the map stands: an update draws nothing
    field = fine.field(frames, Pose2(0.0, 0.0, 0.0), 5.0, 0.05)
    assert fine.update(frames, Pose2(0.0, 0.0, 0.0), field, 0.05) is field

"""Scan odometry's kernels against plain references: the thinning against the SLAM voxel
filter, the nearest map point against a search over every point, the map table through
inserts, drops and rehashes, and the yaw search and ICP on a known offset."""

from __future__ import annotations

import math

import numpy as np

from navd.slam import _odometry_kernels as kernels
from navd.slam.voxel import voxel_downsample

VOXEL_M = 0.1


def _table(slots: int = 1024) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    keys = np.full(slots, kernels.EMPTY, dtype=np.int64)
    return keys, np.zeros((slots, kernels.MAX_POINTS, 2)), np.zeros(slots, dtype=np.int64)


def _map_points(keys: np.ndarray, points: np.ndarray, counts: np.ndarray) -> np.ndarray:
    live = np.flatnonzero(keys > kernels.TOMBSTONE)
    return np.concatenate([points[s, : counts[s]] for s in live]) if live.size else np.zeros((0, 2))


def _room(n: int = 400) -> np.ndarray:
    """Points on the walls of a 6 x 4 m room with a pillar, centred on the origin [m]."""
    t = np.linspace(0.0, 1.0, n // 4, endpoint=False)
    walls = [
        np.c_[-3 + 6 * t, np.full_like(t, -2.0)],
        np.c_[np.full_like(t, 3.0), -2 + 4 * t],
        np.c_[3 - 6 * t, np.full_like(t, 2.0)],
        np.c_[np.full_like(t, -3.0), 2 - 4 * t],
    ]
    angles = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    pillar = np.c_[1.0 + 0.3 * np.cos(angles), 0.5 + 0.3 * np.sin(angles)]
    return np.concatenate([*walls, pillar])


def _seen_from(points: np.ndarray, pose: tuple[float, float, float]) -> np.ndarray:
    """World points as a robot at ``pose`` sees them (its frame)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    d = points - (x, y)
    return np.c_[c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]]


def _first_of_each_cell(points: np.ndarray, voxel: float) -> np.ndarray:
    """The reference: a stable sort of the cells, the first of each, in scan order."""
    cells = np.floor(points / voxel).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    return points[np.sort(first)]


def test_thinning_keeps_the_first_point_of_each_voxel_in_scan_order() -> None:
    rng = np.random.default_rng(3)
    points = rng.uniform(-5.0, 5.0, (3000, 2))
    for voxel in (0.05, 0.15, 0.7):
        expected = _first_of_each_cell(points, voxel)
        np.testing.assert_array_equal(kernels.thin(points, voxel), expected)
        # The SLAM voxel filter is this kernel, also for a strided view of the points.
        strided = np.repeat(points, 2, axis=0)[::2]
        np.testing.assert_array_equal(voxel_downsample(strided, voxel), expected)
    assert kernels.thin(np.zeros((0, 2)), 0.1).shape == (0, 2)


def test_the_map_table_keeps_every_point_it_took_through_drops_and_rehashes() -> None:
    rng = np.random.default_rng(4)
    keys, points, counts = _table(1024)  # some 300 voxels: probes run past others
    scan = rng.uniform(-4.0, 4.0, (300, 2))
    added = kernels.insert_points(keys, points, counts, VOXEL_M, scan, np.zeros(3), 0.0)
    cells = {tuple(c) for c in np.floor(scan / VOXEL_M).astype(int)}
    assert added == len(cells) == np.count_nonzero(keys > kernels.TOMBSTONE)
    # Every point is in the table, in its own voxel (spacing 0: none is too close).
    np.testing.assert_array_equal(
        np.sort(_map_points(keys, points, counts), axis=0), np.sort(scan, axis=0)
    )
    # Drop what is beyond 3 m of (1, 0): judged by each voxel's first point.
    dropped = kernels.drop_far(keys, points, 1.0, 0.0, 3.0)
    kept = _map_points(keys, points, counts)
    assert dropped > 0
    assert np.all(np.hypot(kept[:, 0] - 1.0, kept[:, 1]) <= 3.0)
    far = scan[np.hypot(scan[:, 0] - 1.0, scan[:, 1]) > 3.0]
    assert len(kept) + len(far) == len(scan)
    # Lookups go on past the tombstones: every point kept is found, none dropped is.
    for x, y in kept:
        assert kernels.nearest(keys, points, counts, VOXEL_M, x, y, 0.0)[2] == 0.0
    for x, y in far:
        d2 = kernels.nearest(keys, points, counts, VOXEL_M, x, y, 0.0)[2]
        assert d2 != 0.0 or np.any(np.all(kept == (x, y), axis=1))
    # A voxel dropped and seen again is a new voxel, in a free slot: still found once.
    again = far[:5]
    assert kernels.insert_points(keys, points, counts, VOXEL_M, again, np.zeros(3), 0.0) == 5
    for x, y in again:
        assert kernels.nearest(keys, points, counts, VOXEL_M, x, y, 0.0)[2] == 0.0
    kept = np.concatenate([kept, again])
    # A rehash into a smaller table keeps exactly the live voxels, and lookups still work.
    into = _table(512)
    copied = kernels.rehash(keys, points, counts, *into)
    assert copied == np.count_nonzero(keys > kernels.TOMBSTONE)
    assert not np.any(into[0] == kernels.TOMBSTONE)
    np.testing.assert_array_equal(np.sort(_map_points(*into), axis=0), np.sort(kept, axis=0))
    for x, y in kept[:20]:
        qx, qy, d2 = kernels.nearest(*into, VOXEL_M, x, y, 0.05)
        assert (qx, qy, d2) == (x, y, 0.0)


def test_a_voxel_takes_no_point_closer_than_the_spacing_and_no_more_than_it_holds() -> None:
    keys, points, counts = _table()
    crowd = np.c_[0.05 + 0.004 * np.arange(25), np.full(25, 0.05)] % 0.1  # one voxel
    kernels.insert_points(keys, points, counts, VOXEL_M, crowd, np.zeros(3), 0.01)
    kept = _map_points(keys, points, counts)
    gaps = np.hypot(*(kept[:, None, :] - kept[None, :, :]).transpose(2, 0, 1))
    assert np.all(gaps[~np.eye(len(kept), dtype=bool)] >= 0.01)
    keys, points, counts = _table()
    many = np.c_[np.linspace(0.001, 0.099, 60), np.full(60, 0.05)]
    kernels.insert_points(keys, points, counts, VOXEL_M, many, np.zeros(3), 0.0)
    assert counts.max() == kernels.MAX_POINTS


def test_nearest_is_the_closest_map_point_in_the_voxels_around_within_the_gate() -> None:
    rng = np.random.default_rng(5)
    keys, points, counts = _table(4096)
    cloud = rng.uniform(-2.0, 2.0, (1500, 2))
    kernels.insert_points(keys, points, counts, VOXEL_M, cloud, np.zeros(3), 0.0)
    stored = _map_points(keys, points, counts)
    stored_cells = np.floor(stored / VOXEL_M).astype(int)
    for x, y in rng.uniform(-2.2, 2.2, (300, 2)):
        qx, qy, d2 = kernels.nearest(keys, points, counts, VOXEL_M, x, y, 0.12)
        cell = np.floor(np.array([x, y]) / VOXEL_M).astype(int)
        around = np.all(np.abs(stored_cells - cell) <= 1, axis=1)
        dist2 = np.sum((stored[around] - (x, y)) ** 2, axis=1)
        dist2 = dist2[dist2 <= 0.12**2]
        if dist2.size == 0:
            assert d2 == math.inf
        else:
            assert d2 == dist2.min()
            assert (qx - x) ** 2 + (qy - y) ** 2 == d2


def _room_map() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    table = _table(4096)
    kernels.insert_points(*table, VOXEL_M, kernels.thin(_room(), 0.05), np.zeros(3), 0.02)
    return table


def test_the_yaw_search_finds_a_turn_the_guess_missed() -> None:
    table = _room_map()
    truth = (0.3, -0.2, math.radians(11.0))
    source = kernels.thin(_seen_from(_room(), truth), 0.15)
    guess = np.array([0.3, -0.2, 0.0])  # the turn missed entirely
    coarse = kernels.best_yaw(source, *table, VOXEL_M, guess, math.radians(15), 0.026, False)
    fine = kernels.best_yaw(
        source, *table, VOXEL_M, np.array([0.3, -0.2, coarse]), 0.026, 0.0087, True
    )
    assert abs(coarse - truth[2]) <= 0.026
    assert abs(fine - truth[2]) <= 0.0087
    # Without a better yaw in reach, the guess's own is kept.
    right = np.array(truth)
    assert kernels.best_yaw(source, *table, VOXEL_M, right, 0.05, 0.01, True) == right[2]


def test_icp_lands_a_displaced_scan_on_the_map() -> None:
    table = _room_map()
    truth = (0.4, 0.25, math.radians(-4.0))
    source = kernels.thin(_seen_from(_room(), truth), 0.15)
    guess = np.array([0.35, 0.31, math.radians(-3.0)])  # 8 cm and 1 degree off
    pose, iterations, pairs = kernels.align(source, *table, VOXEL_M, guess, 0.3, 0.1, 100, 1e-6)
    assert np.hypot(pose[0] - truth[0], pose[1] - truth[1]) < 0.005
    assert abs(pose[2] - truth[2]) < math.radians(0.2)
    assert 1 < iterations < 100
    assert pairs > 0.9 * len(source)


def test_icp_returns_the_guess_when_there_is_nothing_to_align_to() -> None:
    empty = _table()
    guess = np.array([1.0, 2.0, 0.5])
    pose, _, pairs = kernels.align(_room(), *empty, VOXEL_M, guess, 0.3, 0.1, 100, 1e-6)
    assert pairs == 0
    np.testing.assert_array_equal(pose, guess)

"""Scan odometry on the synthetic room: a drive, a turn the constant-velocity guess misses,
the local map's forgetting, and the input guards."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2, scan_points
from navd.slam import _odometry_kernels as kernels
from navd.slam import odometry as odometry_module
from navd.slam.odometry import ScanOdometry, ScanOdometrySettings


def _odometry() -> ScanOdometry:
    return ScanOdometry(ScanOdometrySettings(voxel_size_m=0.1, max_range_m=12.0, min_range_m=0.1))


def test_scan_odometry_follows_a_drive_without_wheels() -> None:
    odometry = _odometry()
    start = Pose2(-4.0, -1.0, 0.3)
    for i in range(60):
        truth = start.compose(Pose2(0.05 * i, 0.0, 0.01 * i))
        a0, inc, r = cast(truth)
        pose = odometry.register(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits)
    moved = start.between(truth)  # 3 m and 34 degrees
    assert math.hypot(pose.x - moved.x, pose.y - moved.y) < 0.05
    assert abs(pose.yaw - moved.yaw) < math.radians(1.0)


def test_bad_input_is_refused_or_skipped_never_a_crash() -> None:
    odometry = _odometry()
    with pytest.raises(ValueError, match=r"points must be N x 2, got shape \(5, 3\)"):
        odometry.register(np.zeros((5, 3)))
    # Too few points (or none, or NaN) cannot be registered: the pose holds.
    assert odometry.register(np.zeros((0, 2))) == Pose2(0.0, 0.0, 0.0)
    assert odometry.register(np.full((50, 2), np.nan)) == Pose2(0.0, 0.0, 0.0)
    assert odometry.skipped == 2


def _drive(odometry: ScanOdometry, steps: list[Pose2]) -> tuple[Pose2, Pose2]:
    """Register the room's scans along ``steps`` (each relative to the last); the estimate
    and the truth, both relative to the start."""
    start = truth = Pose2(-3.5, -1.0, 0.2)
    pose = odometry.register(_scan(start))
    for step in steps:
        truth = truth.compose(step)
        pose = odometry.register(_scan(truth))
    return pose, start.between(truth)


def _scan(pose: Pose2) -> np.ndarray:
    a0, inc, r = cast(pose)
    return scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits


def test_a_turn_started_between_two_scans_is_followed(monkeypatch: pytest.MonkeyPatch) -> None:
    # Straight at 5 cm a scan, then turning on the spot at 12 degrees a scan: the first scan
    # of the turn is 12 degrees off the constant-velocity guess, too far for ICP alone.
    steps = [Pose2(0.05, 0.0, 0.0)] * 20 + [Pose2(0.0, 0.0, math.radians(12.0))] * 15
    pose, moved = _drive(_odometry(), steps)
    assert math.hypot(pose.x - moved.x, pose.y - moved.y) < 0.05
    assert abs(pose.yaw - moved.yaw) < math.radians(1.0)
    # The yaw search is what follows it: without it the turn is lost.
    monkeypatch.setattr(odometry_module, "YAW_SPAN_RAD", 0.0)
    pose, moved = _drive(_odometry(), steps)
    assert abs(pose.yaw - moved.yaw) > math.radians(5.0)


def _lapping(odometry: ScanOdometry) -> tuple[Pose2, Pose2]:
    """Back and forth along the room, 5 m each way, 8 times (40 m, 8 half turns)."""
    leg = [Pose2(0.05, 0.0, 0.0)] * 100 + [Pose2(0.0, 0.0, math.radians(7.5))] * 24
    return _drive(odometry, leg * 8)


def _forgetful() -> ScanOdometry:
    """Odometry that sees 6 m: the room's far end (12 m long) drops out of its map."""
    return ScanOdometry(ScanOdometrySettings(voxel_size_m=0.1, max_range_m=6.0, min_range_m=0.1))


def _table_is_consistent(odometry: ScanOdometry) -> None:
    keys = odometry._keys
    assert odometry._filled == np.count_nonzero(keys != kernels.EMPTY)
    assert 2 * odometry._filled <= keys.shape[0]


def test_the_map_forgets_what_is_out_of_range_and_keeps_tracking() -> None:
    odometry = _forgetful()
    pose, moved = _lapping(odometry)
    assert math.hypot(pose.x - moved.x, pose.y - moved.y) < 0.1
    assert abs(pose.yaw - moved.yaw) < math.radians(1.0)
    live = odometry._keys > kernels.TOMBSTONE
    assert 0 < np.count_nonzero(live) == odometry.voxels
    # Every voxel left has its first point within range of where the robot ended.
    first = odometry._points[live, 0]
    assert np.all(np.hypot(*(first - (pose.x, pose.y)).T) <= 6.0)
    _table_is_consistent(odometry)


def test_a_table_that_fills_up_is_compacted_and_grown_without_changing_a_pose(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    roomy = _forgetful()
    expected = _lapping(roomy)
    # A small first table: it fills with voxels and the dropped ones' tombstones, so it is
    # compacted (and grown) along the way; lookups through tombstones must hold meanwhile.
    monkeypatch.setattr(odometry_module, "INITIAL_SLOTS", 256)
    cramped = _forgetful()
    compactions = 0
    original = cramped.compact

    def counted(incoming: int = 0) -> None:
        nonlocal compactions
        compactions += 1
        _table_is_consistent(cramped)
        original(incoming)
        _table_is_consistent(cramped)

    monkeypatch.setattr(cramped, "compact", counted)
    assert _lapping(cramped) == expected
    assert compactions >= 3
    _table_is_consistent(cramped)

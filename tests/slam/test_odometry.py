"""Scan odometry with kiss-icp on the synthetic room, and its input guards."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.bench.room import cast
from navd.geometry.pose import Pose2
from navd.geometry.scan import scan_points
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

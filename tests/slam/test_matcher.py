"""Correlative matching: finds known offsets, and branch and bound equals the exhaustive search."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.bench.room import cast
from navd.slam import _grid_kernels as k
from navd.slam.matcher import CorrelativeMatcher
from navd.slam.occupancy import OccupancyGrid
from navd.slam.pose import Pose2
from navd.slam.scan import scan_points, voxel_downsample


def _room_grid() -> OccupancyGrid:
    grid = OccupancyGrid(0.05)
    for pose in (Pose2(0, 0, 0), Pose2(-3, -1, 1.0), Pose2(4, 2.5, -2.0)):
        a0, inc, r = cast(pose)
        grid.insert(pose, scan_points(r, a0, inc, range_min=0.1, range_max=30.0))
    return grid


GRID = _room_grid()
FIELD = GRID.likelihood_field(Pose2(0, 0, 0), 12.0, 0.05)


@pytest.mark.parametrize(
    "truth",
    [
        Pose2(0.12, -0.08, 0.05),
        Pose2(-0.2, 0.25, -0.2),
        Pose2(0.01, 0.02, 0.0),
        Pose2(1.0, -1.5, 0.3),
    ],
)
def test_the_true_pose_is_found_within_a_cell_and_a_degree(truth: Pose2) -> None:
    prior = Pose2(truth.x - 0.15, truth.y + 0.1, truth.yaw - 0.1)  # inside the window
    a0, inc, r = cast(truth)
    points = voxel_downsample(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits, 0.1)
    match = CorrelativeMatcher(search_xy_m=0.3, search_yaw_rad=0.35).match(FIELD, points, prior)
    assert math.hypot(match.pose.x - truth.x, match.pose.y - truth.y) < 0.05
    assert abs(math.remainder(match.pose.yaw - truth.yaw, 2 * math.pi)) < math.radians(1.0)
    assert match.score > 0.8
    assert np.all(np.diag(match.covariance) > 0)


def test_branch_and_bound_returns_the_exhaustive_optimum() -> None:
    truth = Pose2(0.17, -0.11, 0.12)
    a0, inc, r = cast(truth)
    points = voxel_downsample(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits, 0.1)
    matcher = CorrelativeMatcher(search_xy_m=0.3, search_yaw_rad=0.2, angle_step_rad=0.01)
    match = matcher.match(FIELD, points, Pose2(0, 0, 0))
    res = FIELD.resolution
    px, py = points[:, 0] / res, points[:, 1] / res
    tx, ty = -FIELD.origin_x / res - 0.5, -FIELD.origin_y / res - 0.5
    best = -1.0
    for angle in 0.01 * np.arange(-20, 21):
        scores = k.fine_scores(
            FIELD.values, px, py, np.cos(angle), np.sin(angle), tx, ty, -6, -6, 13, 13
        )
        best = max(best, float(scores.max()))
    assert match.score * points.shape[0] == pytest.approx(best, rel=1e-5)
    # Far fewer blocks than the 9 blocks x 41 rotations of an exhaustive search.
    assert match.blocks < 9 * 41 / 4


def test_a_prior_outside_the_window_is_not_reached() -> None:
    truth = Pose2(0.9, 0.0, 0.0)
    a0, inc, r = cast(truth)
    points = voxel_downsample(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits, 0.1)
    match = CorrelativeMatcher(search_xy_m=0.3, search_yaw_rad=0.1).match(
        FIELD, points, Pose2(0, 0, 0)
    )
    assert abs(match.pose.x) <= 0.3 + 0.05
    assert match.score < 0.8

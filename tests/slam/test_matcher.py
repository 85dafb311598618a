"""Correlative matching: finds known offsets, branch and bound equals the exhaustive search
(with and without a motion prior), and ambiguous matches are told apart."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import pytest

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2, scan_points
from navd.slam import _grid_kernels as k
from navd.slam.likelihood_field import LikelihoodField
from navd.slam.matcher import CorrelativeMatcher, rival_ratio
from navd.slam.occupancy import OccupancyGrid
from navd.slam.settings import MapperSettings
from navd.slam.voxel import voxel_downsample


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


def test_with_a_prior_weight_branch_and_bound_returns_the_exhaustive_optimum() -> None:
    truth = Pose2(0.17, -0.11, 0.12)
    a0, inc, r = cast(truth)
    points = voxel_downsample(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits, 0.1)
    w_xy, w_yaw = 40.0, 20.0  # strong enough to move the optimum off the truth
    matcher = CorrelativeMatcher(
        search_xy_m=0.3,
        search_yaw_rad=0.2,
        angle_step_rad=0.01,
        prior_weight_per_m2=w_xy,
        prior_weight_per_rad2=w_yaw,
    )
    match = matcher.match(FIELD, points, Pose2(0, 0, 0))
    res, n = FIELD.resolution, points.shape[0]
    px, py = points[:, 0] / res, points[:, 1] / res
    tx, ty = -FIELD.origin_x / res - 0.5, -FIELD.origin_y / res - 0.5
    offsets = np.arange(-6, 7) * res
    pull = w_xy * (offsets[None, :] ** 2 + offsets[:, None] ** 2)
    best, best_raw, best_pose = -np.inf, 0.0, (0.0, 0.0, 0.0)
    for angle in 0.01 * np.arange(-20, 21):
        raw = k.fine_scores(
            FIELD.values, px, py, np.cos(angle), np.sin(angle), tx, ty, -6, -6, 13, 13
        )
        pulled = raw / n - pull - w_yaw * angle**2
        j, i = np.unravel_index(int(np.argmax(pulled)), pulled.shape)
        if pulled[j, i] > best:
            best, best_raw = float(pulled[j, i]), float(raw[j, i])
            best_pose = (float(offsets[i]), float(offsets[j]), float(angle))
    assert match.score * n == pytest.approx(best_raw, rel=1e-5)
    # The pull moved the optimum towards the prior, away from the truth.
    assert math.hypot(best_pose[0], best_pose[1]) < math.hypot(truth.x, truth.y) - res


def _corridor(y_robot: float) -> tuple[float, float, npt.NDArray[np.float64]]:
    """A scan in an endless corridor along x, walls at y = +-1 m, robot facing +x."""
    angles = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    s = np.sin(angles)
    with np.errstate(divide="ignore"):
        ranges = np.where(s > 0, (1.0 - y_robot) / s, (-1.0 - y_robot) / s)
    ranges[(ranges > 8.0) | ~np.isfinite(ranges)] = np.inf  # well inside the field
    return float(angles[0]), float(angles[1] - angles[0]), ranges


def _corridor_field() -> LikelihoodField:
    grid = OccupancyGrid(0.05)
    for x in (-4.0, 0.0, 4.0):
        a0, inc, r = _corridor(0.0)
        grid.insert(Pose2(x, 0.0, 0.0), scan_points(r, a0, inc, range_min=0.1, range_max=30.0))
    return grid.likelihood_field(Pose2(0, 0, 0), 12.0, 0.05)


CORRIDOR = _corridor_field()


def _corridor_points(y_robot: float) -> npt.NDArray[np.float64]:
    a0, inc, r = _corridor(y_robot)
    return voxel_downsample(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits, 0.1)


def test_in_a_corridor_the_prior_decides_along_it_and_the_walls_across_it() -> None:
    truth = Pose2(0.0, 0.2, 0.0)
    points = _corridor_points(truth.y)
    prior = Pose2(0.37, 0.05, 0.0)  # off along the corridor and across it
    pulled = CorrelativeMatcher(search_xy_m=0.6, search_yaw_rad=0.1, prior_weight_per_m2=0.5).match(
        CORRIDOR, points, prior
    )
    assert abs(pulled.pose.y - truth.y) < 0.05  # the walls fix y
    assert abs(pulled.pose.x - prior.x) < 0.06  # nothing in the scan fixes x: the prior does
    # Without the pull, x is whichever of the equal scores the search met first.
    free = CorrelativeMatcher(search_xy_m=0.6, search_yaw_rad=0.1).match(CORRIDOR, points, prior)
    assert abs(free.pose.x - prior.x) > 0.1


# (at 2.3 rad a pull turned the wrong way, and at 1.5 rad one not turned into the map's frame,
# lies across the corridor: the match slips as without it)
@pytest.mark.parametrize(("heading", "step"), [(0.0, 0.2), (2.3, 0.27), (1.5, 0.27)])
def test_a_step_along_a_corridor_is_kept_by_the_defaults(heading: float, step: float) -> None:
    # The map is the corridor as drawn from -4 .. 0 m along it, every 0.2 m (walls to 8 m);
    # the robot has gone ``step`` further. Moved back toward where the map was drawn from,
    # the scan fits better: its far ends onto wall drawn already, its cells onto those of
    # the same view drawn at 0 m. The corridor runs at ``heading`` in the map, the robot
    # facing along it.
    c, s = math.cos(heading), math.sin(heading)
    grid = OccupancyGrid(0.05)
    a0, inc, r = _corridor(0.0)
    for along in np.arange(-4.0, 0.01, 0.2):
        pose = Pose2(float(along) * c, float(along) * s, heading)
        grid.insert(pose, scan_points(r, a0, inc, range_min=0.1, range_max=30.0))
    truth = Pose2(step * c, step * s, heading)
    field = grid.likelihood_field(truth, 10.0, 0.05)
    points = _corridor_points(0.0)
    settings = MapperSettings.defaults()
    assert settings.prior_axis_weight_per_m2 > 0.0

    def matched(axis_weight: float) -> tuple[float, float]:
        """(along, across) the corridor [m] of the match, the wheels' step right."""
        pose = (
            CorrelativeMatcher(
                search_xy_m=settings.search_xy_m,
                search_yaw_rad=settings.search_yaw_rad,
                prior_weight_per_m2=settings.prior_weight_per_m2,
                prior_axis_weight_per_m2=axis_weight,
                point_spacing_m=settings.voxel_size_m,
            )
            .match(field, points, truth)
            .pose
        )
        return pose.x * c + pose.y * s, -pose.x * s + pose.y * c

    # With the plain pull the match slips back (measured: the whole 0.2 m step at heading
    # 0; 0.073 and 0.052 m of the 0.27 m at 2.3 and 1.5 rad).
    assert matched(0.0)[0] < step - 0.04
    # With the default pull along the corridor (its weak axis) the wheels' step holds.
    along, across = matched(settings.prior_axis_weight_per_m2)
    assert abs(along - step) < 0.02
    assert abs(across) < 0.03


def test_the_pull_along_the_weak_axis_leaves_a_room_match_alone() -> None:
    # In a room the surfaces hold every direction: the extra pull is off, the match the same.
    truth = Pose2(0.12, -0.08, 0.05)
    a0, inc, r = cast(truth)
    points = voxel_downsample(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits, 0.1)
    prior = Pose2(0.0, 0.0, 0.0)

    def matched(axis_weight: float) -> Pose2:
        return (
            CorrelativeMatcher(
                search_xy_m=0.3,
                search_yaw_rad=0.2,
                prior_weight_per_m2=0.5,
                prior_axis_weight_per_m2=axis_weight,
            )
            .match(FIELD, points, prior)
            .pose
        )

    # (the room's surfaces hold the weaker direction 0.96 as much as the stronger)
    assert matched(40.0) == matched(0.0)


def test_a_corridor_match_is_ambiguous_and_a_room_match_is_not() -> None:
    corridor = rival_ratio(
        CORRIDOR, _corridor_points(0.0), Pose2(0, 0, 0), radius_m=1.0, exclude_m=0.3
    )
    assert corridor > 0.95
    truth = Pose2(0.12, -0.08, 0.05)
    a0, inc, r = cast(truth)
    points = voxel_downsample(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits, 0.1)
    match = CorrelativeMatcher(search_xy_m=0.3, search_yaw_rad=0.35).match(FIELD, points, truth)
    room = rival_ratio(FIELD, points, match.pose, radius_m=1.0, exclude_m=0.3)
    assert room < 0.8


@pytest.mark.parametrize(
    ("pose", "radius_m", "exclude_m"),
    [
        (Pose2(0.1, -0.05, 0.05), 1.0, 0.3),
        (Pose2(-2.0, 1.0, 0.8), 2.6, 0.6),
        (Pose2(0, 0, 0), 0.2, 0.1),
    ],
)
def test_rival_ratio_is_the_best_rival_of_the_whole_ring_over_the_pose_s_own_score(
    pose: Pose2, radius_m: float, exclude_m: float
) -> None:
    a0, inc, r = cast(Pose2(0.12, -0.08, 0.05))
    points = voxel_downsample(scan_points(r, a0, inc, range_min=0.1, range_max=30.0).hits, 0.1)
    px, py, tx, ty = FIELD.in_cells(points, pose)
    limit = math.ceil(radius_m / FIELD.resolution)
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    window = k.fine_scores(
        FIELD.values, px, py, c, s, tx, ty, -limit, -limit, 2 * limit + 1, 2 * limit + 1
    )
    offsets = np.arange(-limit, limit + 1) * FIELD.resolution
    distance = np.hypot(offsets[None, :], offsets[:, None])
    ring = window[(distance > exclude_m) & (distance <= radius_m)]
    want = float(ring.max()) / float(window[limit, limit])
    got = rival_ratio(FIELD, points, pose, radius_m=radius_m, exclude_m=exclude_m)
    assert got == want

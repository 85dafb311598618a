"""A scan as points in the robot frame, through the lidar's mount."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.geometry._scan_kernels import split_ranges, split_ranges_numpy
from navd.geometry.mount import LidarMount
from navd.geometry.pose import Pose2
from navd.geometry.scan import laser_points, scan_points
from navd.lifecycle.messages import LaserScan


def test_invalid_ranges_are_dropped_and_no_returns_clear_space() -> None:
    ranges = [1.0, float("nan"), 0.05, 2.0, float("inf"), 30.0, 5.0]
    scan = scan_points(ranges, 0.0, math.pi / 2, range_min=0.1, range_max=30.0, max_range=4.0)
    # Beam 0 at 0 rad and beam 3 at 3pi/2 hit; 5 m (beam 6) is beyond max_range: a miss.
    np.testing.assert_allclose(scan.hits, [[1.0, 0.0], [0.0, -2.0]], atol=1e-12)
    # inf and 30 m (no return) and 5 m clear space up to 4 m; NaN and 0.05 m say nothing.
    assert scan.misses.shape == (3, 2)
    np.testing.assert_allclose(np.linalg.norm(scan.misses, axis=1), 4.0)


def test_the_mount_pose_moves_points_into_the_robot_frame() -> None:
    scan = scan_points(
        [1.0], 0.0, 0.1, range_min=0.1, range_max=10.0, mount=Pose2(0.2, 0.1, math.pi / 2)
    )
    np.testing.assert_allclose(scan.hits, [[0.2, 1.1]], atol=1e-12)


def test_laser_points_use_the_mount_and_its_shortest_range() -> None:
    config = NavdConfig.model_validate(
        {"lidar": {"x_m": 0.1, "yaw_rad": math.pi, "min_range_m": 0.3}}
    )
    mount = LidarMount.of(config.lidar)
    scan = LaserScan(
        stamp=0.0,
        received=0.0,
        device_id="l",
        angle_min=0.0,
        angle_increment=math.pi / 2,
        ranges=np.array([0.25, 1.0, 2.0, 9.0], dtype=np.float32),
        range_min=0.05,
        range_max=10.0,
    )
    points = laser_points(scan, mount, max_range_m=5.0)
    # A lidar facing backwards 0.1 m ahead of base_link: its +y beam points to the robot's
    # right; 0.25 m is the robot itself; 9 m lies beyond the 5 m the caller uses.
    np.testing.assert_allclose(points.hits, [[0.1, -1.0], [2.1, 0.0]], atol=1e-6)
    np.testing.assert_allclose(points.misses, [[0.1, 5.0]], atol=1e-6)


@pytest.mark.parametrize(
    ("angle_min", "increment", "beams", "all_around"),
    [
        (-math.pi, 2 * math.pi / 360, 360, True),  # a 360° lidar
        (-0.75 * math.pi, 1.5 * math.pi / 719, 720, False),  # 270°, counter-clockwise
        (0.75 * math.pi, -1.5 * math.pi / 719, 720, False),  # the same, clockwise
    ],
)
def test_a_scan_knows_the_bearings_its_rays_cover(
    angle_min: float, increment: float, beams: int, all_around: bool
) -> None:
    mount = Pose2(-0.1, 0.0, 0.0)
    points = scan_points(
        np.full(beams, 2.0), angle_min, increment, range_min=0.1, range_max=10.0, mount=mount
    )
    assert points.view.all_around is all_around
    behind = np.array([[-1.0, 0.0]])  # straight behind the lidar
    ahead = np.array([[1.0, 0.5]])
    assert bool(points.view.unseen(behind)[0]) is not all_around
    assert not points.view.unseen(ahead)[0]
    assert not points.view.unseen(points.hits).any()  # every ray's end is in view


def test_an_upside_down_lidar_sees_its_left_on_the_robots_right() -> None:
    scan = LaserScan(
        stamp=0.0,
        received=0.0,
        device_id="l",
        angle_min=0.0,
        angle_increment=math.pi / 2,
        ranges=np.array([1.0, 2.0], dtype=np.float32),  # ahead, then to the lidar's left
        range_min=0.05,
        range_max=10.0,
    )
    upright = laser_points(scan, LidarMount(Pose2(0.0, 0.0, 0.0), 0.1), max_range_m=5.0)
    hanging = laser_points(scan, LidarMount(Pose2(0.0, 0.0, 0.0), 0.1, True), max_range_m=5.0)
    np.testing.assert_allclose(upright.hits, [[1.0, 0.0], [0.0, 2.0]], atol=1e-6)
    np.testing.assert_allclose(hanging.hits, [[1.0, 0.0], [0.0, -2.0]], atol=1e-6)
    # facing backwards too: its left is the robot's left again
    back = LidarMount(Pose2(-0.1, 0.0, math.pi), 0.1, upside_down=True)
    np.testing.assert_allclose(
        laser_points(scan, back, max_range_m=5.0).hits, [[-1.1, 0.0], [-0.1, 2.0]], atol=1e-6
    )


def test_each_beam_lands_where_its_range_and_bearing_put_it_through_the_mount() -> None:
    """Beam by beam against the definition, on ranges with every kind of special value."""
    rng = np.random.default_rng(11)
    ranges = rng.uniform(0.0, 15.0, 720)
    ranges[rng.choice(720, 40, replace=False)] = np.inf
    ranges[rng.choice(720, 40, replace=False)] = np.nan
    ranges[rng.choice(720, 20, replace=False)] = -np.inf
    ranges[:4] = (0.2, 8.0, 12.0, 0.19)  # range_min: a hit; the range used: a hit; ...
    mount = Pose2(0.12, -0.05, 0.4)
    angle_min, step = -math.pi, 2.0 * math.pi / 720
    points = scan_points(
        ranges, angle_min, step, range_min=0.2, range_max=12.0, mount=mount, max_range=8.0
    )
    hits, misses = [], []
    for k, r in enumerate(ranges):
        a = angle_min + step * k
        if r == np.inf or (math.isfinite(r) and (r >= 12.0 or r > 8.0)):
            reach, out = 8.0, misses  # no return, or beyond the range used: clears to 8 m
        elif math.isfinite(r) and r >= 0.2:
            reach, out = float(r), hits
        else:
            continue
        x, y = reach * math.cos(a), reach * math.sin(a)
        c, s = math.cos(mount.yaw), math.sin(mount.yaw)
        out.append((mount.x + c * x - s * y, mount.y + s * x + c * y))
    np.testing.assert_allclose(points.hits, np.array(hits), atol=1e-12)
    np.testing.assert_allclose(points.misses, np.array(misses), atol=1e-12)


@pytest.mark.parametrize(
    ("ranges", "range_min", "range_max", "use_max"),
    [
        ([0.5, 1.0, 2.0], 0.1, 10.0, 10.0),  # all hits
        ([0.1, 10.0, 5.0], 0.1, 10.0, 5.0),  # at range_min, at range_max, at the range used
        ([np.nan, np.inf, -np.inf, -1.0, 0.0, -0.0], 0.1, 10.0, 8.0),  # special values
        ([3.0, 4.0], 5.0, 2.0, 2.0),  # range_min above range_max: nothing is a hit
        (np.linspace(0.0, 20.0, 401), 0.15, 12.0, 6.0),  # a sweep across every boundary
    ],
)
def test_the_kernel_and_its_numpy_twin_give_the_same_points(
    ranges: list[float], range_min: float, range_max: float, use_max: float
) -> None:
    r = np.asarray(ranges, dtype=np.float64)
    args = (r, -1.0, 0.01, range_min, range_max, use_max, 0.3, -0.2, 0.7)
    for got, want in zip(split_ranges(*args), split_ranges_numpy(*args), strict=True):
        assert got.shape == want.shape
        np.testing.assert_allclose(got, want, atol=1e-12)


def test_float32_and_strided_ranges_read_as_their_values() -> None:
    values = np.array([1.0, 9.0, 2.5, 9.0, 4.0, 9.0], dtype=np.float32)
    strided = values[::2]  # 1.0, 2.5, 4.0: a view with a stride of two
    points = scan_points(strided, 0.0, 0.5, range_min=0.1, range_max=8.0)
    expected = scan_points([1.0, 2.5, 4.0], 0.0, 0.5, range_min=0.1, range_max=8.0)
    np.testing.assert_array_equal(points.hits, expected.hits)
    assert points.hits.shape == (3, 2) and points.misses.shape == (0, 2)

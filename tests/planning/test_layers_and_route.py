"""The planner's layers (frames that grow, maps on another lattice) and route following."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.geometry import ALL_AROUND, IDENTITY, FieldOfView, Pose2
from navd.planning.errors import GoalRefusedError
from navd.planning.layers import FRAME_MARGIN_M, Layers
from navd.planning.route import Route
from navd.planning.settings import layer_settings


def test_the_snapshot_frame_holds_the_map_the_robot_and_the_goal() -> None:
    layers = Layers(layer_settings(NavdConfig().planning))
    occupancy = np.zeros((40, 60), np.int8)
    occupancy[10, 10] = 100
    layers.set_map(occupancy, 0.05, -1.0, -1.0)
    frame, obstacles, unknown = layers.snapshot(0.0, [(0.0, 0.0), (8.0, 0.5)])
    assert frame.origin_x_m <= -1.0 and frame.origin_y_m <= -1.0 - 0.0
    assert frame.origin_x_m + frame.cols * 0.05 >= 8.0 + FRAME_MARGIN_M - 1e-9
    # The map's cells keep their place on the lattice.
    assert obstacles[frame.cell_of(-1.0 + 10.5 * 0.05, -1.0 + 10.5 * 0.05)]
    assert obstacles.sum() == 1
    assert not unknown[frame.cell_of(0.0, 0.0)] and unknown[frame.cell_of(7.0, 0.0)]


def test_scan_marks_survive_a_growing_map_and_a_new_lattice_starts_afresh() -> None:
    layers = Layers(layer_settings(NavdConfig().planning))
    layers.snapshot(0.0, [(0.0, 0.0)])  # the obstacle layer exists before any map
    layers.add_scan(IDENTITY, np.array([[1.0, 0.0]]), np.empty((0, 2)), 0.0)
    frame, obstacles, _ = layers.snapshot(0.1, [(0.0, 0.0), (5.0, 0.0)])
    assert obstacles[frame.cell_of(1.0, 0.0)]
    # A map whose cells are offset by half a cell from the marks' lattice.
    layers.set_map(np.zeros((20, 20), np.int8), 0.05, -0.525, -0.525)
    frame, obstacles, _ = layers.snapshot(0.2, [(0.0, 0.0)])
    assert not obstacles.any()  # the marks were dropped, not misplaced
    assert math.isclose((frame.origin_x_m + 0.525) / 0.05, round((frame.origin_x_m + 0.525) / 0.05))


def test_what_a_270_degree_lidar_saw_stays_an_obstacle_in_its_blind_sector() -> None:
    ahead = FieldOfView(0.0, 0.0, -0.75 * math.pi, 1.5 * math.pi)  # blind behind the robot
    layers = Layers(layer_settings(NavdConfig().planning))  # persistence 2 s
    layers.snapshot(0.0, [(0.0, 0.0)])
    layers.add_scan(IDENTITY, np.array([[1.0, 0.0]]), np.empty((0, 2)), 0.0, ahead)
    # the robot turned round: the obstacle is behind it now, where its lidar cannot see
    turned = Pose2(0.0, 0.0, math.pi)
    layers.add_scan(turned, np.empty((0, 2)), np.empty((0, 2)), 0.5, ahead)
    assert layers.scan_points.shape[0] == 0
    near = layers.local_points(turned, 2.0, now=1.0)
    assert near.shape[0] > 0 and np.min(np.hypot(near[:, 0] - 1.0, near[:, 1])) < 0.05
    assert layers.local_points(turned, 2.0, now=2.5).shape[0] == 0  # forgotten after 2 s
    assert layers.local_points(IDENTITY, 2.0, now=1.0).shape[0] == 0  # in view: the scan rules
    # a lidar that sees all around would see it if it were there: nothing is added
    layers.add_scan(turned, np.empty((0, 2)), np.empty((0, 2)), 0.6)
    assert layers.local_points(turned, 2.0, now=1.0).shape[0] == 0


def test_two_lidars_scans_are_live_together_and_their_views_join() -> None:
    front = FieldOfView(0.1, 0.0, -0.5 * math.pi, math.pi)
    left = FieldOfView(0.0, 0.1, 0.0, math.pi)  # front-left and rear-left: blind on the right
    layers = Layers(layer_settings(NavdConfig().planning))
    layers.snapshot(0.0, [(0.0, 0.0)])
    layers.add_scan(IDENTITY, np.array([[1.0, 0.0]]), np.empty((0, 2)), 0.0, front, source="a")
    layers.add_scan(IDENTITY, np.array([[0.0, 1.0]]), np.empty((0, 2)), 0.05, left, source="b")
    np.testing.assert_allclose(layers.scan_points, [[1.0, 0.0], [0.0, 1.0]])
    # a mark on the right that neither lidar looks at now stays; one ahead is theirs to say
    behind_right = np.array([[-0.7, -0.7]])
    layers.add_scan(IDENTITY, behind_right, np.empty((0, 2)), 0.1, ALL_AROUND, source="c")
    layers.add_scan(IDENTITY, np.empty((0, 2)), np.empty((0, 2)), 0.8, front, source="a")
    layers.add_scan(IDENTITY, np.empty((0, 2)), np.empty((0, 2)), 0.85, left, source="b")
    near = layers.local_points(IDENTITY, 2.0, now=0.9)
    assert np.min(np.hypot(near[:, 0] + 0.7, near[:, 1] + 0.7)) < 0.05
    assert np.min(np.hypot(near[:, 0] - 1.0, near[:, 1])) > 0.5
    # lidar c, silent for more than LIVE_SCAN_S, is no longer live
    assert layers.scan_points.shape[0] == 0


def test_a_far_goal_does_not_grow_every_later_snapshot_nor_exceed_the_cell_limit() -> None:
    settings = layer_settings(NavdConfig().planning)
    layers = Layers(settings)
    far, _, _ = layers.snapshot(0.0, [(0.0, 0.0), (60.0, 0.0)])
    near, _, _ = layers.snapshot(1.0, [(0.0, 0.0), (2.0, 0.0)])
    assert near.cols * near.resolution_m < 10.0 < far.cols * far.resolution_m
    small = Layers(dataclasses.replace(settings, max_cells=100_000))
    with pytest.raises(GoalRefusedError, match=r"more than planning\.max_plan_cells \(100000\)"):
        small.snapshot(0.0, [(0.0, 0.0), (60.0, 0.0)])


def test_route_progress_remaining_carrot_and_blocking() -> None:
    route = Route(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]]))
    assert route.length_m == 7.0
    assert route.remaining(Pose2(1.0, 0.5, 0.0)) == pytest.approx(0.5 + 6.0)
    assert route.carrot(Pose2(1.0, 0.5, 0.0), 1.0) == pytest.approx((2.0, 0.0))
    assert route.carrot(Pose2(3.5, 0.0, 0.0), 1.0) == pytest.approx((4.0, 0.5))
    assert route.carrot(Pose2(4.0, 2.9, 0.0), 1.0) == pytest.approx(
        (4.0, 3.0)
    )  # clamped at the end
    # Progress never goes back: a pose near the start now measures from the second leg.
    assert route.distance_to(Pose2(0.0, 0.0, 0.0)) == pytest.approx(4.0)
    assert route.blocked(np.array([[4.1, 2.0]]), 0.3, 3.0)
    assert not route.blocked(np.array([[4.1, 2.0]]), 0.05, 3.0)
    assert not route.blocked(np.array([[0.0, 0.0]]), 0.3, 3.0)  # behind the robot


def test_other_robots_are_obstacles_where_they_are_and_where_they_are_going() -> None:
    layers = Layers(layer_settings(NavdConfig().planning))
    # one standing at (2, 0), one at (0, 3) driving +x at 0.5 m/s
    layers.set_robots((("a/one", 2.0, 0.0, 0.0, 0.0, 0.3), ("a/two", 0.0, 3.0, 0.0, 0.5, 0.3)))
    frame, obstacles, _ = layers.snapshot(0.0, [(0.0, 0.0), (4.0, 4.0)])

    def blocked(x: float, y: float) -> bool:
        r, c = frame.cell_of(x, y)
        return bool(obstacles[r, c])

    assert blocked(2.0, 0.0) and blocked(2.3, 0.0) and not blocked(2.5, 0.0)
    assert blocked(0.0, 3.0) and blocked(0.5, 3.0)  # where it will be in 1 s
    assert not blocked(1.5, 3.0)
    assert any(np.hypot(*(layers.scan_points - [2.0, 0.0]).T) < 0.31)  # the DWA sees it too
    layers.set_robots(())
    _, obstacles, _ = layers.snapshot(1.0, [(0.0, 0.0), (4.0, 0.0)])
    assert not obstacles.any() and layers.scan_points.shape[0] == 0


def test_what_a_proximity_sensor_felt_is_never_cleared_by_a_lidar_looking_through_it() -> None:
    """Glass 1 m ahead: the sonar hears it, the lidar's rays pass through it to a wall 3 m
    ahead. The glass stays an obstacle in the snapshot and near the robot."""
    layers = Layers(layer_settings(NavdConfig().planning))
    layers.snapshot(0.0, [(0.0, 0.0), (4.0, 0.0)])  # the layers take their frame
    glass = np.array([[1.0, y] for y in np.linspace(-0.1, 0.1, 5)])
    layers.add_scan(IDENTITY, glass, np.empty((0, 2)), 0.0, source="range:front", proximity=True)
    wall = np.array([[3.0, y] for y in np.linspace(-0.5, 0.5, 21)])
    for t in (0.1, 0.2, 0.3):
        layers.add_scan(IDENTITY, wall, np.empty((0, 2)), t, source="lidar0")
    frame, obstacles, _ = layers.snapshot(0.3, [(0.0, 0.0), (4.0, 0.0)])
    r, c = frame.cell_of(1.0, 0.0)
    assert obstacles[r, c]
    near = layers.local_points(IDENTITY, 2.0, 0.3)
    assert np.min(np.hypot(near[:, 0] - 1.0, near[:, 1])) < 0.05
    # the sonar, clear again, clears its own marks
    clear = np.array([[3.0, y] for y in np.linspace(-0.3, 0.3, 7)])
    layers.add_scan(IDENTITY, np.empty((0, 2)), clear, 0.4, source="range:front", proximity=True)
    frame, obstacles, _ = layers.snapshot(0.4, [(0.0, 0.0), (4.0, 0.0)])
    r, c = frame.cell_of(1.0, 0.0)
    assert not obstacles[r, c]


def test_a_bumped_spot_is_kept_long_after_scan_obstacles_expire() -> None:
    settings = layer_settings(NavdConfig().planning)
    layers = Layers(settings)
    layers.snapshot(0.0, [(0.0, 0.0), (4.0, 0.0)])
    layers.mark_spot(Pose2(1.0, 0.0, 0.0), (0.2, 0.0), until=60.0)
    later = 60.0 + settings.obstacle_persistence_s / 2
    frame, obstacles, _ = layers.snapshot(later, [(0.0, 0.0), (4.0, 0.0)])
    r, c = frame.cell_of(1.2, 0.0)
    assert obstacles[r, c]

"""The planner's layers (frames that grow, maps on another lattice) and route following."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.geometry.pose import IDENTITY, Pose2
from navd.planning.layers import FRAME_MARGIN_M, Layers, LayerSettings
from navd.planning.route import Route


def test_the_snapshot_frame_holds_the_map_the_robot_and_the_goal() -> None:
    layers = Layers(LayerSettings.from_config(NavdConfig()))
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
    layers = Layers(LayerSettings.from_config(NavdConfig()))
    layers.snapshot(0.0, [(0.0, 0.0)])  # the obstacle layer exists before any map
    layers.add_scan(IDENTITY, np.array([[1.0, 0.0]]), np.empty((0, 2)), 0.0)
    frame, obstacles, _ = layers.snapshot(0.1, [(0.0, 0.0), (5.0, 0.0)])
    assert obstacles[frame.cell_of(1.0, 0.0)]
    # A map whose cells are offset by half a cell from the marks' lattice.
    layers.set_map(np.zeros((20, 20), np.int8), 0.05, -0.525, -0.525)
    frame, obstacles, _ = layers.snapshot(0.2, [(0.0, 0.0)])
    assert not obstacles.any()  # the marks were dropped, not misplaced
    assert math.isclose((frame.origin_x_m + 0.525) / 0.05, round((frame.origin_x_m + 0.525) / 0.05))


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

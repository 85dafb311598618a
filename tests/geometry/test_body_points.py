"""Range sensors' cones and depth cameras' points as obstacle points in the robot frame."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.geometry import Pose2, SensorMounts, band_points, cone_points


def test_a_cone_reading_is_an_arc_at_its_range_and_a_clear_cone_clears_to_its_reach() -> None:
    sonar = Pose2(0.2, 0.1, math.pi / 2)  # on the left, looking left
    seen = cone_points(0.5, math.radians(30), 4.0, sonar, reach_m=3.0)
    assert seen.misses.shape[0] == 0 and seen.hits.shape[0] >= 7
    distances = np.hypot(seen.hits[:, 0] - 0.2, seen.hits[:, 1] - 0.1)
    np.testing.assert_allclose(distances, 0.5)
    bearings = np.degrees(np.arctan2(seen.hits[:, 1] - 0.1, seen.hits[:, 0] - 0.2))
    assert bearings.min() == pytest.approx(75.0) and bearings.max() == pytest.approx(105.0)
    clear = cone_points(math.inf, math.radians(30), 4.0, sonar, reach_m=3.0)
    assert clear.hits.shape[0] == 0
    np.testing.assert_allclose(np.hypot(clear.misses[:, 0] - 0.2, clear.misses[:, 1] - 0.1), 3.0)


def test_a_depth_camera_keeps_what_lies_in_the_robots_height_band() -> None:
    config = NavdConfig.model_validate(
        {
            "mounts": {
                "depth": {
                    "cam": {"x_m": 0.1, "z_m": 0.4, "min_height_m": 0.05, "max_height_m": 1.0}
                }
            }
        }
    )
    mount = SensorMounts.of(config.mounts, config.lidar).body.depth_camera("cam")
    points = np.array(
        [
            [1.5, 0.0, -0.39],  # the floor, 1.5 m ahead (1 cm up): not an obstacle
            [1.0, 0.2, 0.35],  # a table top 0.75 m up, 1 m ahead: an obstacle
            [1.0, -0.2, 1.2],  # a shelf 1.6 m up: above the robot
            [6.0, 0.0, 0.0],  # far beyond the camera's reach
        ]
    )
    band = band_points(points, mount)
    np.testing.assert_allclose(band.hits, [[1.1, 0.2]])

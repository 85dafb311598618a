"""The bearing -> yaw convention, and means on the circle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.bench.ukf_reference import angle_mean
from navd.estimation.bearing import bearing_to_yaw
from navd.geometry import wrap_angle

PI = math.pi


@pytest.mark.parametrize(
    ("bearing_deg", "yaw_rad"),
    [
        (0.0, PI / 2),
        (90.0, 0.0),
        (180.0, -PI / 2),
        (270.0, -PI),
        (45.0, PI / 4),
        (315.0, 3 * PI / 4),
    ],
)
def test_bearing_clockwise_from_north_becomes_yaw_counter_clockwise_from_east(
    bearing_deg: float, yaw_rad: float
) -> None:
    yaw = bearing_to_yaw(
        bearing_deg,
        declination_deg=0.0,
        magnetic=False,
        grid_convergence_rad=0.0,
        map_rotation_rad=0.0,
    )
    assert yaw == pytest.approx(yaw_rad, abs=1e-12)


def test_declination_applies_to_magnetic_bearings_only() -> None:
    kwargs = {"grid_convergence_rad": 0.0, "map_rotation_rad": 0.0}
    # Magnetic north 10 deg east of true north: a magnetic bearing of 80 deg is due east.
    assert bearing_to_yaw(80.0, declination_deg=10.0, magnetic=True, **kwargs) == pytest.approx(0)
    assert bearing_to_yaw(80.0, declination_deg=10.0, magnetic=False, **kwargs) == pytest.approx(
        math.radians(10.0)
    )


def test_map_rotation_and_grid_convergence_turn_the_yaw() -> None:
    # Map +x points north-east (rotated 45 deg from east): facing east is yaw -45 deg.
    yaw = bearing_to_yaw(
        90.0, declination_deg=0.0, magnetic=False, grid_convergence_rad=0.0, map_rotation_rad=PI / 4
    )
    assert yaw == pytest.approx(-PI / 4)
    # Grid north 1 deg counter-clockwise of true north: true north is 91 deg from grid east.
    yaw = bearing_to_yaw(
        0.0,
        declination_deg=0.0,
        magnetic=False,
        grid_convergence_rad=math.radians(1.0),
        map_rotation_rad=0.0,
    )
    assert yaw == pytest.approx(math.radians(89.0))


def test_angle_mean_crosses_pi_without_passing_through_zero() -> None:
    weights = np.array([0.5, 0.25, 0.25])
    mean = angle_mean(np.array([PI - 0.05, PI - 0.1, -PI + 0.1]), weights)
    # Offsets from the first: -0.05 and +0.15 (across the wrap), so the mean is pi - 0.025.
    assert abs(wrap_angle(mean - (PI - 0.025))) < 1e-12


def test_angle_mean_survives_merwe_weights_where_the_sin_cos_mean_flips() -> None:
    # alpha = 0.1, kappa = 6, n = 9: central weight -59, spread sqrt(0.15) * 1.8 rad.
    n, lam = 9, 0.01 * 15 - 9
    wm = np.full(2 * n + 1, 0.5 / (n + lam))
    wm[0] = lam / (n + lam)
    spread = math.sqrt(n + lam) * 1.8
    angles = np.zeros(2 * n + 1)
    angles[1], angles[n + 1] = spread, -spread
    sin_cos = math.atan2(wm @ np.sin(angles), wm @ np.cos(angles))
    assert abs(sin_cos) == pytest.approx(PI)  # the flip the docstring describes
    assert angle_mean(angles, wm) == pytest.approx(0.0, abs=1e-12)

"""MadgwickFilter: integration, irregular intervals, ordering, gaps, rejection, bias, windows."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.config import EstimationConfig
from navd.estimation.madgwick import GRAVITY_MPS2, MadgwickFilter
from navd.lifecycle.messages import Imu, Vector3


def _imu(t: float, gz: float = 0.0, ax: float = 0.0, ay: float = 0.0) -> Imu:
    return Imu(
        stamp=t,
        received=t,
        device_id="imu",
        gyro_radps=Vector3(0.0, 0.0, gz),
        accel_mps2=Vector3(ax, ay, GRAVITY_MPS2),
    )


def _yaw(f: MadgwickFilter) -> float:
    w, x, y, z = f.quaternion
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def test_constant_yaw_rate_integrates_to_the_angle() -> None:
    f = MadgwickFilter(EstimationConfig(gyro_bias_gain_per_s=0.0))
    for i in range(2001):
        f.update(_imu(i * 0.001, gz=0.5))
    assert _yaw(f) == pytest.approx(1.0, abs=1e-6)


def test_irregular_intervals_give_the_same_angle() -> None:
    f = MadgwickFilter(EstimationConfig(gyro_bias_gain_per_s=0.0))
    rng = np.random.default_rng(3)
    stamps = np.concatenate([[0.0], np.sort(rng.uniform(0.0, 2.0, 1500)), [2.0]])
    for t in stamps:
        f.update(_imu(float(t), gz=0.5))
    assert _yaw(f) == pytest.approx(1.0, abs=1e-6)


def test_out_of_order_samples_are_skipped_and_counted() -> None:
    f = MadgwickFilter(EstimationConfig())
    assert f.update(_imu(1.0))
    assert f.update(_imu(1.001))
    assert not f.update(_imu(1.0005))
    assert not f.update(_imu(1.001))
    assert f.counters["imu_out_of_order"] == 2
    assert f.last_stamp == 1.001


def test_a_long_gap_is_integrated_as_the_configured_maximum() -> None:
    f = MadgwickFilter(EstimationConfig(imu_max_gap_s=0.1, gyro_bias_gain_per_s=0.0))
    f.update(_imu(0.0, gz=1.0))
    f.update(_imu(5.0, gz=1.0))
    assert f.counters["imu_gaps"] == 1
    assert _yaw(f) == pytest.approx(0.1, abs=1e-3)  # not 5 rad: the gap counts as 0.1 s


def _tilt(f: MadgwickFilter) -> float:
    _w, x, y, _z = f.quaternion
    return math.acos(min(1.0, 1 - 2 * (x * x + y * y)))  # angle of body z from vertical


def test_strong_acceleration_does_not_tilt_the_estimate() -> None:
    rejecting = MadgwickFilter(EstimationConfig(madgwick_beta=2.0, accel_reject_mps2=1.0))
    trusting = MadgwickFilter(EstimationConfig(madgwick_beta=2.0, accel_reject_mps2=50.0))
    for f in (rejecting, trusting):
        f.update(_imu(0.0))
        for i in range(1, 500):
            f.update(_imu(i * 0.001, ax=6.0))  # braking hard: |a| is 1.8 m/s² off g
    assert _tilt(rejecting) < 1e-9
    assert _tilt(trusting) > 0.3


def test_gyro_bias_is_learned_while_still_and_removed() -> None:
    f = MadgwickFilter(EstimationConfig(gyro_bias_gain_per_s=1.0, still_time_s=0.5))
    for i in range(10_000):
        f.update(_imu(i * 0.001, gz=0.01))
    assert f.gyro_bias_radps.z == pytest.approx(0.01, rel=1e-3)
    before = _yaw(f)
    for i in range(10_000, 11_000):
        f.update(_imu(i * 0.001, gz=0.01))
    assert abs(_yaw(f) - before) < 1e-4


def test_window_mean_reports_levelled_rate_and_heading_frame_acceleration() -> None:
    f = MadgwickFilter(EstimationConfig(gyro_bias_gain_per_s=0.0, madgwick_beta=0.0))
    f.update(_imu(0.0))  # level at the start; then the robot turns and accelerates
    for i in range(1, 1001):
        f.update(_imu(i * 0.001, gz=0.2, ax=0.5, ay=-0.25))
    window = f.window_mean(1.0, 0.0495)
    assert window is not None
    assert window.samples == 50
    assert window.yaw_rate_radps == pytest.approx(0.2)
    assert window.accel_forward_mps2 == pytest.approx(0.5)
    assert window.accel_left_mps2 == pytest.approx(-0.25)
    assert f.window_mean(10.0, 0.05) is None

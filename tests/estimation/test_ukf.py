"""The pose UKF: exact model, yaw on the circle, gated outliers, numerical failure reported."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.estimation._ukf_kernels import propagate
from navd.estimation.motion_model import (
    AX,
    STATE_SIZE,
    TH,
    VTH,
    VX,
    ProcessNoise,
    Row,
    X,
    Y,
    evaluate_rows,
    transition_matrix,
)
from navd.estimation.ukf import Measurement, PoseUkf, StepOutcome, UkfSettings


def _ukf(kappa: float = 6.0) -> PoseUkf:
    return PoseUkf(
        UkfSettings(alpha=0.1, beta=2.0, kappa=kappa, linear_jerk_psd=0.25, angular_jerk_psd=1.0)
    )


def _pose(x: float, y: float, yaw: float, std: float = 0.02) -> Measurement:
    return Measurement(
        rows=(Row.X, Row.Y, Row.YAW),
        z=np.array([x, y, yaw]),
        r=np.diag([std**2, std**2, (std / 2) ** 2]),
        gated_rows=3,
    )


def test_transition_is_exact_for_constant_acceleration() -> None:
    state = np.zeros(STATE_SIZE)
    state[[X, VX, AX]] = (1.0, 2.0, 0.5)
    state[[TH, VTH, 8]] = (0.1, 0.2, -0.3)
    moved = transition_matrix(2.0) @ state
    assert moved[X] == pytest.approx(1.0 + 2.0 * 2.0 + 0.5 * 0.5 * 4.0)
    assert moved[VX] == pytest.approx(2.0 + 0.5 * 2.0)
    assert moved[TH] == pytest.approx(0.1 + 0.2 * 2.0 - 0.5 * 0.3 * 4.0)


def test_process_noise_adds_up_over_split_steps() -> None:
    # White jerk: the variance of acceleration grows linearly with time, whatever the steps.
    noise = ProcessNoise(0.25, 1.0)
    one = noise(0.2)
    f = transition_matrix(0.1)
    two = f @ noise(0.1) @ f.T + noise(0.1)
    np.testing.assert_allclose(one, two, atol=1e-15)
    assert one[AX, AX] == pytest.approx(0.25 * 0.2)


def test_the_linear_prediction_kernel_is_the_transition_and_the_process_noise() -> None:
    rng = np.random.default_rng(3)
    state = rng.normal(size=STATE_SIZE)
    root = rng.normal(size=(STATE_SIZE, STATE_SIZE))
    cov = root @ root.T
    noise = ProcessNoise(0.25, 1.0)
    for dt in (0.0, 0.04, 0.7):
        x, p = propagate(state, cov, dt, noise.polynomial)
        f = transition_matrix(dt)
        np.testing.assert_allclose(x, f @ state, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(p, f @ cov @ f.T + noise(dt), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.0, math.pi - 0.01])
def test_heading_rows_turn_map_vectors_into_the_body_frame(yaw: float) -> None:
    state = np.zeros((1, STATE_SIZE))
    state[0, TH] = yaw
    state[0, [VX, VX + 1]] = (math.cos(yaw) * 1.5, math.sin(yaw) * 1.5)  # 1.5 m/s forward
    table = evaluate_rows((Row.VELOCITY_FORWARD, Row.VELOCITY_LEFT, Row.YAW), state)
    np.testing.assert_allclose(table[0], [1.5, 0.0, yaw], atol=1e-12)


def test_yaw_update_takes_the_short_way_across_pi() -> None:
    ukf = _ukf()
    state = np.zeros(STATE_SIZE)
    state[TH] = math.pi - 0.05
    ukf.set_state(state, np.diag([0.01] * 6 + [0.01, 0.01, 0.01]))
    assert ukf.step(0.0, _pose(0.0, 0.0, -math.pi + 0.05, std=0.01), 100.0) is StepOutcome.APPLIED
    yaw = ukf.x[TH]
    assert abs(abs(yaw) - math.pi) < 0.05  # near +-pi, not dragged through 0
    assert -math.pi <= yaw < math.pi


def test_outlier_is_rejected_by_the_gate_and_the_tail_still_applies() -> None:
    ukf = _ukf()
    ukf.set_state(np.zeros(STATE_SIZE), np.eye(STATE_SIZE) * 0.01)
    outlier = Measurement(
        rows=(Row.X, Row.Y, Row.YAW, Row.YAW_RATE),
        z=np.array([5.0, 0.0, 0.0, 0.3]),
        r=np.diag([0.0004, 0.0004, 0.0003, 0.0001]),
        gated_rows=3,
    )
    assert ukf.step(0.1, outlier, 16.3) is StepOutcome.REJECTED
    assert ukf.last_mahalanobis_sq > 16.3
    assert abs(ukf.x[X]) < 0.01  # position untouched
    assert ukf.x[VTH] == pytest.approx(0.3, abs=0.02)  # the IMU row applied
    assert ukf.step(0.1, _pose(0.05, 0.0, 0.0), 16.3) is StepOutcome.APPLIED


def test_a_covariance_that_is_not_positive_definite_is_reported_not_raised() -> None:
    ukf = _ukf()
    p = np.eye(STATE_SIZE)
    p[X, X] = -1.0
    ukf.set_state(np.zeros(STATE_SIZE), p)
    assert ukf.step(0.1, _pose(0.0, 0.0, 0.0), 16.3) is StepOutcome.DIVERGED


def test_negative_kappa_without_yaw_measurements_never_raises() -> None:
    # kappa = -6 (lambda + n = 0.03, central weight -299) with position-only updates: the
    # setup that broke a plain filterpy filter after 68 steps.
    ukf = _ukf(kappa=-6.0)
    state = np.zeros(STATE_SIZE)
    ukf.set_state(state, np.diag([2.25, 2.25, 0.25, 0.25, 0.25, 0.25, 3.0, 0.25, 1.0]))
    rng = np.random.default_rng(11)
    outcomes = []
    for i in range(300):
        t = i * 0.2
        truth = (0.5 * t, 0.1 * t)
        z = np.array(truth) + rng.normal(0.0, 1.5, 2)
        gps = Measurement(rows=(Row.X, Row.Y), z=z, r=np.eye(2) * 2.25, gated_rows=2)
        outcomes.append(ukf.step(0.2, gps, 13.8))
        if outcomes[-1] is StepOutcome.DIVERGED:
            ukf.set_state(state, np.eye(STATE_SIZE))
    assert StepOutcome.DIVERGED not in outcomes
    assert np.all(np.isfinite(ukf.x))
    assert math.hypot(ukf.x[X] - 0.5 * 59.8, ukf.x[Y] - 0.1 * 59.8) < 3.0


def test_a_measurement_gating_more_rows_than_it_has_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match=r"gated_rows must be in 0\.\.3, got 4"):
        Measurement(rows=(Row.X, Row.Y, Row.YAW), z=np.zeros(3), r=np.eye(3), gated_rows=4)


def test_the_reported_distance_is_the_last_steps_even_when_it_cannot_be_computed() -> None:
    ukf = _ukf()
    ukf.set_state(np.zeros(STATE_SIZE), np.eye(STATE_SIZE) * 0.1)
    ukf.step(0.1, _pose(0.0, 0.0, 0.0), 16.0)
    assert math.isfinite(ukf.last_mahalanobis_sq)
    broken = _pose(math.nan, 0.0, 0.0)
    assert ukf.step(0.1, broken, 16.0) is not StepOutcome.APPLIED
    assert math.isnan(ukf.last_mahalanobis_sq)  # not the previous step's distance

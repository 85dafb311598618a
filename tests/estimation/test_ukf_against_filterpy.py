"""navd's UKF does filterpy's algebra without importing filterpy: step for step, on the same
model, sigma points, residuals and means, the two give the same state and covariance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.bench.ukf_reference import stock_filter
from navd.estimation.motion_model import (
    STATE_SIZE,
    TH,
    ProcessNoise,
    Row,
    evaluate_rows,
    transition_matrix,
)
from navd.estimation.ukf import Measurement, PoseUkf, UkfSettings

pytest.importorskip("filterpy.kalman", reason="filterpy (a dev dependency) missing")

ROWS = (Row.X, Row.Y, Row.YAW, Row.YAW_RATE, Row.ACCEL_FORWARD, Row.VELOCITY_LEFT)
# Two beacons' ranges and a bearing to one of them, then the IMU's rows riding along.
BEACON_ROWS = (Row.RANGE, Row.RANGE, Row.BEARING, Row.YAW_RATE, Row.ACCEL_FORWARD)
BEACONS = np.array([[4.0, 1.0], [-2.0, 3.0], [-2.0, 3.0], [0.0, 0.0], [0.0, 0.0]])


@pytest.mark.parametrize(
    ("seed", "rows", "points"),
    [(0, ROWS, None), (1, ROWS, None), (2, ROWS, None), (3, BEACON_ROWS, BEACONS)],
)
def test_every_step_matches_filterpys_unscented_kalman_filter(
    seed: int, rows: tuple[Row, ...], points: np.ndarray | None
) -> None:
    rng = np.random.default_rng(seed)
    settings = UkfSettings(
        alpha=0.1, beta=2.0, kappa=6.0, linear_jerk_psd=0.25, angular_jerk_psd=1.0
    )
    ours = PoseUkf(settings)
    theirs = stock_filter(settings, rows, points)
    x0 = rng.normal(0.0, 0.5, STATE_SIZE)
    x0[TH] = 3.0  # near the wrap, so yaw residuals and means are exercised
    p0 = np.diag(rng.uniform(0.01, 0.2, STATE_SIZE))
    ours.set_state(x0, p0)
    theirs.x, theirs.P = x0.copy(), p0.copy()
    noise = ProcessNoise(settings.linear_jerk_psd, settings.angular_jerk_psd)
    truth = x0.copy()
    for _ in range(60):
        dt = float(rng.uniform(0.02, 0.15))
        truth = transition_matrix(dt) @ truth
        z = evaluate_rows(rows, truth[None, :], points)[0] + rng.normal(0.0, 0.05, len(rows))
        z[2] = math.remainder(z[2], math.tau)
        r = np.diag(rng.uniform(0.01, 0.05, len(rows)) ** 2)
        measurement = Measurement(rows=rows, z=z, r=r, gated_rows=3, points=points)
        ours.step(dt, measurement, math.inf)
        theirs.Q = noise(dt)
        theirs.predict(dt=dt)
        theirs.update(z, R=r)
        theirs.P = 0.5 * (theirs.P + theirs.P.T)  # navd keeps P symmetric after each step
        np.testing.assert_allclose(ours.x, theirs.x, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(ours.p, theirs.P, rtol=1e-9, atol=1e-12)

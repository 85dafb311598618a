"""The Madgwick kernels against their NumPy twin, and the ring window mean against NumPy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.estimation import _madgwick_kernels as k
from tests.estimation import madgwick_reference as ref

PARAMS = np.array([0.5, 3.0, 0.5, 0.05, 0.01, 0.1])


def _random_samples(rng: np.random.Generator, n: int, with_mag: bool) -> np.ndarray:
    gyro = rng.normal(0.0, 0.8, (n, 3))
    accel = np.array([0.3, -0.2, k.GRAVITY_MPS2]) + rng.normal(0.0, 0.6, (n, 3))
    mag = (np.array([20.0, -5.0, -40.0]) + rng.normal(0.0, 2.0, (n, 3))) * with_mag
    return np.hstack([gyro, accel, mag])


@pytest.mark.parametrize(("seed", "with_mag"), [(1, False), (2, True), (3, True), (4, False)])
def test_kernel_steps_match_the_reference(seed: int, with_mag: bool) -> None:
    rng = np.random.default_rng(seed)
    samples = _random_samples(rng, 200, with_mag)
    dts = rng.uniform(0.0005, 0.004, 200)
    state = np.zeros(k.STATE_SIZE)
    state[0] = 1.0
    state[8] = 1.0  # start from the identity, skip the accel initialization
    ref_state = state[:9].copy()
    out = np.zeros(4)
    for dt, sample in zip(dts, samples, strict=True):
        k.madgwick_step(state, PARAMS, out, dt, *sample)
        expected = ref.step(ref_state, PARAMS, dt, sample)
        np.testing.assert_allclose(state[:9], ref_state, atol=1e-9)
        np.testing.assert_allclose(out, expected, atol=1e-9)


def test_first_sample_sets_roll_pitch_and_heading_from_gravity_and_field() -> None:
    roll, pitch, yaw = 0.2, -0.1, 1.0
    q = np.array(
        [
            math.cos(yaw / 2) * math.cos(pitch / 2) * math.cos(roll / 2)
            + math.sin(yaw / 2) * math.sin(pitch / 2) * math.sin(roll / 2),
            math.cos(yaw / 2) * math.cos(pitch / 2) * math.sin(roll / 2)
            - math.sin(yaw / 2) * math.sin(pitch / 2) * math.cos(roll / 2),
            math.cos(yaw / 2) * math.sin(pitch / 2) * math.cos(roll / 2)
            + math.sin(yaw / 2) * math.cos(pitch / 2) * math.sin(roll / 2),
            math.sin(yaw / 2) * math.cos(pitch / 2) * math.cos(roll / 2)
            - math.cos(yaw / 2) * math.sin(pitch / 2) * math.sin(roll / 2),
        ]
    )
    accel = ref.to_sensor(q, np.array([0.0, 0.0, k.GRAVITY_MPS2]))
    mag = ref.to_sensor(q, np.array([18.0, 0.0, -45.0]))
    state = np.zeros(k.STATE_SIZE)
    out = np.zeros(4)
    k.madgwick_step(state, PARAMS, out, 0.0, 0.0, 0.0, 0.0, *accel, *mag)
    assert abs(abs(float(state[:4] @ q)) - 1.0) < 1e-9
    assert out[3] == pytest.approx(yaw, abs=1e-9)


def test_window_mean_matches_numpy_over_a_wrapped_ring() -> None:
    rng = np.random.default_rng(6)
    ring = np.zeros((64, k.RING_COLUMNS))
    stamps = np.arange(100) * 0.001
    values = rng.normal(size=(100, 3))
    head = 0
    for t, v in zip(stamps, values, strict=True):
        ring[head] = (t, *v, 0.0)
        head = (head + 1) % 64
    out = np.zeros(3)
    n = k.imu_window_mean(ring, head, 64, 0.0805, 0.0905, out)
    inside = (stamps > 0.0805) & (stamps <= 0.0905)
    assert n == inside.sum() == 10
    np.testing.assert_allclose(out, values[inside].mean(axis=0))
    assert k.imu_window_mean(ring, head, 64, 0.5, 0.6, out) == 0

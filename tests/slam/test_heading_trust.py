"""The heading prior's weight follows the odometry's measured heading errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.slam.heading_trust import (
    MAX_WEIGHT,
    MIN_SAMPLES,
    MIN_WEIGHT,
    START_WEIGHT,
    WEIGHT_PER_PRECISION,
    HeadingTrust,
)


def _trust(errors: np.ndarray) -> HeadingTrust:
    trust = HeadingTrust()
    for error in errors:
        trust.record(float(error))
    return trust


def test_until_enough_errors_are_known_the_weight_is_the_starting_one() -> None:
    trust = _trust(np.full(MIN_SAMPLES - 1, 0.001))
    assert trust.sigma_rad() is None
    assert trust.weight_per_rad2() == START_WEIGHT


@pytest.mark.parametrize("sigma_deg", [0.15, 0.4])
def test_the_weight_is_the_precision_of_the_measured_errors(sigma_deg: float) -> None:
    sigma = math.radians(sigma_deg)
    errors = np.random.default_rng(3).normal(0.0, sigma, 400)
    trust = _trust(errors)
    assert trust.sigma_rad() == pytest.approx(sigma, rel=0.1)
    assert trust.weight_per_rad2() == pytest.approx(WEIGHT_PER_PRECISION / sigma**2, rel=0.2)


def test_a_few_wild_errors_barely_move_it_and_old_errors_age_out() -> None:
    rng = np.random.default_rng(4)
    sigma = math.radians(0.2)
    errors = rng.normal(0.0, sigma, 400)
    errors[::10] = 0.3  # one scan in ten turned 17 degrees (slips, wrong matches)
    assert _trust(errors).sigma_rad() == pytest.approx(sigma * 1.15, rel=0.15)
    # Wheels that got worse: after a window of larger errors, only those count.
    worse = np.concatenate([errors, rng.normal(0.0, 4 * sigma, 400)])
    assert _trust(worse).sigma_rad() == pytest.approx(4 * sigma, rel=0.1)


def test_the_weight_stays_within_its_bounds() -> None:
    assert _trust(np.zeros(100)).weight_per_rad2() == MAX_WEIGHT
    assert _trust(np.full(100, 1.0)).weight_per_rad2() == MIN_WEIGHT
    # Errors are angles: a full turn off is no error.
    assert _trust(np.full(100, 2 * math.pi)).weight_per_rad2() == MAX_WEIGHT

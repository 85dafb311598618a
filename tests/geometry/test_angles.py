"""The one angle wrap, in Python, in numpy and in numba."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.geometry._angle_kernels import wrap
from navd.geometry.angles import angle_between, wrap_angle, wrap_angles

PI = math.pi


@pytest.mark.parametrize(
    ("angle", "wrapped"),
    [
        (0.0, 0.0),
        (PI, -PI),
        (-PI, -PI),
        (3 * PI / 2, -PI / 2),
        (-3 * PI / 2, PI / 2),
        (2 * PI + 0.1, 0.1),
        (-2 * PI - 0.1, -0.1),
        (7 * PI, -PI),
    ],
)
def test_wrap_angle_lands_in_minus_pi_to_pi(angle: float, wrapped: float) -> None:
    assert wrap_angle(angle) == pytest.approx(wrapped, abs=1e-12)
    assert wrap_angles(np.array([angle]))[0] == pytest.approx(wrapped, abs=1e-12)


@pytest.mark.parametrize("angle", [*np.linspace(-25.0, 25.0, 101).tolist(), PI, -PI, 3 * PI])
def test_the_numba_twin_wraps_exactly_as_python_does(angle: float) -> None:
    assert wrap(angle) == wrap_angle(angle)


@pytest.mark.parametrize(
    ("a", "b", "turn"),
    [(0.1, -0.1, 0.2), (PI - 0.1, -PI + 0.1, 0.2), (1.0, 1.0, 0.0), (0.0, PI, PI)],
)
def test_angle_between_is_the_smallest_turn(a: float, b: float, turn: float) -> None:
    assert angle_between(a, b) == pytest.approx(turn)
    assert angle_between(b, a) == pytest.approx(turn)

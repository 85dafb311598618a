from __future__ import annotations

import pytest

from navd.drivers.kinematics import (
    WheelCalibration,
    body_velocity,
    format_command,
    ramp,
    wheel_command,
    wheel_speeds,
)

CAL = WheelCalibration(scale_per_mps=1000.0, deadband=0, limit=1000)


@pytest.mark.parametrize(
    ("v", "w", "track", "left", "right"),
    [
        (0.5, 0.0, 0.3, 0.5, 0.5),  # straight
        (0.0, 1.0, 0.3, -0.15, 0.15),  # spin left in place: right wheel forward
        (0.2, -2.0, 0.4, 0.6, -0.2),  # turning right
        (-0.3, 0.0, 0.3, -0.3, -0.3),  # reversing
    ],
)
def test_wheel_speeds_and_back(v: float, w: float, track: float, left: float, right: float) -> None:
    assert wheel_speeds(v, w, track) == pytest.approx((left, right))
    assert body_velocity(left, right, track) == pytest.approx((v, w))


@pytest.mark.parametrize(
    ("left", "right", "cal", "expected"),
    [
        (0.5, 0.5, CAL, (500, 500)),
        (0.1234, -0.0005, CAL, (123, -1)),  # rounds half away from zero
        (0.0025, -0.0025, CAL, (3, -3)),
        # over the limit: both scaled down together, the ratio (curvature) kept
        (2.0, 1.0, CAL, (1000, 500)),
        (-3.0, 1.5, CAL, (-1000, 500)),
        # deadband zeroes small commands
        (0.04, 0.2, WheelCalibration(1000.0, 50, 1000), (0, 200)),
        # inverted sides
        (0.3, 0.1, WheelCalibration(1000.0, 0, 1000, invert_left=True), (-300, 100)),
        (0.3, 0.1, WheelCalibration(1000.0, 0, 1000, invert_right=True), (300, -100)),
        (0.0, 0.0, CAL, (0, 0)),
    ],
)
def test_wheel_command(
    left: float, right: float, cal: WheelCalibration, expected: tuple[int, int]
) -> None:
    assert wheel_command(left, right, cal) == expected


def test_format_is_two_integers_and_the_line_ending() -> None:
    assert format_command(-12, 345) == b"-12 345\n"
    assert format_command(0, 0, "\r\n") == b"0 0\r\n"


@pytest.mark.parametrize(
    ("current", "target", "step", "expected"),
    [
        (0.0, 0.5, 0.1, 0.1),  # speeding up: one step
        (0.45, 0.5, 0.1, 0.5),  # the last bit
        (0.5, 0.1, 0.1, 0.1),  # slowing down: at once
        (0.5, 0.0, 0.1, 0.0),  # stopping: at once
        (0.3, -0.3, 0.1, -0.1),  # reversing: braking at once, then one step the other way
        (-0.2, -0.6, 0.1, -0.3),
    ],
)
def test_ramp_limits_speeding_up_only(
    current: float, target: float, step: float, expected: float
) -> None:
    assert ramp(current, target, step) == pytest.approx(expected)

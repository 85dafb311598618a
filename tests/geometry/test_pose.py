"""Pose2: composition, inverse, relative motion, and points through a pose."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from navd.geometry.pose import IDENTITY, Pose2

coordinate = st.floats(-50.0, 50.0)
heading = st.floats(-math.pi, math.pi)
poses = st.builds(Pose2, coordinate, coordinate, heading)


def _close(a: Pose2, b: Pose2) -> bool:
    return (
        math.isclose(a.x, b.x, abs_tol=1e-9)
        and math.isclose(a.y, b.y, abs_tol=1e-9)
        and abs(math.remainder(a.yaw - b.yaw, math.tau)) < 1e-9
    )


@pytest.mark.parametrize(
    ("a", "b", "composed"),
    [
        (Pose2(1.0, 2.0, 0.0), Pose2(0.5, 0.0, 0.0), Pose2(1.5, 2.0, 0.0)),
        (Pose2(0.0, 0.0, math.pi / 2), Pose2(1.0, 0.0, 0.0), Pose2(0.0, 1.0, math.pi / 2)),
        (Pose2(1.0, 1.0, math.pi), Pose2(1.0, 1.0, math.pi), Pose2(0.0, 0.0, 0.0)),
        (Pose2(0.2, 0.0, 0.0), Pose2(0.0, 0.1, -0.5), Pose2(0.2, 0.1, -0.5)),
    ],
)
def test_compose_places_the_inner_pose_in_the_outer_frame(
    a: Pose2, b: Pose2, composed: Pose2
) -> None:
    assert _close(a.compose(b), composed)


@given(poses, poses)
def test_between_undoes_compose_and_the_inverse_is_the_identity(a: Pose2, b: Pose2) -> None:
    assert _close(a.compose(a.between(b)), b)
    assert _close(a.compose(a.inverse()), IDENTITY)


@given(poses, poses)
def test_points_through_a_composed_pose_are_points_through_both(a: Pose2, b: Pose2) -> None:
    points = np.array([[1.0, 0.0], [0.0, -2.0], [0.3, 0.4]])
    np.testing.assert_allclose(
        a.compose(b).transform(points), a.transform(b.transform(points)), atol=1e-9
    )


def test_the_yaw_stays_in_minus_pi_to_pi() -> None:
    turned = Pose2(0.0, 0.0, 3.0).compose(Pose2(0.0, 0.0, 3.0))
    assert -math.pi <= turned.yaw < math.pi
    assert turned.yaw == pytest.approx(6.0 - 2 * math.pi)


def test_distance_between_positions() -> None:
    assert Pose2(1.0, 1.0, 0.3).distance_to(Pose2(4.0, 5.0, -2.0)) == 5.0

"""Where the lidar sits in a replay: the command line, then the recording, then the config."""

from __future__ import annotations

import math

import pytest

from navd.geometry import LidarMount, Pose2
from navd.offline.replay import replay_mount

CONFIGURED = LidarMount(Pose2(0.1, 0.0, 0.0), 0.2)
RECORDED = Pose2(0.3, -0.05, math.pi)


@pytest.mark.parametrize(
    ("recorded", "given", "pose"),
    [
        (None, {}, Pose2(0.1, 0.0, 0.0)),  # the config's
        (RECORDED, {}, RECORDED),  # the recording's own transforms beat the config
        (RECORDED, {"yaw_rad": 0.0}, Pose2(0.3, -0.05, 0.0)),  # each given value beats both
        (None, {"x_m": 0.5, "y_m": 0.1}, Pose2(0.5, 0.1, 0.0)),
    ],
)
def test_mount_precedence(recorded: Pose2 | None, given: dict[str, float], pose: Pose2) -> None:
    mount = replay_mount(CONFIGURED, recorded, **given)
    assert mount == LidarMount(pose, 0.2)  # the shortest range always from the config

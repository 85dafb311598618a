"""A synthetic room (wall segments) and an exact ray caster for it, for SLAM tests."""

from __future__ import annotations

import math

import numpy as np

from navd.slam.pose import Pose2

# A 12 m x 8 m room with an L-shaped inner wall and a pillar: no symmetry to confuse matching.
SEGMENTS = np.array(
    [
        ((-6, -4), (6, -4)),
        ((6, -4), (6, 4)),
        ((6, 4), (-6, 4)),
        ((-6, 4), (-6, -4)),
        ((-2, 1), (2, 1)),
        ((2, 1), (2, 3)),
        ((3, -2), (3.5, -2)),
        ((3.5, -2), (3.5, -1.5)),
        ((3.5, -1.5), (3, -1.5)),
        ((3, -1.5), (3, -2)),
        ((-4, -4), (-4, -2.5)),
    ],
    dtype=np.float64,
)


def cast(
    pose: Pose2, beams: int = 360, fov: float = 2 * math.pi
) -> tuple[float, float, np.ndarray]:
    """(angle_min, angle_increment, ranges) of a scan taken at ``pose``; inf where no hit."""
    angle_min = -fov / 2
    increment = fov / beams
    angles = pose.yaw + angle_min + increment * np.arange(beams)
    d = np.stack([np.cos(angles), np.sin(angles)], axis=1)  # beams x 2
    p = SEGMENTS[:, 0]
    e = SEGMENTS[:, 1] - SEGMENTS[:, 0]  # segments x 2
    o = np.array([pose.x, pose.y])
    # Solve o + t d = p + u e for every beam and segment.
    denom = d[:, None, 0] * (-e[None, :, 1]) - d[:, None, 1] * (-e[None, :, 0])
    w = p[None, :, :] - o
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * (-e[None, :, 1]) - w[..., 1] * (-e[None, :, 0])) / denom
        u = (d[:, None, 0] * w[..., 1] - d[:, None, 1] * w[..., 0]) / denom
    valid = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    ranges = np.where(valid, t, np.inf).min(axis=1)
    return angle_min, increment, ranges

"""A synthetic room with exact ray casting: ground truth for SLAM tests and benchmarks.

A 12 m x 8 m room with an L-shaped inner wall, a pillar and a short wall: no symmetry for a
matcher to confuse.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2

__all__ = ["WALLS", "cast"]

# The room's walls: (x0, y0, x1, y1) [m].
WALLS = np.array(
    [
        (-6, -4, 6, -4),
        (6, -4, 6, 4),
        (6, 4, -6, 4),
        (-6, 4, -6, -4),
        (-2, 1, 2, 1),
        (2, 1, 2, 3),
        (3, -2, 3.5, -2),
        (3.5, -2, 3.5, -1.5),
        (3.5, -1.5, 3, -1.5),
        (3, -1.5, 3, -2),
        (-4, -4, -4, -2.5),
    ],
    dtype=np.float64,
)


def cast(
    pose: Pose2, beams: int = 360, walls: npt.NDArray[np.float64] = WALLS
) -> tuple[float, float, npt.NDArray[np.float64]]:
    """A full-circle scan at ``pose`` in a world of ``walls`` (K x 4 segments x0 y0 x1 y1 [m]):
    (angle_min, angle_increment, ranges; inf: no hit)."""
    angle_min = -math.pi
    increment = 2 * math.pi / beams
    angles = pose.yaw + angle_min + increment * np.arange(beams)
    d = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    p, e = walls[:, :2], walls[:, 2:] - walls[:, :2]
    # Solve origin + t d = p + u e for every beam and wall.
    w = p[None, :, :] - np.array([pose.x, pose.y])
    denom = -d[:, None, 0] * e[None, :, 1] + d[:, None, 1] * e[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (-w[..., 0] * e[None, :, 1] + w[..., 1] * e[None, :, 0]) / denom
        u = (d[:, None, 0] * w[..., 1] - d[:, None, 1] * w[..., 0]) / denom
    hit = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    ranges: npt.NDArray[np.float64] = np.where(hit, t, np.inf).min(axis=1)
    return angle_min, increment, ranges

"""Rotations in three dimensions, for sensors mounted turned on the robot."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["rotation_rpy"]

FloatArray = np.ndarray[tuple[int, ...], np.dtype[np.float64]]


def rotation_rpy(roll_rad: float, pitch_rad: float, yaw_rad: float) -> FloatArray:
    """The 3 x 3 rotation R = Rz(yaw) Ry(pitch) Rx(roll): a vector in the sensor's axes,
    multiplied by R, is the same vector in base_link's."""
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )

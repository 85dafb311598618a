"""The collision guard's kernel: the footprint swept along a command's arc, against scan
points (``guard`` says when and how it is asked)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from navd.geometry import footprint_distance

__all__ = ["sweep_clearance"]

FloatArray = npt.NDArray[np.float64]


@njit(cache=True, nogil=True)
def sweep_clearance(
    points: FloatArray,
    v: float,
    w: float,
    duration: float,
    samples: int,
    kind: int,
    half_length: float,
    half_width: float,
) -> tuple[float, float]:
    """[m] (clearance now, smallest clearance along the sweep) of the footprint to the points
    (robot frame), the footprint moving at (v, ω) for ``duration`` [s]."""
    now = 1e9
    for q in range(points.shape[0]):
        now = min(
            now,
            footprint_distance(
                points[q, 0], points[q, 1], 0.0, 0.0, 1.0, 0.0, kind, half_length, half_width
            ),
        )
    swept = now
    for s in range(1, samples + 1):
        t = duration * s / samples
        yaw = w * t
        if abs(w) < 1e-9:
            x = v * t
            y = 0.0
        else:
            x = v / w * math.sin(yaw)
            y = v / w * (1.0 - math.cos(yaw))
        c = math.cos(yaw)
        sn = math.sin(yaw)
        for q in range(points.shape[0]):
            swept = min(
                swept,
                footprint_distance(
                    points[q, 0], points[q, 1], x, y, c, sn, kind, half_length, half_width
                ),
            )
    return now, swept

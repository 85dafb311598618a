"""Angles on the circle: the one wrap into [-pi, pi).

Kernels use the numba twin ``_angle_kernels.wrap`` (same formula, compared in the tests);
Python code calls ``wrap_angle``, which costs a tenth of a call into numba.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = ["angle_between", "wrap_angle", "wrap_angles"]

FloatArray = npt.NDArray[np.float64]
_TAU = 2.0 * math.pi


def wrap_angle(angle_rad: float) -> float:
    """``angle_rad`` wrapped into [-pi, pi): (a + pi) mod 2 pi - pi."""
    return (angle_rad + math.pi) % _TAU - math.pi


def wrap_angles(angles_rad: FloatArray) -> FloatArray:
    """Element-wise ``wrap_angle`` of an array."""
    # Python floats, not numpy scalars: half the cost on the short arrays of a UKF step.
    return np.remainder(angles_rad + math.pi, _TAU) - math.pi


def angle_between(a_rad: float, b_rad: float) -> float:
    """[rad] the smallest turn from ``b_rad`` to ``a_rad``, in [0, pi]."""
    return abs(wrap_angle(a_rad - b_rad))

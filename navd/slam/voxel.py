"""Voxel filter: one point per square cell, for matching, loop closure and scan odometry."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from navd.slam._odometry_kernels import thin

__all__ = ["voxel_downsample"]

FloatArray = npt.NDArray[np.float64]


def voxel_downsample(points: FloatArray, voxel_m: float) -> FloatArray:
    """One point per ``voxel_m`` square cell (the first one seen), order kept.

    A numba kernel (one pass over a small hash set of the cells, the interpreter lock
    released), called with one array layout so that the warm-up's signature is the only one.
    """
    if points.shape[0] == 0:
        return points
    kept: FloatArray = thin(np.ascontiguousarray(points, dtype=np.float64), voxel_m)
    return kept

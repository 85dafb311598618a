"""Voxel filter: one point per square cell, for matching and loop closure."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["voxel_downsample"]

FloatArray = npt.NDArray[np.float64]


def voxel_downsample(points: FloatArray, voxel_m: float) -> FloatArray:
    """One point per ``voxel_m`` square cell (the first one seen), order kept."""
    if points.shape[0] == 0:
        return points
    keys = np.floor(points / voxel_m).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    kept: FloatArray = points[np.sort(first)]
    return kept

"""Numba kernel of the exact Euclidean distance transform of a grid.

``distance_to`` gives every cell its distance, in cells, to the nearest cell set in a mask:
the lower envelope of parabolas of Felzenszwalb and Huttenlocher (2012, "Distance transforms
of sampled functions"), once down every column and once along every row, linear in the
cells. The distances are exact: the square root of a whole number of squared cells, as
``scipy.ndimage.distance_transform_edt`` gives them (the test compares the two), without
loading scipy.ndimage (some 20 MB of the daemon's memory for this one function).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["distance_to"]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]


@njit(cache=True, nogil=True)
def _envelope(
    f: FloatArray, n: int, out: FloatArray, v: npt.NDArray[np.int64], z: FloatArray
) -> None:
    """out[q] = min over p of (q - p)^2 + f[p], for the first ``n`` entries; inf where every
    f[p] is inf (no feature on this line)."""
    k = -1
    for q in range(n):
        if f[q] == math.inf:
            continue
        if k < 0:
            k = 0
            v[0] = q
            z[0] = -math.inf
            z[1] = math.inf
            continue
        fq = f[q] + q * q
        s = (fq - (f[v[k]] + v[k] * v[k])) / (2.0 * (q - v[k]))
        while s <= z[k]:
            k -= 1
            s = (fq - (f[v[k]] + v[k] * v[k])) / (2.0 * (q - v[k]))
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = math.inf
    if k < 0:
        for q in range(n):
            out[q] = math.inf
        return
    k = 0
    for q in range(n):
        while z[k + 1] < q:
            k += 1
        d = q - v[k]
        out[q] = d * d + f[v[k]]


@njit(cache=True, nogil=True)
def distance_to(mask: BoolArray) -> FloatArray:
    """[cells] Euclidean distance from every cell to the nearest cell set in ``mask``
    (rows x columns); 0 on the set cells, inf everywhere when none is set."""
    rows, cols = mask.shape
    longest = max(rows, cols)
    f = np.empty(longest)
    line = np.empty(longest)
    v = np.empty(longest, dtype=np.int64)
    z = np.empty(longest + 1)
    squared = np.empty((rows, cols))
    for c in range(cols):
        for r in range(rows):
            f[r] = 0.0 if mask[r, c] else math.inf
        _envelope(f, rows, line, v, z)
        for r in range(rows):
            squared[r, c] = line[r]
    for r in range(rows):
        for c in range(cols):
            f[c] = squared[r, c]
        _envelope(f, cols, line, v, z)
        for c in range(cols):
            squared[r, c] = math.sqrt(line[c])
    return squared

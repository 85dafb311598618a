"""Numba kernels of the costmap: the obstacle layer marked and cleared by scan rays.

The kernels see arrays and scalars only; tests/planning/test_costmap.py checks them.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

__all__ = ["mark_and_clear"]


@njit(cache=True, nogil=True)
def mark_and_clear(
    last_seen: FloatArray,
    origin_i: int,
    origin_j: int,
    cells: IntArray,
    is_hit: npt.NDArray[np.bool_],
    stamp: float,
) -> None:
    """Clear the cells each ray crosses, then mark the cells it ends in if it hit something.

    A cell's ``last_seen`` is the stamp [s] it was last seen occupied, or -inf when free.
    Rays run from the sensor cell (origin_i, origin_j) = (row, column) to ``cells[k]`` by
    Bresenham's line; the end cell itself is only cleared for a miss (a ray that saw nothing).
    Cells outside the grid are skipped; all clearing happens before any marking, so one ray
    never clears what another of the same scan hit, and a ray ending in the same cell as the
    one before it (neighbouring beams on a wall a few metres off: several per cell) is not
    traced again.

    Args:
        last_seen: rows x columns, updated in place.
        origin_i, origin_j: the sensor's cell.
        cells: K x 2 end cells (row, column).
        is_hit: K flags, True where the ray ended on an obstacle.
        stamp: [s] the scan's time.
    """
    rows, cols = last_seen.shape
    for k in range(cells.shape[0]):
        i1 = cells[k, 0]
        j1 = cells[k, 1]
        if k > 0 and i1 == cells[k - 1, 0] and j1 == cells[k - 1, 1]:
            # the ray before ended in the same cell: the same line, already cleared (a miss
            # clears its end cell too, but a hit there is marked after all clearing anyway)
            continue
        di = abs(i1 - origin_i)
        dj = abs(j1 - origin_j)
        si = 1 if i1 > origin_i else -1
        sj = 1 if j1 > origin_j else -1
        err = dj - di
        i = origin_i
        j = origin_j
        while True:
            at_end = i == i1 and j == j1
            if at_end and is_hit[k]:
                break
            if 0 <= i < rows and 0 <= j < cols:
                last_seen[i, j] = -np.inf
            if at_end:
                break
            e2 = 2 * err
            if e2 > -di:
                err -= di
                j += sj
            if e2 < dj:
                err += dj
                i += si
    for k in range(cells.shape[0]):
        if is_hit[k]:
            i1 = cells[k, 0]
            j1 = cells[k, 1]
            if 0 <= i1 < rows and 0 <= j1 < cols:
                last_seen[i1, j1] = stamp

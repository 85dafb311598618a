"""The numba kernel of ``scan.scan_points``: a sweep's ranges to hit and no-return points in
one pass (its numpy twin takes some twenty passes over the beams; three modules convert each
scan, ten times a second). The twin serves callers on the event loop until a warm-up has
loaded the kernel, and checks it in the tests."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["split_ranges", "split_ranges_numpy"]

FloatArray = npt.NDArray[np.float64]


@njit(cache=True, nogil=True)
def split_ranges(
    ranges: FloatArray,
    angle_min: float,
    angle_increment: float,
    range_min: float,
    range_max: float,
    use_max: float,
    mount_x: float,
    mount_y: float,
    mount_yaw: float,
) -> tuple[FloatArray, FloatArray]:
    """Hits and misses (N x 2 and M x 2, [m]) of a sweep, through the mount.

    Beam k, at angle_min + k * angle_increment [rad], is a hit where its range is finite,
    within [range_min, range_max) and at most ``use_max``; a miss, placed at ``use_max``,
    where it is +inf or finite and at least range_max or beyond ``use_max`` (no return: it
    only clears space); dropped otherwise (NaN, -inf, below range_min).
    """
    n = ranges.size
    hits = np.empty((n, 2))
    misses = np.empty((n, 2))
    cos_yaw, sin_yaw = math.cos(mount_yaw), math.sin(mount_yaw)
    n_hits = n_misses = 0
    for k in range(n):
        r = ranges[k]
        if math.isfinite(r):
            if r >= range_max or r > use_max:
                is_hit, reach = False, use_max
            elif r >= range_min:
                is_hit, reach = True, r
            else:
                continue
        elif r > 0.0:  # +inf: no return
            is_hit, reach = False, use_max
        else:
            continue
        angle = angle_min + angle_increment * k
        x, y = reach * math.cos(angle), reach * math.sin(angle)
        out = hits if is_hit else misses
        i = n_hits if is_hit else n_misses
        out[i, 0] = mount_x + cos_yaw * x - sin_yaw * y
        out[i, 1] = mount_y + sin_yaw * x + cos_yaw * y
        if is_hit:
            n_hits += 1
        else:
            n_misses += 1
    return hits[:n_hits].copy(), misses[:n_misses].copy()  # not views of n-row buffers


def split_ranges_numpy(
    ranges: FloatArray,
    angle_min: float,
    angle_increment: float,
    range_min: float,
    range_max: float,
    use_max: float,
    mount_x: float,
    mount_y: float,
    mount_yaw: float,
) -> tuple[FloatArray, FloatArray]:
    """``split_ranges`` in numpy: the same points, without compiling anything."""
    r = ranges
    angles = angle_min + angle_increment * np.arange(r.size)
    finite = np.isfinite(r)
    hit = finite & (r >= range_min) & (r < range_max) & (r <= use_max)
    miss = (~finite & (r > 0)) | (finite & ((r >= range_max) | (r > use_max)))
    local = [
        np.column_stack([reach * np.cos(angles[chosen]), reach * np.sin(angles[chosen])])
        for reach, chosen in ((r[hit], hit), (use_max, miss))
    ]
    c, s = math.cos(mount_yaw), math.sin(mount_yaw)
    rotation = np.array([[c, -s], [s, c]])
    hits, misses = (points @ rotation.T + (mount_x, mount_y) for points in local)
    return hits, misses

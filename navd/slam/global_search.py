"""Finding the robot on a map with no (or a poor) initial guess: multi-level branch and bound.

Candidates are (rotation, block of 2^L x 2^L translations). A block's score is bounded from
above by the sum, under the scan points, of the likelihood field's sliding maximum over
2^L cells; the best bound is expanded first into four blocks of half the size, down to
single translations whose score is exact. The first exact candidate taken off the queue is
therefore the global optimum over the whole search space (Cartographer's fast correlative
matcher follows the same idea). ``relocalize`` then refines it with the local matcher.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam import _grid_kernels as k
from navd.slam.likelihood_field import FIELD_PEAK, LikelihoodField
from navd.slam.matcher import CorrelativeMatcher, Match
from navd.slam.occupancy import OccupancyGrid

__all__ = ["global_search", "relocalize"]

FloatArray = npt.NDArray[np.float64]
# A search window wider than this [m] (half-width) is searched on a coarser grid first:
# coarsened 2 times if that leaves the field at most COARSE_MAX_CELLS cells (the field and
# its six bounds, 4 bytes a cell each: 56 MB), else 4 times, with no cap then (a
# 244 m x 432 m map searched whole: 4.7 million cells, 131 MB). A grid coarser than needed
# makes look-alike places score alike: on the Intel lab's map coarsened 4 times (20 cm
# cells), scores of 0.95-0.99 are found all over it, and for some scans the true place is
# not even among the best eight the search gives (it scores 1.0 on cells aligned with it,
# but the search's cells are not); refining its best then misses. Coarsened 2 times, 25 of
# 27 scans are found from nothing, against 21.
COARSE_ABOVE_M, COARSE_FACTORS, COARSE_MAX_CELLS = 10.0, (2, 4), 2_000_000
# ... and then at full resolution this near what it found [m], [rad].
REFINE_XY_M, REFINE_YAW_RAD = 0.5, math.radians(3.0)


def global_search(
    field: LikelihoodField,
    points: FloatArray,
    *,
    center: Pose2,
    half_width_m: float,
    yaw_window_rad: float = math.pi,
    angle_step_rad: float = math.radians(1.0),
    levels: int = 6,
    min_score: float = -math.inf,
) -> tuple[Pose2, float, int]:
    """The best pose within ``half_width_m`` and ``yaw_window_rad`` of ``center``.

    ``min_score`` is the least mean field value the caller takes: the search drops what
    cannot reach it, so a window without such a pose is given up early (the answer is then
    ``center`` with score 0), and one with it finds the same pose as without.

    Returns:
        (pose, mean field value under the points, candidates expanded).
    """
    res = field.resolution
    px, py, tx, ty = field.in_cells(points, center)
    n_angles = max(1, round(2 * yaw_window_rad / angle_step_rad))
    angles = center.yaw - yaw_window_rad + angle_step_rad * np.arange(n_angles)
    bounds = tuple(field.bound(1 << level) for level in range(levels + 1))
    a, dx, dy, total, expanded = k.branch_and_bound(
        bounds,
        px,
        py,
        np.cos(angles),
        np.sin(angles),
        tx,
        ty,
        math.ceil(half_width_m / res),
        np.zeros(angles.size),  # no prior: every pose within the window is as likely
        0.0,
        -math.inf if min_score == -math.inf else min_score * points.shape[0],
        FIELD_PEAK,
        1.0,
        0.0,
        0.0,  # nor along any axis
    )
    if a < 0:
        return center, 0.0, expanded
    pose = Pose2(
        (tx + 0.5 + dx) * res + field.origin_x,
        (ty + 0.5 + dy) * res + field.origin_y,
        math.remainder(float(angles[a]), 2 * math.pi),
    )
    return pose, total / max(points.shape[0], 1), expanded


def relocalize(
    grid: OccupancyGrid,
    points: FloatArray,
    *,
    guess: Pose2 | None = None,
    search_xy_m: float = 1.0,
    search_yaw_rad: float = math.radians(30.0),
    blur_sigma_m: float = 0.05,
    reach_m: float = 12.0,
) -> Match:
    """Where ``points`` (robot frame) fit ``grid``: around ``guess``, or anywhere if None.

    ``reach_m`` [m] is the longest range among the points (the field around a guess need not
    be larger than that plus the search window). A window wider than ``COARSE_ABOVE_M`` (the
    whole map, say) is searched first on a coarser grid (``COARSE_FACTORS``), then within
    ``REFINE_XY_M`` and ``REFINE_YAW_RAD`` of what that found at full resolution: the field
    and its bounds take a fraction of the memory (a 244 m x 432 m map at 5 cm, searched
    whole, would need seven arrays of 300 MB) and the search a fraction of the time.
    """
    if guess is None:
        center, half = grid.whole()
        field_half, yaw_window = half, math.pi
    else:
        center, half, yaw_window = guess, search_xy_m, search_yaw_rad
        field_half = reach_m + search_xy_m
    if half > COARSE_ABOVE_M:
        # only the part searched: a lost robot's 16 m window on a large map, every scan
        part = grid if guess is None else grid.cropped(center, field_half)
        coarse = part.coarsened(_coarse_factor(field_half / grid.resolution))
        blur = max(blur_sigma_m, coarse.resolution)
        field = coarse.likelihood_field(center, field_half, blur)
        center, _, _ = global_search(
            field, points, center=center, half_width_m=half, yaw_window_rad=yaw_window
        )
        del field  # (and its bounds) before the fine field is made
        half, yaw_window, field_half = REFINE_XY_M, REFINE_YAW_RAD, reach_m + REFINE_XY_M
    field = grid.likelihood_field(center, field_half, blur_sigma_m)
    found, _, _ = global_search(
        field, points, center=center, half_width_m=half, yaw_window_rad=yaw_window
    )
    local = CorrelativeMatcher(search_xy_m=0.1, search_yaw_rad=math.radians(2.0))
    return local.match(field, points, found)


def _coarse_factor(field_half_cells: float) -> int:
    """How many times to coarsen the grid for a field ``field_half_cells`` (full-resolution
    cells) to either side: the least factor that keeps it within ``COARSE_MAX_CELLS``, else
    the largest."""
    cells = (2.0 * field_half_cells) ** 2
    for factor in COARSE_FACTORS:
        if cells <= COARSE_MAX_CELLS * factor**2:
            return factor
    return COARSE_FACTORS[-1]

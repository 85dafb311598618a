"""One lidar revolution as one LaserScan: clockwise degrees from the lidar's front (as the
LDRobot and Slamtec lidars report them) turned into the ROS convention: counter-clockwise
radians, ``angle_min`` -π, a fixed increment, ``null`` where no point fell, the nearest
point of a bin kept (an obstacle is never hidden behind a far one)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.wire import ScanFrame

__all__ = ["turn_scan"]


def turn_scan(
    angles_cw_deg: npt.NDArray[np.float64],
    ranges_m: npt.NDArray[np.float64],
    *,
    stamp: float,
    bins: int,
    range_min_m: float,
    range_max_m: float,
) -> ScanFrame | None:
    """The scan of one turn, or None when no point of it returned.

    Args:
        angles_cw_deg: [deg] each point's angle, clockwise from the lidar's front.
        ranges_m: [m] each point's range; NaN for no return.
        stamp: [s] when the turn began (this computer's clock).
        bins: rays of the scan over the full circle.
        range_min_m, range_max_m: [m] the lidar's valid interval.
    """
    valid = np.isfinite(ranges_m)
    if not valid.any():
        return None
    ccw = np.mod(-np.radians(angles_cw_deg) + math.pi, 2.0 * math.pi) - math.pi
    increment = 2.0 * math.pi / bins
    index = np.clip(((ccw + math.pi) / increment).astype(np.int64), 0, bins - 1)
    binned = np.full(bins, np.nan)
    order = np.argsort(-ranges_m[valid])  # far first, so the nearest is written last
    binned[index[valid][order]] = ranges_m[valid][order]
    return ScanFrame(
        stamp=stamp,
        angle_min=-math.pi,
        angle_increment=increment,
        range_min=range_min_m,
        range_max=range_max_m,
        ranges=[None if not math.isfinite(r) else round(float(r), 3) for r in binned],
    )

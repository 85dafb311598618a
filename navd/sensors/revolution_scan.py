"""One lidar revolution as one LaserScan, in the order the rays were measured.

LDRobot and Slamtec lidars turn clockwise and report clockwise degrees from the lidar's
front. A turn becomes a scan of ``bins`` rays whose first ray is where the turn began and
whose ``angle_increment`` is negative (clockwise, in the ROS convention of counter-clockwise
radians): ray k is measured ``k * time_increment`` after ``stamp``, so a consumer that moves
each ray by the robot's motion meanwhile can. Ray k is centred on its angle (a point goes to
the nearest ray, not the one below it); of several points in one ray the nearest is kept
(an obstacle is never hidden behind a far one), with its intensity.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.wire import ScanFrame

__all__ = ["turn_scan"]

FloatArray = npt.NDArray[np.float64]


def turn_scan(
    angles_cw_deg: FloatArray,
    ranges_m: FloatArray,
    *,
    stamp: float,
    duration_s: float,
    bins: int,
    range_min_m: float,
    range_max_m: float,
    intensities: FloatArray | None = None,
) -> ScanFrame | None:
    """The scan of one turn, or None when no point of it returned.

    Args:
        angles_cw_deg: [deg] each point's angle, clockwise from the lidar's front, in the
            order measured.
        ranges_m: [m] each point's range; NaN for no return.
        stamp: [s, this computer's clock] when the turn's first point was measured.
        duration_s: [s] from the first point to the turn's end (0: not known).
        bins: rays of the scan over the full circle.
        range_min_m, range_max_m: [m] the lidar's valid interval.
        intensities: each point's intensity in the device's units, or None.
    """
    valid = np.isfinite(ranges_m)
    if not valid.any():
        return None
    step_deg = 360.0 / bins
    cells = np.rint(np.asarray(angles_cw_deg) / step_deg).astype(np.int64) % bins
    first = int(cells[0])
    index = (cells - first) % bins
    order = np.argsort(-ranges_m[valid])  # far first, so the nearest is written last
    rays = index[valid][order]
    binned = np.full(bins, np.nan)
    binned[rays] = ranges_m[valid][order]
    angle_min = math.remainder(-math.radians(first * step_deg), 2.0 * math.pi)
    strengths = None
    if intensities is not None:
        kept = np.full(bins, np.nan)
        kept[rays] = np.asarray(intensities, dtype=np.float64)[valid][order]
        strengths = [None if not math.isfinite(v) else float(v) for v in kept]
    return ScanFrame(
        stamp=stamp,
        angle_min=angle_min,
        angle_increment=-2.0 * math.pi / bins,
        range_min=range_min_m,
        range_max=range_max_m,
        time_increment=max(duration_s, 0.0) / bins,
        ranges=[None if not math.isfinite(r) else round(float(r), 3) for r in binned],
        intensities=strengths,
    )

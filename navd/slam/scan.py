"""Scan intake: ranges to points in the robot frame, invalid ranges dropped, voxel filter."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.config import SlamConfig
from navd.lifecycle.messages import LaserScan
from navd.slam.pose import Pose2

__all__ = ["ScanPoints", "laser_points", "scan_points", "voxel_downsample"]

FloatArray = npt.NDArray[np.float64]
IDENTITY = Pose2(0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class ScanPoints:
    """One scan in the robot frame.

    Attributes:
        hits: [m] N x 2 end points of the rays that hit something within range.
        misses: [m] M x 2 points at ``max_range`` along rays that saw nothing (free space).
    """

    hits: FloatArray
    misses: FloatArray


def scan_points(
    ranges: npt.ArrayLike,
    angle_min: float,
    angle_increment: float,
    *,
    range_min: float,
    range_max: float,
    mount: Pose2 = IDENTITY,
    max_range: float | None = None,
) -> ScanPoints:
    """Ranges of a LaserScan as points in the robot frame.

    Readings outside [range_min, range_max), NaN and inf are dropped as hits; readings at or
    beyond ``max_range`` (or beyond range_max, "no return") become misses that only clear
    space up to ``max_range``.

    Args:
        ranges: [m] one per beam.
        angle_min, angle_increment: [rad] beam k is at angle_min + k * angle_increment.
        range_min, range_max: [m] the sensor's valid interval.
        mount: the sensor's pose in the robot frame.
        max_range: [m] longest range used (default: range_max).
    """
    r = np.asarray(ranges, dtype=np.float64)
    angles = angle_min + angle_increment * np.arange(r.size)
    use_max = range_max if max_range is None else min(max_range, range_max)
    finite = np.isfinite(r)
    hit = finite & (r >= range_min) & (r < range_max) & (r <= use_max)
    miss = (~finite & (r > 0)) | (finite & ((r >= range_max) | (r > use_max)))
    hits = np.column_stack([r[hit] * np.cos(angles[hit]), r[hit] * np.sin(angles[hit])])
    misses = np.column_stack([use_max * np.cos(angles[miss]), use_max * np.sin(angles[miss])])
    return ScanPoints(mount.transform(hits), mount.transform(misses))


def laser_points(scan: LaserScan, slam: SlamConfig) -> ScanPoints:
    """A LaserScan's points in the robot frame: the lidar's mount and the range limits come
    from the slam section (``laser_*``, ``min_range_m``, ``max_range_m``)."""
    return scan_points(
        scan.ranges,
        scan.angle_min,
        scan.angle_increment,
        range_min=max(scan.range_min, slam.min_range_m),
        range_max=scan.range_max,
        mount=Pose2(slam.laser_x_m, slam.laser_y_m, slam.laser_yaw_rad),
        max_range=slam.max_range_m,
    )


def voxel_downsample(points: FloatArray, voxel_m: float) -> FloatArray:
    """One point per ``voxel_m`` square cell (the first one seen), order kept."""
    if points.shape[0] == 0:
        return points
    keys = np.floor(points / voxel_m).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    kept: FloatArray = points[np.sort(first)]
    return kept

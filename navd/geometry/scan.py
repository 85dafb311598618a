"""A lidar sweep as points in the robot frame: invalid ranges dropped, no-returns kept apart.

The meaning of the ranges is that of sensor_msgs/LaserScan: beam k points at angle_min +
k * angle_increment in the sensor's frame; readings outside [range_min, range_max), NaN and
inf are not hits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from navd.geometry._scan_kernels import split_ranges, split_ranges_numpy
from navd.geometry.mount import LidarMount
from navd.geometry.pose import IDENTITY, Pose2

__all__ = [
    "ALL_AROUND",
    "FieldOfView",
    "LaserScanLike",
    "ScanPoints",
    "laser_points",
    "scan_points",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class FieldOfView:
    """The bearings a scan's rays cover, in the robot frame: from the lidar at (x_m, y_m),
    counter-clockwise from ``first_rad`` through ``span_rad``; the rest is the lidar's blind
    sector (behind a 270° lidar, say).

    Attributes:
        x_m, y_m: [m] the lidar in the robot frame.
        first_rad: [rad] bearing of the first ray (counter-clockwise order).
        span_rad: [rad] from the first ray to the last, one ray's width added.
    """

    x_m: float
    y_m: float
    first_rad: float
    span_rad: float

    @property
    def all_around(self) -> bool:
        """True when the rays cover every bearing."""
        return self.span_rad >= 2.0 * math.pi - 1e-9

    def unseen(self, points_m: FloatArray) -> BoolArray:
        """Which of N x 2 points [m, robot frame] lie in the blind sector."""
        if self.all_around:
            return np.zeros(points_m.shape[0], dtype=np.bool_)
        bearing = np.arctan2(points_m[:, 1] - self.y_m, points_m[:, 0] - self.x_m)
        offset = np.mod(bearing - self.first_rad, 2.0 * math.pi)
        unseen: BoolArray = offset > self.span_rad
        return unseen


ALL_AROUND = FieldOfView(0.0, 0.0, -math.pi, 2.0 * math.pi)


@dataclass(frozen=True, slots=True)
class ScanPoints:
    """One scan in the robot frame.

    Attributes:
        hits: [m] N x 2 end points of the rays that hit something within range.
        misses: [m] M x 2 points at ``max_range`` along rays that saw nothing (free space).
        view: the bearings its rays cover.
    """

    hits: FloatArray
    misses: FloatArray
    view: FieldOfView = ALL_AROUND


class LaserScanLike(Protocol):
    """What ``laser_points`` reads of a scan (``lifecycle.messages.LaserScan`` is one)."""

    @property
    def ranges(self) -> npt.NDArray[np.floating[Any]]: ...
    @property
    def angle_min(self) -> float: ...
    @property
    def angle_increment(self) -> float: ...
    @property
    def range_min(self) -> float: ...
    @property
    def range_max(self) -> float: ...


def scan_points(
    ranges: npt.ArrayLike,
    angle_min: float,
    angle_increment: float,
    *,
    range_min: float,
    range_max: float,
    mount: Pose2 = IDENTITY,
    max_range: float | None = None,
    loaded_only: bool = False,
) -> ScanPoints:
    """Ranges of a LaserScan as points in the robot frame.

    Readings outside [range_min, range_max), NaN and inf are dropped as hits; readings
    beyond ``max_range`` (or at or beyond range_max, "no return") become misses that only
    clear space up to ``max_range``.

    Args:
        ranges: [m] one per beam.
        angle_min, angle_increment: [rad] beam k is at angle_min + k * angle_increment.
        range_min, range_max: [m] the sensor's valid interval.
        mount: the sensor's pose in the robot frame.
        max_range: [m] longest range used (default: range_max).
        loaded_only: never compile (for a caller on the event loop): until a warm-up has
            loaded the kernel, its numpy twin does the work.
    """
    r = np.ascontiguousarray(ranges, dtype=np.float64).reshape(-1)
    use_max = range_max if max_range is None else min(max_range, range_max)
    split = split_ranges_numpy if loaded_only and not split_ranges.signatures else split_ranges
    # floats always: an int or float32 argument would compile another specialization
    hits, misses = split(
        r,
        float(angle_min),
        float(angle_increment),
        float(range_min),
        float(range_max),
        float(use_max),
        float(mount.x),
        float(mount.y),
        float(mount.yaw),
    )
    step = abs(angle_increment)
    lowest = angle_min + min(angle_increment * (r.size - 1), 0.0)
    view = FieldOfView(
        mount.x, mount.y, lowest + mount.yaw - step / 2, min(step * r.size, 2.0 * math.pi)
    )
    return ScanPoints(hits, misses, view)


def laser_points(
    scan: LaserScanLike, mount: LidarMount, *, max_range_m: float, loaded_only: bool = False
) -> ScanPoints:
    """A scan's points in the robot frame, through the lidar's mount.

    Args:
        scan: the sweep.
        mount: where the lidar sits, and its shortest trusted range (upside down, its
            bearings are mirrored: a ray at +a in the lidar is at -a in base_link).
        max_range_m: [m] longest range the caller uses (SLAM's matching reach, the
            obstacle layer's, the collision guard's); farther readings become misses.
        loaded_only: never compile (for a caller on the event loop), see ``scan_points``.
    """
    flip = -1.0 if mount.upside_down else 1.0
    return scan_points(
        scan.ranges,
        flip * scan.angle_min,
        flip * scan.angle_increment,
        range_min=max(scan.range_min, mount.min_range_m),
        range_max=scan.range_max,
        mount=mount.pose,
        max_range=max_range_m,
        loaded_only=loaded_only,
    )

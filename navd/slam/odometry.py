"""Scan odometry with kiss-icp: the motion prior when the robot has no wheel odometry.

kiss-icp registers 3D point clouds; a 2D scan is embedded at z = 0. Facts measured with
kiss-icp 1.3.0 and guarded here: ``KISSConfig()`` alone raises TypeError (the config comes
from ``load_config(None)`` and is then adjusted); deskewing with all-zero timestamps aborts
the process, so deskew is always off and no timestamps are passed; N x 2 input raises, so
points are always N x 3 float64; a scan with almost no points is skipped (the pose holds).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.config import NavdConfig
from navd.geometry.pose import Pose2

__all__ = ["MIN_POINTS", "ScanOdometry", "ScanOdometrySettings"]

MIN_POINTS = 20  # fewer points than this cannot constrain a 2D registration


@dataclass(frozen=True, slots=True)
class ScanOdometrySettings:
    """What kiss-icp is set up with.

    Attributes:
        voxel_size_m: [m] kiss-icp's voxel size (about 0.1 m suits 2D lidars indoors).
        max_range_m, min_range_m: [m] the ranges kiss-icp keeps.
    """

    voxel_size_m: float
    max_range_m: float
    min_range_m: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> ScanOdometrySettings:
        """The settings the slam and lidar sections describe."""
        slam = config.slam
        return cls(slam.voxel_size_m, slam.max_range_m, config.lidar.min_range_m)


class ScanOdometry:
    """The pose of the robot by registering each scan onto kiss-icp's local map.

    Args:
        settings: kiss-icp's voxel size and range window (fixed for the instance: kiss-icp
            is built with them, so new settings mean a new ScanOdometry).
    """

    def __init__(self, settings: ScanOdometrySettings) -> None:
        from kiss_icp.config.parser import load_config  # noqa: PLC0415 - heavy, first use only
        from kiss_icp.kiss_icp import KissICP  # noqa: PLC0415

        self.settings = settings
        config = load_config(None)
        config.data.deskew = False  # with zero timestamps deskewing aborts the process
        config.data.max_range = settings.max_range_m
        config.data.min_range = settings.min_range_m
        config.mapping.voxel_size = settings.voxel_size_m
        config.registration.max_num_threads = 1  # one worker thread is ours to use
        self._icp = KissICP(config=config)
        self._no_timestamps = np.zeros(0)
        self.skipped = 0

    @property
    def pose(self) -> Pose2:
        """The latest pose in the odometry frame (the first scan's pose is the origin)."""
        t = self._icp.last_pose
        return Pose2(float(t[0, 3]), float(t[1, 3]), math.atan2(float(t[1, 0]), float(t[0, 0])))

    def register(self, points: npt.NDArray[np.float64]) -> Pose2:
        """Register one scan (N x 2 points in the robot frame [m]); returns the new pose."""
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(f"points must be N x 2, got shape {points.shape}")
        finite = points[np.all(np.isfinite(points), axis=1)]
        if finite.shape[0] < MIN_POINTS:
            self.skipped += 1
            return self.pose
        frame = np.zeros((finite.shape[0], 3), dtype=np.float64)
        frame[:, :2] = finite
        self._icp.register_frame(frame, self._no_timestamps)
        return self.pose

"""Scan odometry: the motion prior when the robot has no wheel odometry.

Each scan is registered onto a local map of the scans before it by point-to-point ICP, as
KISS-ICP does (Vizzo et al., RA-L 2023), in the plane: a constant-velocity guess, a
correspondence gate that adapts to how far the guesses have been off, a robust kernel, and a
map of small voxels that forgets what is beyond the sensor's range. The kernels are navd's
own (``_odometry_kernels``) and release the interpreter lock for the whole registration: the
event loop goes on while a worker registers a scan. (kiss-icp itself, which navd used here
before, keeps the lock through its C++: up to 6 ms at a time, during which the daemon's loop
could not run; docs/performance.md.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import IDENTITY, Pose2, wrap_angle
from navd.slam import _odometry_kernels as kernels
from navd.slam.voxel import voxel_downsample

__all__ = ["MIN_POINTS", "ScanOdometry", "ScanOdometrySettings"]

MIN_POINTS = 20  # fewer points than this cannot constrain a 2D registration
INITIAL_SIGMA_M = 2.0  # [m] the guesses' error before any has been measured
MIN_MODEL_ERROR_M = 0.1  # [m] smaller misses of the guess do not teach the gate (KISS-ICP's)
MAX_ITERATIONS = 500
TOLERANCE = 1e-4  # [m and rad] a step smaller than this ends the registration
YAW_SPAN_RAD = math.radians(15.0)  # the yaw searched around the guess before ICP
YAW_COARSE_STEP_RAD = math.radians(1.5)
YAW_FINE_STEP_RAD = math.radians(0.5)
# Around the coarse search's best, which is within half its step (0.75 degrees) of the yaw it
# scored: ICP mends what the fine steps leave.
YAW_FINE_SPAN_RAD = math.radians(0.5)
INITIAL_SLOTS = 4096  # the map table's first length (a power of two)


@dataclass(frozen=True, slots=True)
class ScanOdometrySettings:
    """What scan odometry is set up with.

    Attributes:
        voxel_size_m: [m] the map's voxel size (about 0.1 m suits 2D lidars indoors); scans
            are thinned to one point per half voxel for the map and per 1.5 voxels for the
            registration.
        max_range_m, min_range_m: [m] the ranges kept; the map forgets voxels farther than
            ``max_range_m`` from the robot.
    """

    voxel_size_m: float
    max_range_m: float
    min_range_m: float


class ScanOdometry:
    """The pose of the robot by registering each scan onto a local map of the ones before.

    Args:
        settings: voxel size and range window (fixed for the instance: new settings mean a
            new ScanOdometry).
    """

    def __init__(self, settings: ScanOdometrySettings) -> None:
        self.settings = settings
        self.skipped = 0
        self._pose = IDENTITY
        self._delta = IDENTITY  # the last scan-to-scan motion: the next guess repeats it
        self._error_sse = 0.0  # [m²] sum of the squared misses of the guesses that counted
        self._error_count = 0
        self._keys, self._points, self._counts = _table(INITIAL_SLOTS)
        self._filled = 0  # voxels and tombstones in the table

    @property
    def pose(self) -> Pose2:
        """The latest pose in the odometry frame (the first scan's pose is the origin)."""
        return self._pose

    @property
    def voxels(self) -> int:
        """How many voxels the local map holds."""
        return int(np.count_nonzero(self._keys > kernels.TOMBSTONE))

    def register(self, points: npt.NDArray[np.float64]) -> Pose2:
        """Register one scan (N x 2 points in the robot frame [m]); returns the new pose."""
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(f"points must be N x 2, got shape {points.shape}")
        settings = self.settings
        ranges = np.hypot(points[:, 0], points[:, 1])  # NaN for a non-finite point
        kept = points[(ranges >= settings.min_range_m) & (ranges <= settings.max_range_m)]
        if kept.shape[0] < MIN_POINTS:
            self.skipped += 1
            return self._pose
        voxel = settings.voxel_size_m
        frame = voxel_downsample(kept, 0.5 * voxel)
        source = voxel_downsample(frame, 1.5 * voxel)
        sigma = self._sigma()
        guess = self._pose.compose(self._delta)
        # ICP pairs a point only with map points in the voxels around it, so it cannot mend
        # a yaw more than a few tenths of a degree per metre of range off (a robot that
        # started or stopped turning since the last scan): the yaw is searched first.
        coarse = self._best_yaw(source, guess, YAW_SPAN_RAD, YAW_COARSE_STEP_RAD, fine=False)
        turned = Pose2(guess.x, guess.y, coarse)
        yaw = self._best_yaw(source, turned, YAW_FINE_SPAN_RAD, YAW_FINE_STEP_RAD, fine=True)
        found = self._align(source, Pose2(guess.x, guess.y, yaw), sigma)
        pose = Pose2(float(found[0]), float(found[1]), wrap_angle(float(found[2])))
        self._learn(guess.between(pose))
        self._add(frame, found)
        self._delta = self._pose.between(pose)
        self._pose = pose
        return pose

    def _align(
        self, source: npt.NDArray[np.float64], guess: Pose2, sigma: float
    ) -> npt.NDArray[np.float64]:
        """ICP from ``guess``: the pose found (x [m], y [m], yaw [rad])."""
        found, _, _ = kernels.align(
            source,
            self._keys,
            self._points,
            self._counts,
            self.settings.voxel_size_m,
            np.array(tuple(guess)),
            3.0 * sigma,
            sigma / 3.0,
            MAX_ITERATIONS,
            TOLERANCE,
        )
        return found

    def _best_yaw(
        self,
        source: npt.NDArray[np.float64],
        around: Pose2,
        span_rad: float,
        step_rad: float,
        *,
        fine: bool,
    ) -> float:
        """[rad] The yaw within ``span_rad`` of ``around``'s at which the scan best meets
        the map (``kernels.best_yaw``)."""
        return kernels.best_yaw(
            source,
            self._keys,
            self._points,
            self._counts,
            self.settings.voxel_size_m,
            np.array(tuple(around)),
            span_rad,
            step_rad,
            fine,
        )

    def _sigma(self) -> float:
        """[m] how far the guesses have been off: the root mean square of the misses that
        counted (the gate is three of it, the kernel's scale a third)."""
        if self._error_count == 0:
            return INITIAL_SIGMA_M
        return math.sqrt(self._error_sse / self._error_count)

    def _learn(self, miss: Pose2) -> None:
        """Count a guess's miss: its translation plus the arc its rotation sweeps at the
        longest range."""
        error = math.hypot(miss.x, miss.y) + 2.0 * self.settings.max_range_m * math.sin(
            abs(miss.yaw) / 2.0
        )
        if error > MIN_MODEL_ERROR_M:
            self._error_sse += error * error
            self._error_count += 1

    def _add(self, frame: npt.NDArray[np.float64], pose: npt.NDArray[np.float64]) -> None:
        """Add the scan to the map at ``pose`` and forget what is out of range."""
        voxel = self.settings.voxel_size_m
        if 2 * (self._filled + frame.shape[0]) > self._keys.shape[0]:
            self.compact(incoming=frame.shape[0])
        spacing = voxel / math.sqrt(kernels.MAX_POINTS)
        self._filled += kernels.insert_points(
            self._keys, self._points, self._counts, voxel, frame, pose, spacing
        )
        kernels.drop_far(self._keys, self._points, pose[0], pose[1], self.settings.max_range_m)

    def compact(self, incoming: int = 0) -> None:
        """Copy the map into a table without the dropped voxels' tombstones, long enough for
        its voxels and ``incoming`` new ones (with room to spare). Registration does this by
        itself when the table fills up."""
        voxels = self.voxels
        slots = INITIAL_SLOTS
        while 3 * (voxels + incoming) > slots:  # room for a few scans before the next rehash
            slots *= 2
        keys, points, counts = _table(slots)
        self._filled = kernels.rehash(self._keys, self._points, self._counts, keys, points, counts)
        self._keys, self._points, self._counts = keys, points, counts


def _table(
    slots: int,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """An empty map table of ``slots`` (a power of two) voxels."""
    keys = np.full(slots, kernels.EMPTY, dtype=np.int64)
    return keys, np.zeros((slots, kernels.MAX_POINTS, 2)), np.zeros(slots, dtype=np.int64)

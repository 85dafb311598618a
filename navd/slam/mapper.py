"""Scan-to-map SLAM: each scan is matched onto the map around its predicted pose, then
inserted into the occupancy grid at keyframes.

The prediction is the last pose moved by the odometry since the last scan (wheel odometry,
or scan odometry from kiss-icp); without odometry, the last pose. The map the scan is matched
onto is a likelihood field of the occupancy grid around the prediction, rebuilt when the
grid changed or the robot left its window. Scans whose best match scores below
``min_score`` keep the predicted pose and are not inserted (counted).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from navd.config import SlamConfig
from navd.slam.matcher import CorrelativeMatcher
from navd.slam.occupancy import LikelihoodField, OccupancyGrid
from navd.slam.pose import Pose2
from navd.slam.scan import ScanPoints, voxel_downsample

__all__ = ["Keyframe", "MapperSettings", "ScanMapper", "ScanResult", "mapper_settings"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class MapperSettings:
    """Plain values the mapper runs on (built from the slam config section)."""

    resolution_m: float = 0.05
    voxel_size_m: float = 0.1
    max_range_m: float = 12.0
    search_xy_m: float = 0.3
    search_yaw_rad: float = 0.35
    blur_sigma_m: float = 0.05
    keyframe_distance_m: float = 0.3
    keyframe_angle_rad: float = 0.3
    min_score: float = 0.3
    updating_map: bool = True


def mapper_settings(config: SlamConfig) -> MapperSettings:
    """The mapper's plain values from the ``slam`` config section."""
    return MapperSettings(
        resolution_m=config.resolution_m,
        voxel_size_m=config.voxel_size_m,
        max_range_m=config.max_range_m,
        search_xy_m=config.search_xy_m,
        search_yaw_rad=config.search_yaw_rad,
        blur_sigma_m=config.blur_sigma_m,
        keyframe_distance_m=config.keyframe_distance_m,
        keyframe_angle_rad=config.keyframe_angle_rad,
        min_score=config.min_match_score,
        updating_map=config.updating_map,
    )


@dataclass(frozen=True, slots=True)
class Keyframe:
    """A scan inserted into the map, with the pose it was inserted at."""

    stamp: float
    pose: Pose2
    scan: ScanPoints


@dataclass(frozen=True, slots=True)
class ScanResult:
    """Where a scan was taken.

    Attributes:
        pose: the robot's pose in the map.
        covariance: 3x3 covariance of (x, y, yaw) from the match (the prior's, if unmatched).
        score: mean likelihood under the matched points, in [0, 1] (0: not matched).
        matched: True if scan matching set the pose.
        keyframe: True if the scan was inserted into the map.
    """

    pose: Pose2
    covariance: FloatArray
    score: float
    matched: bool
    keyframe: bool


@dataclass
class _Counts:
    scans: int = 0
    matched: int = 0
    weak_matches: int = 0
    keyframes: int = 0
    fields_built: int = 0


@dataclass
class ScanMapper:
    """Builds the map and tracks the robot on it, one scan at a time."""

    settings: MapperSettings = field(default_factory=MapperSettings)

    def __post_init__(self) -> None:
        s = self.settings
        self.grid = OccupancyGrid(s.resolution_m)
        self.matcher = CorrelativeMatcher(
            search_xy_m=s.search_xy_m, search_yaw_rad=s.search_yaw_rad, reach_m=s.max_range_m / 2
        )
        self.pose: Pose2 | None = None
        self.keyframes: list[Keyframe] = []
        self.counts = _Counts()
        self._last_odom: Pose2 | None = None
        self._field: LikelihoodField | None = None
        self._field_revision = -1
        self._field_center = Pose2(0.0, 0.0, 0.0)

    def configure(self, settings: MapperSettings) -> None:
        """Take new settings (the search window, thresholds, updating_map) at once."""
        self.settings = settings
        self.matcher = CorrelativeMatcher(
            search_xy_m=settings.search_xy_m,
            search_yaw_rad=settings.search_yaw_rad,
            reach_m=settings.max_range_m / 2,
        )
        self._field = None

    def predict(self, odom: Pose2 | None) -> Pose2:
        """The pose now: the last pose moved by the odometry since then."""
        if self.pose is None:
            return odom if odom is not None else Pose2(0.0, 0.0, 0.0)
        if odom is None or self._last_odom is None:
            return self.pose
        return self.pose.compose(self._last_odom.between(odom))

    def set_pose(self, pose: Pose2) -> None:
        """Put the robot at ``pose`` (an initial pose from a person, or a global search)."""
        self.pose = pose

    def add(self, stamp: float, scan: ScanPoints, odom: Pose2 | None = None) -> ScanResult:
        """Locate one scan (robot frame) and add it to the map if it makes a keyframe."""
        s = self.settings
        self.counts.scans += 1
        prior = self.predict(odom)
        self._last_odom = odom
        if self.grid.empty:
            self.pose = prior
            keyframe = self._insert(stamp, prior, scan)
            cov = np.diag([s.resolution_m**2, s.resolution_m**2, 1e-4])
            return ScanResult(prior, cov, 0.0, False, keyframe)
        points = voxel_downsample(scan.hits, s.voxel_size_m)
        match = self.matcher.match(self._field_around(prior), points, prior)
        if match.score < s.min_score or points.shape[0] < 10:
            self.counts.weak_matches += 1
            self.pose = prior
            cov = np.diag([s.search_xy_m**2, s.search_xy_m**2, s.search_yaw_rad**2])
            return ScanResult(prior, cov, match.score, False, False)
        self.counts.matched += 1
        pose = Pose2(float(match.pose.x), float(match.pose.y), float(match.pose.yaw))
        self.pose = pose
        keyframe = self._insert(stamp, pose, scan)
        return ScanResult(pose, match.covariance, match.score, True, keyframe)

    def _insert(self, stamp: float, pose: Pose2, scan: ScanPoints) -> bool:
        s = self.settings
        if not s.updating_map:
            return False
        if self.keyframes:
            moved = self.keyframes[-1].pose.between(pose)
            if (
                np.hypot(moved.x, moved.y) < s.keyframe_distance_m
                and abs(moved.yaw) < s.keyframe_angle_rad
            ):
                return False
        self.grid.insert(pose, scan)
        self.keyframes.append(Keyframe(stamp, pose, scan))
        self.counts.keyframes += 1
        return True

    def _field_around(self, prior: Pose2) -> LikelihoodField:
        """The likelihood field for matching near ``prior`` (reused while still valid)."""
        s = self.settings
        reach = s.max_range_m + s.search_xy_m
        stale = self._field is None or self._field_revision != self.grid.revision
        moved = np.hypot(prior.x - self._field_center.x, prior.y - self._field_center.y)
        if stale or moved > s.max_range_m * 0.25:
            radius = reach + s.max_range_m * 0.25
            self._field = self.grid.likelihood_field(prior, radius, s.blur_sigma_m)
            self._field_revision = self.grid.revision
            self._field_center = prior
            self.counts.fields_built += 1
        assert self._field is not None
        return self._field

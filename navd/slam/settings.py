"""The SLAM room's settings: the mapper's and scan odometry's values and the module's own,
derived once from the ``slam``, ``lidar`` and ``mounts`` sections; the only place the room
reads the config."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from navd.config import LidarConfig, NavdConfig, SlamConfig
from navd.geometry import SensorMounts
from navd.slam.motion_check import MotionLimits
from navd.slam.odometry import ScanOdometrySettings

__all__ = ["MapperSettings", "SlamSettings", "scan_odometry_settings"]


@dataclass(frozen=True, slots=True)
class MapperSettings:
    """Plain values the mapper runs on, built from the slam config section by
    ``from_config`` (the config holds the defaults; those with defaults here are fixed)."""

    resolution_m: float
    voxel_size_m: float
    max_range_m: float
    search_xy_m: float
    search_yaw_rad: float
    blur_sigma_m: float
    keyframe_distance_m: float
    keyframe_angle_rad: float
    min_score: float
    lost_after_scans: int  # 0: never lost (navd.slam.lost_search)
    updating_map: bool
    loop_closure: bool
    loop_search_radius_m: float
    loop_search_xy_m: float
    loop_min_score: float
    prior_weight_per_m2: float
    prior_axis_weight_per_m2: float
    prior_weight_per_rad2: float | None  # None: learned (navd.slam.heading_trust)
    motion_limits: MotionLimits  # what steps between scans are plausible
    loop_search_yaw_rad: float = 0.5
    loop_min_gap: int = 40
    loop_check_every: int = 3
    # Keep every scan's pose (relative to its keyframe) for ``trajectory()``: a replay wants
    # it; a robot running for days does not (it grows with every scan).
    keep_trajectory: bool = False

    @classmethod
    def from_config(cls, config: NavdConfig) -> MapperSettings:
        """The settings the slam section describes."""
        slam = config.slam
        return cls(
            resolution_m=slam.resolution_m,
            voxel_size_m=slam.voxel_size_m,
            max_range_m=slam.max_range_m,
            search_xy_m=slam.search_xy_m,
            search_yaw_rad=slam.search_yaw_rad,
            blur_sigma_m=slam.blur_sigma_m,
            keyframe_distance_m=slam.keyframe_distance_m,
            keyframe_angle_rad=slam.keyframe_angle_rad,
            min_score=slam.min_match_score,
            lost_after_scans=slam.lost_after_scans,
            updating_map=slam.updating_map,
            loop_closure=slam.loop_closure,
            loop_search_radius_m=slam.loop_search_radius_m,
            loop_search_xy_m=slam.loop_search_xy_m,
            loop_min_score=slam.loop_min_score,
            prior_weight_per_m2=slam.prior_weight_per_m2,
            prior_axis_weight_per_m2=slam.prior_axis_weight_per_m2,
            prior_weight_per_rad2=slam.prior_weight_per_rad2,
            motion_limits=MotionLimits(slam.plausible_speed_mps, slam.plausible_turn_radps),
        )

    @classmethod
    def defaults(cls, **overrides: Any) -> MapperSettings:
        """The default config's settings with single values replaced (tests, warm-up)."""
        return dataclasses.replace(cls.from_config(NavdConfig()), **overrides)


def scan_odometry_settings(slam: SlamConfig, lidar: LidarConfig) -> ScanOdometrySettings:
    """Scan odometry's: the voxel size and the ranges kept."""
    return ScanOdometrySettings(slam.voxel_size_m, slam.max_range_m, lidar.min_range_m)


@dataclass(frozen=True, slots=True)
class SlamSettings:
    """The SLAM module's settings.

    Attributes:
        mapper: what the mapper runs on.
        odometry: what scan odometry runs on (without wheel odometry).
        mounts: where each lidar sits.
        map_dir, map_name: where maps are saved, and their default name.
        save_on_shutdown: save the map when the daemon stops.
        autosave_period_s: [s] how often the growing map is saved for a crash (0: never).
        enabled: whether SLAM runs (needs a restart).
        load_map: the map to start from, or None (needs a restart).
    """

    mapper: MapperSettings
    odometry: ScanOdometrySettings
    mounts: SensorMounts
    map_dir: str
    map_name: str
    save_on_shutdown: bool
    autosave_period_s: float = 0.0
    enabled: bool = True
    load_map: str | None = None

    @classmethod
    def from_config(cls, config: NavdConfig) -> SlamSettings:
        """The settings the slam and lidar sections describe."""
        slam = config.slam
        return cls(
            mapper=MapperSettings.from_config(config),
            odometry=scan_odometry_settings(slam, config.lidar),
            mounts=SensorMounts.of(config.mounts, config.lidar),
            map_dir=slam.map_dir,
            map_name=slam.map_name,
            save_on_shutdown=slam.save_on_shutdown,
            autosave_period_s=slam.autosave_period_s,
            enabled=slam.enabled,
            load_map=slam.load_map,
        )

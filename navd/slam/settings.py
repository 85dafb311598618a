"""The mapper's settings: plain values taken from the ``slam`` config section."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from navd.config import NavdConfig

__all__ = ["MapperSettings"]


@dataclass(frozen=True, slots=True)
class MapperSettings:
    """Plain values the mapper runs on, built from the slam config section by
    ``from_config`` (the config holds the defaults; those with defaults here are fixed)."""

    resolution_m: float
    match_resolution_m: float  # the fine map's cells (navd.slam.fine_map)
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
            match_resolution_m=(
                slam.resolution_m / 2
                if slam.match_resolution_m is None
                else slam.match_resolution_m
            ),
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
        )

    @classmethod
    def defaults(cls, **overrides: Any) -> MapperSettings:
        """The default config's settings with single values replaced (tests, warm-up)."""
        return dataclasses.replace(cls.from_config(NavdConfig()), **overrides)

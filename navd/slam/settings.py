"""The mapper's settings: plain values taken from the ``slam`` config section."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from navd.config import SlamConfig

__all__ = ["MapperSettings", "mapper_settings"]


@dataclass(frozen=True, slots=True)
class MapperSettings:
    """Plain values the mapper runs on, built from the slam config section by
    ``mapper_settings`` (the config holds the defaults; those with defaults here are fixed)."""

    resolution_m: float
    voxel_size_m: float
    max_range_m: float
    search_xy_m: float
    search_yaw_rad: float
    blur_sigma_m: float
    keyframe_distance_m: float
    keyframe_angle_rad: float
    min_score: float
    updating_map: bool
    loop_closure: bool
    loop_search_radius_m: float
    loop_search_xy_m: float
    loop_min_score: float
    prior_weight_per_m2: float
    prior_weight_per_rad2: float
    loop_search_yaw_rad: float = 0.5
    loop_min_gap: int = 40
    loop_check_every: int = 3
    # Keep every scan's pose (relative to its keyframe) for ``trajectory()``: a replay wants
    # it; a robot running for days does not (it grows with every scan).
    keep_trajectory: bool = False


def mapper_settings(config: SlamConfig | None = None, **overrides: Any) -> MapperSettings:
    """The mapper's plain values from the ``slam`` config section (default: the defaults).

    ``overrides`` replace single values (tests, replays).
    """
    config = config or SlamConfig()
    return dataclasses.replace(_from_config(config), **overrides)


def _from_config(config: SlamConfig) -> MapperSettings:
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
        loop_closure=config.loop_closure,
        loop_search_radius_m=config.loop_search_radius_m,
        loop_search_xy_m=config.loop_search_xy_m,
        loop_min_score=config.loop_min_score,
        prior_weight_per_m2=config.prior_weight_per_m2,
        prior_weight_per_rad2=config.prior_weight_per_rad2,
    )

"""Compile (or load from the cache) every kernel a replay runs before its first scan: the
daemon's SLAM kernels, and the fine refinement's (a search of one level on a fine map, and
that map's field brought up to date with a keyframe's hits)."""

from __future__ import annotations

import math

import numpy as np

from navd.geometry import IDENTITY, scan_points
from navd.offline.fine_map import fine_refiner, refine_pose
from navd.slam import MapperSettings, OccupancyGrid
from navd.slam import warm_up as warm_up_slam

__all__ = ["warm_up"]


def warm_up() -> None:
    """The daemon's SLAM warm-up, then one scan of a 4 m square room refined on a fine map
    of itself."""
    warm_up_slam()
    settings = MapperSettings.defaults()
    angles = -math.pi + 2 * math.pi * np.arange(90) / 90
    ranges = 2.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))
    scan = scan_points(ranges, -math.pi, 2 * math.pi / 90, range_min=0.1, range_max=10.0)
    fine = OccupancyGrid(settings.resolution_m / 2)
    fine.insert(IDENTITY, scan)
    field = fine.likelihood_field(IDENTITY, 3.0, settings.blur_sigma_m)
    refine_pose(fine_refiner(settings), field, scan.hits, IDENTITY)
    fine.stamp_points(field, scan.hits, settings.blur_sigma_m)

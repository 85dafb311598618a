"""Compile (or load from the cache) every SLAM kernel before the first live scan."""

from __future__ import annotations

import math

import numpy as np

from navd.geometry.pose import Pose2
from navd.geometry.scan import scan_points
from navd.slam.global_search import relocalize
from navd.slam.mapper import ScanMapper
from navd.slam.settings import MapperSettings

__all__ = ["warm_up"]


def warm_up() -> None:
    """Run two scans of a small square room through a throwaway mapper, then find the
    second on the map (the global search of localization and loop closure)."""
    angles = -math.pi + 2 * math.pi * np.arange(90) / 90
    # Distance to the walls of a 4 m square room seen from its centre.
    ranges = 2.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))
    mapper = ScanMapper(MapperSettings.defaults(loop_closure=False))
    for shift in (0.0, 0.05):
        scan = scan_points(
            ranges - shift, -math.pi, 2 * math.pi / 90, range_min=0.1, range_max=10.0
        )
        mapper.add(shift, scan, Pose2(shift, 0.0, 0.0))
    relocalize(mapper.grid, scan.hits)

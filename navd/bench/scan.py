"""Scan benchmark: from a 720-ray LaserScan to an updated pose, as the SLAM worker runs it.

A robot drives through a synthetic 12 m x 8 m room (exact ray casting); each scan goes
through intake (ranges -> points, voxel filter) and the mapper (correlative match onto the
map, keyframe insertion, loop closure checks). Printed: ms per scan p50/p95/max over the
drive (kernels compiled before timing), and how far the tracked pose ends from the truth.
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

from navd.bench.room import cast
from navd.config import NavdConfig
from navd.slam.mapper import ScanMapper, mapper_settings
from navd.slam.pose import Pose2
from navd.slam.scan import scan_points
from navd.slam.warmup import warm_up

__all__ = ["run"]


def run(scans: int = 400, beams: int = 720) -> dict[str, object]:
    """Drive ``scans`` scans of ``beams`` rays around the room; time each scan."""
    warm_up()
    mapper = ScanMapper(mapper_settings(NavdConfig().slam))
    rng = np.random.default_rng(1)
    seconds = []
    truth = Pose2(-4.0, -1.0, 0.0)
    for i in range(scans):
        # A slow loop around the inner wall, 10 Hz, about 0.4 m/s.
        angle = 2 * math.pi * i / scans
        truth = Pose2(4.0 * math.cos(angle) - 0.5, 2.2 * math.sin(angle) - 0.5, angle + math.pi / 2)
        angle_min, increment, ranges = cast(truth, beams)
        ranges = ranges + rng.normal(0.0, 0.01, beams)
        start = time.perf_counter()
        points = scan_points(
            ranges, angle_min, increment, range_min=0.1, range_max=30.0, max_range=12.0
        )
        odom = Pose2(truth.x + 0.02 * i / scans, truth.y, truth.yaw)  # odometry drifting 2 cm
        result = mapper.add(0.1 * i, points, odom)
        seconds.append(time.perf_counter() - start)
    ms = sorted(1e3 * s for s in seconds)
    return {
        "beams": beams,
        "scans": scans,
        "ms_per_scan_p50": round(statistics.median(ms), 3),
        "ms_per_scan_p95": round(ms[int(0.95 * (len(ms) - 1))], 3),
        "ms_per_scan_max": round(ms[-1], 3),
        "final_error_m": round(math.hypot(result.pose.x - truth.x, result.pose.y - truth.y), 4),
        "keyframes": mapper.counts.keyframes,
        "loops_found": mapper.counts.loops_found,
    }

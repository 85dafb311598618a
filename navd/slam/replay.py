"""Offline SLAM over a laser log, as fast as the CPU allows (simulated time).

The same ScanMapper as on the robot. Written into the output folder: the map (map.yaml,
map.pgm, map.npz), map.png (the map with the trajectory), trajectory.tum (stamp x y z qx qy
qz qw per scan) and summary.json.
"""

from __future__ import annotations

import dataclasses
import json
import math
import statistics
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from navd.slam.logfiles import LogScan
from navd.slam.map_io import save_map
from navd.slam.mapper import ScanMapper
from navd.slam.odometry import ScanOdometry
from navd.slam.picture import map_picture
from navd.slam.pose import Pose2
from navd.slam.scan import IDENTITY, scan_points
from navd.slam.settings import MapperSettings

__all__ = ["ReplayResult", "replay", "tum_line"]

Progress = Callable[[int, float], None]


@dataclass(frozen=True, slots=True)
class ReplayResult:
    """What a replay produced: the trajectory and the summary written to summary.json."""

    stamps: list[float]
    poses: list[Pose2]
    summary: dict[str, object]


def tum_line(stamp: float, pose: Pose2) -> str:
    """One TUM trajectory line: stamp x y z qx qy qz qw (a rotation about z)."""
    half = pose.yaw / 2.0
    return f"{stamp:.6f} {pose.x:.6f} {pose.y:.6f} 0 0 0 {math.sin(half):.9f} {math.cos(half):.9f}"


def replay(
    scans: Iterable[LogScan],
    out_dir: Path,
    settings: MapperSettings,
    *,
    mount: Pose2 = IDENTITY,
    min_range_m: float = 0.1,
    odometry: str = "log",
    progress: Progress | None = None,
) -> ReplayResult:
    """Run SLAM over ``scans`` and write the results into ``out_dir``.

    Args:
        odometry: the motion prior: "log" (the log's odometry), "scan" (kiss-icp on the
            scans themselves) or "none" (the last pose).
    """
    if odometry not in ("log", "scan", "none"):
        raise ValueError(f"odometry must be log, scan or none, got {odometry!r}")
    out_dir.mkdir(parents=True, exist_ok=True)
    mapper = ScanMapper(dataclasses.replace(settings, keep_trajectory=True))
    scan_odometry = (
        ScanOdometry(
            voxel_size_m=settings.voxel_size_m,
            max_range_m=settings.max_range_m,
            min_range_m=min_range_m,
        )
        if odometry == "scan"
        else None
    )
    stamps: list[float] = []
    poses: list[Pose2] = []
    per_scan: list[float] = []
    start = time.perf_counter()
    for scan in scans:
        t0 = time.perf_counter()
        points = scan_points(
            scan.ranges,
            scan.angle_min,
            scan.angle_increment,
            range_min=max(scan.range_min, min_range_m),
            range_max=scan.range_max,
            mount=mount,
            max_range=settings.max_range_m,
        )
        if scan_odometry is not None:
            odom: Pose2 | None = scan_odometry.register(points.hits)
        else:
            odom = scan.odom if odometry == "log" else None
        result = mapper.add(scan.stamp, points, odom)
        per_scan.append(time.perf_counter() - t0)
        stamps.append(scan.stamp)
        poses.append(result.pose)
        if progress is not None:
            progress(len(stamps), time.perf_counter() - start)
    wall = time.perf_counter() - start
    # The trajectory as the final pose graph has it (loop closures correct the past too).
    poses = mapper.trajectory()
    keyframes = np.array([tuple(k.pose) for k in mapper.keyframes]).reshape(-1, 3)
    save_map(mapper.grid, out_dir, "map", keyframe_poses=keyframes, image_stem="map")
    map_picture(mapper.grid, poses, out_dir / "map.png")
    (out_dir / "trajectory.tum").write_text(
        "".join(tum_line(t, p) + "\n" for t, p in zip(stamps, poses, strict=True)),
        encoding="ascii",
    )
    ms = sorted(1e3 * s for s in per_scan) or [math.nan]
    counts = mapper.counts
    summary: dict[str, object] = {
        "scans": len(stamps),
        "data_seconds": round(stamps[-1] - stamps[0], 3) if stamps else 0.0,
        "wall_seconds": round(wall, 3),
        "ms_per_scan_p50": round(statistics.median(ms), 3),
        "ms_per_scan_p95": round(ms[int(0.95 * (len(ms) - 1))], 3),
        "matched": counts.matched,
        "weak_matches": counts.weak_matches,
        "exploring": counts.exploring,
        "keyframes": counts.keyframes,
        "loop_checks": mapper.loops.counts.checks,
        "loops_found": mapper.loops.counts.found,
        "loops_ambiguous": mapper.loops.counts.ambiguous,
        "graph_optimizations": counts.optimizations,
        "map_cells": list(mapper.grid.logodds.shape),
    }
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="ascii")
    return ReplayResult(stamps, poses, summary)

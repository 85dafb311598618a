"""Scan benchmark: from a 720-ray LaserScan to an updated pose, as the SLAM worker runs it.

A robot drives through a synthetic 12 m x 8 m room (exact ray casting); each scan goes
through intake (ranges -> points, voxel filter) and the mapper (correlative match onto the
map, keyframe insertion, loop closure checks). Printed: ms per scan p50/p95/max over the
drive (kernels compiled before timing), and how far the tracked pose ends from the truth.

Localization's global search is timed on the map the drive made: the last scan found from
no guess (every rotation and translation of the room) and from a guess 0.5 m / 15° off.
Loop closure re-solves the pose graph off the per-scan path; its cost is printed too: a
synthetic graph of 3000 keyframes (twelve laps of a 20 m circle with drifting odometry, the
size of the fr-clinic graph) with 60 loop edges, solved from the drifted poses.
"""

from __future__ import annotations

import math
import time

import numpy as np

from navd.bench.synthetic_room import cast
from navd.config import NavdConfig
from navd.geometry import Pose2, scan_points
from navd.lifecycle import percentile
from navd.slam import (
    EDGE_WEIGHTS,
    Edge,
    MapperSettings,
    OccupancyGrid,
    ScanMapper,
    optimize,
    relocalize,
    voxel_downsample,
    warm_up,
)

__all__ = ["run"]


def run(scans: int = 400, beams: int = 720) -> dict[str, object]:
    """Drive ``scans`` scans of ``beams`` rays around the room; time each scan."""
    warm_up()
    mapper = ScanMapper(MapperSettings.from_config(NavdConfig()))
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
        "ms_per_scan_p50": round(percentile(ms, 50), 3),
        "ms_per_scan_p95": round(percentile(ms, 95), 3),
        "ms_per_scan_max": round(ms[-1], 3),
        "final_error_m": round(math.hypot(result.pose.x - truth.x, result.pose.y - truth.y), 4),
        "keyframes": mapper.counts.keyframes,
        "loops_found": mapper.loops.counts.found,
        **_relocalize_figures(mapper.grid, voxel_downsample(points.hits, 0.1), truth),
        **_pose_graph_figures(),
    }


def _relocalize_figures(grid: OccupancyGrid, points: np.ndarray, truth: Pose2) -> dict[str, object]:
    """Global search time [ms] (median of 5) from no guess and from a wrong guess, and the
    worst position error [m] of what it found."""
    wrong = truth.compose(Pose2(0.3, 0.4, math.radians(15.0)))
    figures: dict[str, object] = {}
    errors = []
    for name, guess in (("anywhere", None), ("near_guess", wrong)):
        seconds = []
        for _ in range(5):
            start = time.perf_counter()
            found = relocalize(grid, points, guess=guess)
            seconds.append(time.perf_counter() - start)
            errors.append(math.hypot(found.pose.x - truth.x, found.pose.y - truth.y))
        figures[f"relocalize_{name}_ms"] = round(1e3 * percentile(seconds, 50), 1)
    figures["relocalize_error_m"] = round(max(errors), 4)
    return figures


def _pose_graph_figures(nodes: int = 3000, loops: int = 60, repeats: int = 3) -> dict[str, object]:
    """Solve time [ms] (median of ``repeats``) and worst pose error [m] before and after."""
    rng = np.random.default_rng(2)
    per_lap = 250  # 0.5 m apart on a 20 m circle
    step_yaw = 2 * math.pi / per_lap
    chord = 2 * 20.0 * math.sin(step_yaw / 2)
    truth = [
        Pose2(20.0 * math.sin(k * step_yaw), 20.0 - 20.0 * math.cos(k * step_yaw), k * step_yaw)
        for k in range(nodes)
    ]
    edges, drifted = [], [truth[0]]
    for k in range(1, nodes):
        z = Pose2(chord + rng.normal(0, 0.01), rng.normal(0, 0.01), step_yaw + rng.normal(0, 0.002))
        edges.append(Edge(k - 1, k, z, EDGE_WEIGHTS))
        drifted.append(drifted[-1].compose(z))
    for new in rng.choice(np.arange(per_lap, nodes), size=loops, replace=False):
        old = int(new) % per_lap + per_lap * int(rng.integers(0, int(new) // per_lap))
        z = truth[old].between(truth[int(new)])
        edges.append(Edge(old, int(new), z, EDGE_WEIGHTS, robust=True))
    start_poses = np.array(drifted)
    seconds = []
    for _ in range(repeats):
        start = time.perf_counter()
        solved = optimize(start_poses, edges)
        seconds.append(time.perf_counter() - start)
    return {
        "pose_graph_nodes": nodes,
        "pose_graph_solve_ms": round(1e3 * percentile(seconds, 50), 1),
        "pose_graph_error_before_m": round(_worst_offset(start_poses, truth), 3),
        "pose_graph_error_after_m": round(_worst_offset(solved, truth), 3),
    }


def _worst_offset(poses: np.ndarray, truth: list[Pose2]) -> float:
    """[m] the largest distance between a pose and its true position."""
    return float(np.hypot(*(poses[:, :2] - np.array(truth)[:, :2]).T).max())

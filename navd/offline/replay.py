"""Offline SLAM over a laser log, as fast as the CPU allows (simulated time).

The same ScanMapper as on the robot. Written into the output folder: the map (map.yaml,
map.pgm, map.npz with the pose graph), map.png (the map with the trajectory), trajectory.tum
(stamp x y z qx qy qz qw per scan) and summary.json.

Given a saved map (``--map``), the replay goes on mapping it, as a robot started with
``slam.load_map`` does: the first scan is searched for on the whole map, and with the map's
pose graph the new keyframes join it and close loops onto the old ones.

Where the lidar sits on the robot, in order of precedence: a value given for the replay
(``--laser-x`` ...), then the recording's own static transforms (a bag's /tf_static), then
the config's ``[lidar]`` section.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from navd.geometry import LidarMount, Pose2, laser_points
from navd.lifecycle import percentile
from navd.offline.bags import inspect_bag, is_bag, read_bag
from navd.offline.errors import LogFormatError
from navd.offline.logfiles import LogScan, count_scans, open_log
from navd.offline.picture import map_picture
from navd.offline.refinement import FineRefinement
from navd.slam import (
    MapperSettings,
    SavedMap,
    ScanMapper,
    ScanOdometry,
    ScanOdometrySettings,
    jumps,
    relocalize,
    save_map,
    voxel_downsample,
)

__all__ = ["ReplayInput", "ReplayResult", "open_recording", "replay", "replay_mount", "tum_line"]

Progress = Callable[[int, float], None]
FloatArray = npt.NDArray[np.float64]
JUMPS_LISTED = 10  # implausible steps the summary lists (all are counted)


@dataclass(frozen=True, slots=True)
class ReplayResult:
    """What a replay produced: the trajectory and the summary written to summary.json."""

    stamps: list[float]
    poses: list[Pose2]
    summary: dict[str, object]


@dataclass(frozen=True, slots=True)
class ReplayInput:
    """A recording opened for replay.

    Attributes:
        scans: the scans, in order, with the recording's odometry.
        total: how many there are (0 if not known ahead).
        mount: the lidar's pose on the robot as the recording gives it, or None.
    """

    scans: Iterable[LogScan]
    total: int
    mount: Pose2 | None


def open_recording(
    path: Path, *, scan_topic: str | None = None, odom_topic: str | None = None
) -> ReplayInput:
    """The scans of a text log (CARMEN, a ``*_scans.txt`` dump) or a ROS 1/2 bag.

    Args:
        scan_topic, odom_topic: the bag topics (default: found by message type).

    Raises:
        LogFormatError: a format navd cannot read, or a bag without a laser topic.
        OSError: the file cannot be read.
    """
    if is_bag(path):
        bag = inspect_bag(path, scan_topic=scan_topic, odom_topic=odom_topic)
        return ReplayInput(read_bag(bag), bag.scans, bag.mount)
    return ReplayInput(open_log(path), count_scans(path), None)


def replay_mount(
    configured: LidarMount,
    recorded: Pose2 | None,
    *,
    x_m: float | None = None,
    y_m: float | None = None,
    yaw_rad: float | None = None,
) -> LidarMount:
    """The lidar's mount for a replay: each value given here, else the recording's own
    transforms, else the config's (see the module docstring)."""
    base = recorded if recorded is not None else configured.pose
    pose = Pose2(
        base.x if x_m is None else x_m,
        base.y if y_m is None else y_m,
        base.yaw if yaw_rad is None else yaw_rad,
    )
    return LidarMount(pose, configured.min_range_m)


@dataclass
class _Loaded:
    """A saved map the replay goes on: how big its graph was, and where the robot was found.

    Attributes:
        keyframes, edges: the loaded graph's sizes (0 without a map or a graph).
        searching: the next scan is searched for on the whole map.
        found: the pose it was found at, and the search's score.
    """

    keyframes: int = 0
    edges: int = 0
    searching: bool = False
    found: tuple[Pose2, float] | None = None

    @classmethod
    def of(cls, mapper: ScanMapper, start: SavedMap | None) -> _Loaded:
        if start is None:
            return cls()
        mapper.load(start.grid, start.graph)
        return cls(len(mapper.keyframes), len(mapper.edges), searching=True)

    def find(self, mapper: ScanMapper, points: FloatArray) -> None:
        """Search the whole map for the robot at its first scan (one with points)."""
        if points.shape[0] == 0:
            return
        match = relocalize(mapper.grid, points, reach_m=mapper.settings.max_range_m)
        mapper.set_pose(match.pose)
        mapper.forget_odometry()
        self.searching = False
        self.found = (match.pose, match.score)

    def figures(self, mapper: ScanMapper) -> dict[str, object]:
        """The summary's lines on the loaded map: its keyframes, where the robot was found,
        and the loops closed onto its keyframes (the first new edge ties the new keyframes
        to the nearest old one: not a loop)."""
        if self.found is None and not self.searching and not self.keyframes:
            return {}
        new_edges = mapper.edges[self.edges + 1 :]
        loops = sum(1 for e in new_edges if e.robust and e.i < self.keyframes <= e.j)
        pose, score = self.found if self.found is not None else (None, 0.0)
        return {
            "loaded_keyframes": self.keyframes,
            "found_at": None if pose is None else [round(v, 4) for v in pose],
            "found_score": round(score, 4),
            "loops_to_loaded": loops,
        }


def tum_line(stamp: float, pose: Pose2) -> str:
    """One TUM trajectory line: stamp x y z qx qy qz qw (a rotation about z)."""
    half = pose.yaw / 2.0
    return f"{stamp:.6f} {pose.x:.6f} {pose.y:.6f} 0 0 0 {math.sin(half):.9f} {math.cos(half):.9f}"


def replay(
    scans: Iterable[LogScan],
    out_dir: Path,
    settings: MapperSettings,
    *,
    mount: LidarMount,
    odometry: str = "log",
    progress: Progress | None = None,
    start_map: SavedMap | None = None,
    fine_cell_m: float | None = None,
) -> ReplayResult:
    """Run SLAM over ``scans`` and write the results into ``out_dir``.

    Args:
        odometry: the motion prior: "log" (the log's odometry), "scan" (scan odometry on
            the scans themselves) or "none" (the last pose).
        start_map: a saved map to go on mapping (the robot found on it by the first scan).
        fine_cell_m: [m] the fine map's cell the reported poses are refined on (pipeline
            step 6 of docs/slam.md); None: half the map's; the map's own: no refinement.

    Raises:
        LogFormatError: a scan the log cannot give, or no scan at all.
    """
    if odometry not in ("log", "scan", "none"):
        raise ValueError(f"odometry must be log, scan or none, got {odometry!r}")
    out_dir.mkdir(parents=True, exist_ok=True)
    cell_m = settings.resolution_m / 2 if fine_cell_m is None else fine_cell_m
    mapper = ScanMapper(
        dataclasses.replace(settings, keep_trajectory=True),
        fine=FineRefinement.of(settings, cell_m),
    )
    loaded = _Loaded.of(mapper, start_map)
    scan_odometry = (
        ScanOdometry(
            ScanOdometrySettings(settings.voxel_size_m, settings.max_range_m, mount.min_range_m)
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
        points = laser_points(scan, mount, max_range_m=settings.max_range_m)
        if scan_odometry is not None:
            odom: Pose2 | None = scan_odometry.register(points.hits)
        else:
            odom = scan.odom if odometry == "log" else None
        if loaded.searching:
            loaded.find(mapper, voxel_downsample(points.hits, settings.voxel_size_m))
        result = mapper.add(scan.stamp, points, odom)
        per_scan.append(time.perf_counter() - t0)
        stamps.append(scan.stamp)
        poses.append(result.pose)
        if progress is not None:
            progress(len(stamps), time.perf_counter() - start)
    wall = time.perf_counter() - start
    if not stamps:
        raise LogFormatError("it holds no laser scans: nothing to map")
    mapper.finish()
    # The trajectory as the final pose graph has it (loop closures correct the past too).
    poses = mapper.trajectory()
    graph = mapper.graph()
    keyframes = np.array([tuple(k.pose) for k in graph.keyframes]).reshape(-1, 3)
    save_map(mapper.grid, out_dir, "map", keyframe_poses=keyframes, image_stem="map", graph=graph)
    map_picture(mapper.grid, poses, out_dir / "map.png")
    (out_dir / "trajectory.tum").write_text(
        "".join(tum_line(t, p) + "\n" for t, p in zip(stamps, poses, strict=True)),
        encoding="ascii",
    )
    ms = sorted(1e3 * s for s in per_scan) or [math.nan]
    beyond = jumps(stamps, poses, settings.motion_limits)
    summary: dict[str, object] = {
        "scans": len(stamps),
        "data_seconds": round(stamps[-1] - stamps[0], 3) if stamps else 0.0,
        "wall_seconds": round(wall, 3),
        "ms_per_scan_p50": round(percentile(ms, 50), 3),
        "ms_per_scan_p95": round(percentile(ms, 95), 3),
        **mapper.tracking_counts(),
        **loaded.figures(mapper),
        "map_cells": list(mapper.grid.shape),
        # steps of the trajectory no robot makes (slam.plausible_*): the first ones listed
        "implausible_steps": len(beyond),
        "implausible_steps_first": [j.as_dict() for j in beyond[:JUMPS_LISTED]],
    }
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="ascii")
    return ReplayResult(stamps, poses, summary)

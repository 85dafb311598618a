"""navd's scan registration beside its peer, kiss-icp: scan matching onto the map and scan
odometry, each scan timed, on a drive round the synthetic room (part of ``navd bench
compare``)."""

from __future__ import annotations

import importlib.util
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from navd.bench.synthetic_room import cast
from navd.config import NavdConfig
from navd.geometry import Pose2, ScanPoints, scan_points
from navd.lifecycle import percentile
from navd.slam import scan_odometry_settings

if TYPE_CHECKING:
    from navd.slam import ScanOdometrySettings

__all__ = ["run"]


def run(scans: int = 200, beams: int = 720) -> dict[str, object]:
    """navd's scan matching and scan odometry timed on ``scans`` scans of ``beams`` rays
    driving round the synthetic room, beside kiss-icp when it is installed."""
    from navd.slam import (  # noqa: PLC0415
        MapperSettings,
        ScanMapper,
        ScanOdometry,
        warm_up,
    )

    warm_up()
    rng = np.random.default_rng(1)
    drive_scans: list[tuple[Pose2, ScanPoints]] = []
    for i in range(scans):
        angle = 2 * math.pi * i / scans
        truth = Pose2(4.0 * math.cos(angle) - 0.5, 2.2 * math.sin(angle) - 0.5, angle + math.pi / 2)
        angle_min, increment, ranges = cast(truth, beams)
        ranges = ranges + rng.normal(0.0, 0.01, beams)
        points = scan_points(
            ranges, angle_min, increment, range_min=0.1, range_max=30.0, max_range=12.0
        )
        drive_scans.append((truth, points))
    config = NavdConfig()
    mapper = ScanMapper(MapperSettings.from_config(config))
    navd_s = []
    for i, (truth, points) in enumerate(drive_scans):
        start = time.perf_counter()
        mapper.add(0.1 * i, points, truth)
        navd_s.append(time.perf_counter() - start)
    figures: dict[str, object] = {"scan_navd_ms_median": round(1e3 * percentile(navd_s, 50), 3)}
    odometry = ScanOdometry(scan_odometry_settings(config.slam, config.lidar))
    odometry_s, odometry_pose = _register_all(odometry.register, drive_scans)
    figures["scan_odometry_navd_ms_median"] = round(1e3 * percentile(odometry_s, 50), 3)
    figures["scan_odometry_navd_end_error_m"] = _end_error(odometry_pose, drive_scans)
    if importlib.util.find_spec("kiss_icp") is None:
        return figures
    peer = _kiss_icp(scan_odometry_settings(config.slam, config.lidar))
    peer_s, peer_pose = _register_all(peer, drive_scans)
    figures["scan_kiss_icp_ms_median"] = round(1e3 * percentile(peer_s, 50), 3)
    figures["scan_ratio"] = round(percentile(navd_s, 50) / percentile(peer_s, 50), 3)
    figures["scan_odometry_kiss_icp_end_error_m"] = _end_error(peer_pose, drive_scans)
    figures["scan_odometry_ratio"] = round(percentile(odometry_s, 50) / percentile(peer_s, 50), 3)
    return figures


def _register_all(
    register: Callable[[np.ndarray], Pose2], drive_scans: list[tuple[Pose2, ScanPoints]]
) -> tuple[list[float], Pose2]:
    """[s] each scan's registration, and the pose after the last."""
    seconds = []
    pose = Pose2(0.0, 0.0, 0.0)
    for _, points in drive_scans:
        start = time.perf_counter()
        pose = register(points.hits)
        seconds.append(time.perf_counter() - start)
    return seconds, pose


def _end_error(pose: Pose2, drive_scans: list[tuple[Pose2, ScanPoints]]) -> float:
    """[m] how far odometry's last pose (its frame starts at the first scan) is from the
    truth's motion over the drive."""
    moved = drive_scans[0][0].between(drive_scans[-1][0])
    return round(math.hypot(pose.x - moved.x, pose.y - moved.y), 4)


def _kiss_icp(settings: ScanOdometrySettings) -> Callable[[np.ndarray], Pose2]:
    """kiss-icp set up as navd's scan odometry is (voxel size, ranges, one thread), the 2D
    scan embedded at z = 0; a function of N x 2 points to the new pose.

    With zero timestamps its deskewing aborts the process, so it is off and none are given;
    ``KISSConfig()`` alone raises TypeError, so the config comes from ``load_config(None)``.
    """
    from kiss_icp.config.parser import load_config  # noqa: PLC0415 - a dev-only peer
    from kiss_icp.kiss_icp import KissICP  # noqa: PLC0415

    config = load_config(None)
    config.data.deskew = False
    config.data.max_range = settings.max_range_m
    config.data.min_range = settings.min_range_m
    config.mapping.voxel_size = settings.voxel_size_m
    config.registration.max_num_threads = 1
    icp = KissICP(config=config)
    no_timestamps = np.zeros(0)

    def register(points: np.ndarray) -> Pose2:
        frame = np.zeros((points.shape[0], 3))
        frame[:, :2] = points
        icp.register_frame(frame, no_timestamps)
        t = icp.last_pose
        return Pose2(float(t[0, 3]), float(t[1, 3]), math.atan2(float(t[1, 0]), float(t[0, 0])))

    return register

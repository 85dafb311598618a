"""What the robot's other sensors' readings are as obstacle points in the robot frame.

A range sensor's reading is the nearest thing somewhere in its cone: it becomes points
along the arc at that range across the cone (``CONE_STEP_RAD`` apart), which mark obstacles
and stop the robot as a lidar's hits do; a clear cone becomes misses at its reach, which
clear what it marked before. A depth camera's points, turned into base_link, are obstacles
where they lie between the band's heights (above the floor, below the robot's top: the
table top a 2D lidar passes under) and within its reach; their place on the floor is what
counts.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.geometry.body_mounts import DepthMount
from navd.geometry.pose import Pose2
from navd.geometry.scan import FieldOfView, ScanPoints

__all__ = ["CONE_STEP_RAD", "band_points", "cone_points"]

FloatArray = npt.NDArray[np.float64]

CONE_STEP_RAD = math.radians(5.0)  # points across a range sensor's cone


def cone_points(
    range_m: float, fov_rad: float, max_range_m: float, mount: Pose2, reach_m: float
) -> ScanPoints:
    """A range sensor's reading as points in base_link: hits along the arc at ``range_m``
    across the cone (none when it is beyond ``max_range_m`` or ``reach_m``), misses at the
    reach (or just short of the hit) that clear the cone."""
    count = max(3, math.ceil(fov_rad / CONE_STEP_RAD) + 1)
    bearings = mount.yaw + np.linspace(-fov_rad / 2.0, fov_rad / 2.0, count)
    c, s = np.cos(bearings), np.sin(bearings)
    seen = range_m <= max_range_m and range_m <= reach_m
    free = min(range_m, max_range_m, reach_m)
    hits = np.column_stack([mount.x + range_m * c, mount.y + range_m * s]) if seen else None
    misses = np.column_stack([mount.x + free * c, mount.y + free * s]) if not seen else None
    view = FieldOfView(mount.x, mount.y, mount.yaw - fov_rad / 2.0, fov_rad)
    return ScanPoints(
        hits if hits is not None else np.empty((0, 2)),
        misses if misses is not None else np.empty((0, 2)),
        view,
    )


def band_points(points_m: FloatArray, mount: DepthMount) -> ScanPoints:
    """A depth camera's points (N x 3 in its body axes) as obstacle points in base_link:
    those between the band's heights and within its reach, on the floor."""
    robot = points_m @ mount.rotation.T + np.asarray(mount.position_m)
    z = robot[:, 2]
    within = (z >= mount.min_height_m) & (z <= mount.max_height_m)
    dx = robot[:, 0] - mount.position_m[0]
    dy = robot[:, 1] - mount.position_m[1]
    within &= np.hypot(dx, dy) <= mount.max_range_m
    hits = np.ascontiguousarray(robot[within, :2])
    if hits.shape[0]:
        bearings = np.arctan2(hits[:, 1] - mount.position_m[1], hits[:, 0] - mount.position_m[0])
        first, last = float(bearings.min()), float(bearings.max())
        view = FieldOfView(mount.position_m[0], mount.position_m[1], first, last - first)
    else:
        view = FieldOfView(mount.position_m[0], mount.position_m[1], 0.0, 0.0)
    return ScanPoints(hits, np.empty((0, 2)), view)

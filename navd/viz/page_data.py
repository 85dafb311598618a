"""What the operator page draws, as small JSON messages (a phone decodes JSON natively;
the Foxglove channels' protobuf would need a library the page does not carry).

All positions are in the map frame [m]; angles [rad]. Topics:

- ``/page/info``: the robot's name and outline, the keep-out zones, teleop's top speeds and
  whether viewers may command and drive;
- ``/page/map``: the occupancy grid (int8 per cell as ROS: -1 unknown, 0..100 occupied
  percent; base64), coarsened when it has more than MAX_PAGE_CELLS cells;
- ``/page/pose``: the fused pose and its 1-sigma position error;
- ``/page/scan``: the latest scan's hits in the map frame: ``points_cm``, base64 of
  little-endian int32 [x0, y0, x1, y1...] in cm (JSON numbers cost the loop ten times more);
- ``/page/route``: the global route; ``/page/goal``: the goal.

Each message keeps to what viewers read of a JSON schema (``view_schemas``): a point is
``{x, y}``, an unknown value is left out.
"""

from __future__ import annotations

import base64
import math
from typing import Any

import numpy as np
import numpy.typing as npt

from navd.geometry import CIRCLE, LidarMount, laser_points
from navd.lifecycle.messages import Goal, LaserScan, MapUpdate, Path, PoseEstimate
from navd.viz.settings import VizSettings

__all__ = [
    "MAX_PAGE_CELLS",
    "PAGE_POSE_PERIOD_S",
    "PAGE_SCAN_PERIOD_S",
    "coarsened",
    "goal_message",
    "info_message",
    "map_message",
    "pose_message",
    "route_message",
    "scan_message",
]

# A map larger than this is sent coarsened (a phone draws a million cells at ease).
MAX_PAGE_CELLS = 1_000_000
# A phone needs no more than this: the page's scan and pose come at most every [s].
PAGE_SCAN_PERIOD_S = 0.2
PAGE_POSE_PERIOD_S = 0.1
# Scan points farther than this are not drawn [m]; at most this many are sent.
PAGE_SCAN_RANGE_M = 30.0
MAX_SCAN_POINTS = 1440


def coarsened(occupancy: npt.NDArray[np.int8], factor: int) -> npt.NDArray[np.int8]:
    """The grid with each ``factor`` x ``factor`` block as one cell: its highest value, so
    an occupied cell shows over free ones and a free one over unknown ones (-1)."""
    if factor <= 1:
        return occupancy
    rows, cols = occupancy.shape
    padded = np.full((-(-rows // factor) * factor, -(-cols // factor) * factor), -1, dtype=np.int8)
    padded[:rows, :cols] = occupancy
    blocks = padded.reshape(padded.shape[0] // factor, factor, padded.shape[1] // factor, factor)
    reduced: npt.NDArray[np.int8] = blocks.max(axis=(1, 3))
    return reduced


def _xy(point: Any) -> dict[str, float]:
    """A point [m] as the page's JSON has it."""
    return {"x": float(point[0]), "y": float(point[1])}


def map_message(update: MapUpdate) -> dict[str, Any]:
    """The map as the page draws it (row 0 at the origin's y, as ROS stores it)."""
    occupancy = np.asarray(update.occupancy)
    factor = max(1, math.ceil(math.sqrt(occupancy.size / MAX_PAGE_CELLS)))
    cells = np.ascontiguousarray(coarsened(occupancy, factor))
    return {
        "stamp": update.stamp,
        "width": int(cells.shape[1]),
        "height": int(cells.shape[0]),
        "resolution": update.resolution_m * factor,
        "origin": {"x": update.origin_x_m, "y": update.origin_y_m},
        "cells": base64.b64encode(cells.tobytes()).decode("ascii"),
    }


def pose_message(pose: PoseEstimate) -> dict[str, Any]:
    """The pose with its 1-sigma position error [m]."""
    cov = pose.covariance
    return {
        "stamp": pose.stamp,
        "x": round(pose.x_m, 4),
        "y": round(pose.y_m, 4),
        "yaw": round(pose.yaw_rad, 4),
        "std_xy": round(math.sqrt(max(cov[0, 0], cov[1, 1], 0.0)), 4),
        "linear": round(pose.linear_mps, 3),
        "angular": round(pose.angular_radps, 3),
    }


def scan_message(scan: LaserScan, pose: PoseEstimate, mount: LidarMount) -> dict[str, Any]:
    """The scan's hits in the map frame, seen from ``pose``, and which lidar saw them."""
    # on the event loop: never compiles (before the warm-ups, numpy does it)
    hits = laser_points(scan, mount, max_range_m=PAGE_SCAN_RANGE_M, loaded_only=True).hits
    if len(hits) > MAX_SCAN_POINTS:
        hits = hits[:: -(-len(hits) // MAX_SCAN_POINTS)]
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    x = pose.x_m + c * hits[:, 0] - s * hits[:, 1]
    y = pose.y_m + s * hits[:, 0] + c * hits[:, 1]
    cm = np.rint(np.column_stack((x, y)).ravel() * 100.0).astype("<i4")
    return {
        "stamp": scan.stamp,
        "lidar": scan.device_id,
        "points_cm": base64.b64encode(cm.tobytes()).decode("ascii"),
    }


def route_message(path: Path) -> dict[str, Any]:
    """The route's points."""
    points = np.round(np.asarray(path.points_m, dtype=np.float64), 3).tolist()
    return {"stamp": path.stamp, "goal_id": path.goal_id, "points": [_xy(p) for p in points]}


def goal_message(goal: Goal) -> dict[str, Any]:
    """Where the goal is (no yaw: any heading)."""
    heading = {} if goal.yaw_rad is None else {"yaw": goal.yaw_rad}
    return {"goal_id": goal.goal_id, "x": goal.x_m, "y": goal.y_m, **heading}


def info_message(settings: VizSettings) -> dict[str, Any]:
    """What the page needs once: the robot, its zones, its speeds, the token rule."""
    footprint = settings.footprint
    outline = (
        {"kind": "circle", "radius": footprint.half_length_m}
        if footprint.kind == CIRCLE
        else {
            "kind": "rectangle",
            "length": 2 * footprint.half_length_m,
            "width": 2 * footprint.half_width_m,
        }
    )
    return {
        "robot": settings.robot_name,
        "footprint": outline,
        "keep_out": [{"points": [_xy(p) for p in zone]} for zone in settings.keep_out_zones],
        "teleop": {
            "max_linear": settings.teleop_linear_mps,
            "max_angular": settings.teleop_angular_radps,
        },
        "commands": settings.commands,
        "teleop_enabled": settings.teleop_enabled,
    }

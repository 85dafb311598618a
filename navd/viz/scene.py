"""navd's messages as Foxglove's well-known messages: what the live view draws.

Frames follow REP-105: ``map`` (the SLAM map), ``odom``, ``base_link`` (the robot: x forward,
y left) and ``laser`` (the lidar, placed by the lidar mount). navd fuses one pose in the map
frame, so ``map -> odom`` is the identity and ``odom -> base_link`` carries the fused pose.
Times are the daemon clock's seconds (``stamp``) plus ``offset_s``: the node passes the
difference between the wall clock and the daemon clock when it started, so the view and its
recordings show real dates.

Plain functions of plain values, so each can be tested without a server.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    FrameTransform,
    FrameTransforms,
    Grid,
    LaserScan,
    LinePrimitive,
    LinePrimitiveLineType,
    Odometry,
    PackedElementField,
    PackedElementFieldNumericType,
    Point3,
    Pose,
    PoseInFrame,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    Timestamp,
    Vector2,
    Vector3,
)

from navd.geometry import CIRCLE, Footprint, LidarMount, Pose2
from navd.lifecycle.messages import (
    CostmapUpdate,
    Goal,
    LocalTrajectory,
    MapUpdate,
    Path,
    PoseEstimate,
)
from navd.lifecycle.messages import LaserScan as NavdScan
from navd.planning import GridFrame

__all__ = [
    "BASE_LINK",
    "LASER",
    "MAP",
    "ODOM",
    "as_timestamp",
    "footprint_scene",
    "frame_tree",
    "goal_scene",
    "keep_out_scene",
    "laser_scan",
    "nanoseconds",
    "occupancy_grid",
    "odometry",
    "pose_in_frame",
    "route_scene",
    "trajectory_scene",
    "zone_grid",
]

MAP, ODOM, BASE_LINK, LASER = "map", "odom", "base_link", "laser"
CIRCLE_SIDES = 32  # a circular footprint is drawn as this many-sided polygon

ROUTE_COLOR = Color(r=0.1, g=0.6, b=1.0, a=1.0)
FOOTPRINT_COLOR = Color(r=1.0, g=0.8, b=0.1, a=1.0)
GOAL_COLOR = Color(r=0.2, g=0.9, b=0.3, a=1.0)
TRAJECTORY_COLOR = Color(r=1.0, g=0.5, b=0.0, a=1.0)
KEEP_OUT_COLOR = Color(r=1.0, g=0.2, b=0.2, a=1.0)


def nanoseconds(stamp_s: float) -> int:
    """[ns] a time in seconds."""
    return round(stamp_s * 1e9)


def as_timestamp(stamp_s: float) -> Timestamp:
    """A time in seconds as a Foxglove timestamp."""
    ns = nanoseconds(stamp_s)
    return Timestamp(ns // 1_000_000_000, ns % 1_000_000_000)


def _yaw(yaw_rad: float) -> Quaternion:
    """The rotation about +z by ``yaw_rad``."""
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw_rad / 2.0), w=math.cos(yaw_rad / 2.0))


def _pose(x_m: float, y_m: float, yaw_rad: float) -> Pose:
    return Pose(position=Vector3(x=x_m, y=y_m, z=0.0), orientation=_yaw(yaw_rad))


def occupancy_grid(update: MapUpdate | CostmapUpdate, *, offset_s: float = 0.0) -> Grid:
    """The SLAM map (or the costmap) as a grid of int8 ``occupancy`` cells (-1 unknown,
    0..100) in ``map``; row 0 is the lowest y, as in the map."""
    cols = update.occupancy.shape[1]
    return Grid(
        timestamp=as_timestamp(update.stamp + offset_s),
        frame_id=MAP,
        pose=_pose(update.origin_x_m, update.origin_y_m, 0.0),
        column_count=cols,
        cell_size=Vector2(x=update.resolution_m, y=update.resolution_m),
        row_stride=cols,
        cell_stride=1,
        fields=[
            PackedElementField(name="occupancy", offset=0, type=PackedElementFieldNumericType.Int8)
        ],
        data=np.ascontiguousarray(update.occupancy, dtype=np.int8).tobytes(),
    )


def zone_grid(frame: GridFrame, values: npt.NDArray[np.int8], stamp_s: float) -> Grid:
    """A zone mask as a grid of int8 ``occupancy`` cells in ``map`` (row 0 the lowest y)."""
    return Grid(
        timestamp=as_timestamp(stamp_s),
        frame_id=MAP,
        pose=_pose(frame.origin_x_m, frame.origin_y_m, 0.0),
        column_count=frame.cols,
        cell_size=Vector2(x=frame.resolution_m, y=frame.resolution_m),
        row_stride=frame.cols,
        cell_stride=1,
        fields=[
            PackedElementField(name="occupancy", offset=0, type=PackedElementFieldNumericType.Int8)
        ],
        data=np.ascontiguousarray(values, dtype=np.int8).tobytes(),
    )


def laser_scan(scan: NavdScan, mount: LidarMount, *, offset_s: float = 0.0) -> LaserScan:
    """The scan in ``base_link`` at its lidar's mount; rays outside [range_min, range_max]
    (no return, or not to be trusted) and shorter than the mount's ``min_range_m`` (the
    robot's own body) are NaN, which the view leaves out. An upside-down lidar's bearings
    are mirrored."""
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    valid = (ranges >= max(scan.range_min, mount.min_range_m)) & (ranges <= scan.range_max)
    shown = np.where(valid, ranges, np.nan)
    last = scan.angle_min + scan.angle_increment * max(ranges.size - 1, 0)
    flip = -1.0 if mount.upside_down else 1.0
    at = mount.pose
    return LaserScan(
        timestamp=as_timestamp(scan.stamp + offset_s),
        frame_id=BASE_LINK,
        pose=_pose(at.x, at.y, at.yaw),
        start_angle=flip * scan.angle_min,
        end_angle=flip * last,
        ranges=shown.tolist(),
    )


def frame_tree(pose: PoseEstimate, lidar: Pose2, *, offset_s: float = 0.0) -> FrameTransforms:
    """map -> odom (identity), odom -> base_link (the fused pose), base_link -> laser (the
    lidar's mount)."""
    t = as_timestamp(pose.stamp + offset_s)

    def transform(parent: str, child: str, x: float, y: float, yaw: float) -> FrameTransform:
        return FrameTransform(
            timestamp=t,
            parent_frame_id=parent,
            child_frame_id=child,
            translation=Vector3(x=x, y=y, z=0.0),
            rotation=_yaw(yaw),
        )

    return FrameTransforms(
        transforms=[
            transform(MAP, ODOM, 0.0, 0.0, 0.0),
            transform(ODOM, BASE_LINK, pose.x_m, pose.y_m, pose.yaw_rad),
            transform(BASE_LINK, LASER, lidar.x, lidar.y, lidar.yaw),
        ]
    )


def pose_in_frame(pose: PoseEstimate, *, offset_s: float = 0.0) -> PoseInFrame:
    """The fused pose in ``map``, as every viewer's 3D panel draws it (Lichtblick does not
    draw Odometry)."""
    return PoseInFrame(
        timestamp=as_timestamp(pose.stamp + offset_s),
        frame_id=MAP,
        pose=_pose(pose.x_m, pose.y_m, pose.yaw_rad),
    )


def odometry(pose: PoseEstimate, *, offset_s: float = 0.0) -> Odometry:
    """The fused pose in ``map`` with its covariance (6 x 6, row-major over x, y, z, roll,
    pitch, yaw; navd estimates x, y and yaw) and its velocity in ``base_link``."""
    cov3 = np.asarray(pose.covariance, dtype=np.float64)
    cov6 = np.zeros((6, 6))
    index = [0, 1, 5]  # x, y, yaw among x, y, z, roll, pitch, yaw
    cov6[np.ix_(index, index)] = cov3
    return Odometry(
        timestamp=as_timestamp(pose.stamp + offset_s),
        frame_id=MAP,
        body_frame_id=BASE_LINK,
        pose=_pose(pose.x_m, pose.y_m, pose.yaw_rad),
        linear_velocity=Vector3(x=pose.linear_mps, y=0.0, z=0.0),
        angular_velocity=Vector3(x=0.0, y=0.0, z=pose.angular_radps),
        pose_covariance=cov6.ravel().tolist(),
    )


def _line(
    points_m: npt.NDArray[np.float64], color: Color, kind: LinePrimitiveLineType, width_m: float
) -> LinePrimitive:
    return LinePrimitive(
        type=kind,
        pose=_pose(0.0, 0.0, 0.0),
        thickness=width_m,
        points=[Point3(x=float(x), y=float(y), z=0.0) for x, y in points_m],
        color=color,
    )


def _entity(frame_id: str, entity_id: str, stamp_s: float, **primitives: Any) -> SceneUpdate:
    """A scene update of one entity, replacing the last with the same id."""
    return SceneUpdate(
        entities=[
            SceneEntity(
                timestamp=as_timestamp(stamp_s), frame_id=frame_id, id=entity_id, **primitives
            )
        ]
    )


def route_scene(path: Path, *, offset_s: float = 0.0) -> SceneUpdate:
    """The global route as a line in ``map`` (entity ``route``, replaced by the next)."""
    line = _line(path.points_m, ROUTE_COLOR, LinePrimitiveLineType.LineStrip, 0.03)
    return _entity(MAP, "route", path.stamp + offset_s, lines=[line])


def trajectory_scene(trajectory: LocalTrajectory, *, offset_s: float = 0.0) -> SceneUpdate:
    """The local planner's chosen rollout as a line in ``map`` (entity ``trajectory``)."""
    line = _line(trajectory.points_m, TRAJECTORY_COLOR, LinePrimitiveLineType.LineStrip, 0.04)
    return _entity(MAP, "trajectory", trajectory.stamp + offset_s, lines=[line])


def footprint_scene(footprint: Footprint, stamp_s: float) -> SceneUpdate:
    """The robot's outline in ``base_link`` (it moves with the robot)."""
    if footprint.kind == CIRCLE:
        angles = 2.0 * np.pi * np.arange(CIRCLE_SIDES) / CIRCLE_SIDES
        r = footprint.half_length_m
        outline = np.column_stack([r * np.cos(angles), r * np.sin(angles)])
    else:
        hx, hy = footprint.half_length_m, footprint.half_width_m
        outline = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
    line = _line(outline, FOOTPRINT_COLOR, LinePrimitiveLineType.LineLoop, 0.02)
    return _entity(BASE_LINK, "footprint", stamp_s, frame_locked=True, lines=[line])


def goal_scene(goal: Goal, *, offset_s: float = 0.0) -> SceneUpdate:
    """The goal as an arrow in ``map`` (pointing along its yaw, or +x when any will do)."""
    arrow = ArrowPrimitive(
        pose=_pose(goal.x_m, goal.y_m, goal.yaw_rad or 0.0),
        shaft_length=0.3,
        shaft_diameter=0.05,
        head_length=0.15,
        head_diameter=0.12,
        color=GOAL_COLOR,
    )
    return _entity(MAP, "goal", goal.stamp + offset_s, arrows=[arrow])


def keep_out_scene(
    zones: tuple[tuple[tuple[float, float], ...], ...], stamp_s: float
) -> SceneUpdate:
    """The keep-out zones as closed outlines in ``map`` (one entity, all zones)."""
    lines = [
        _line(
            np.asarray(zone, dtype=np.float64), KEEP_OUT_COLOR, LinePrimitiveLineType.LineLoop, 0.04
        )
        for zone in zones
    ]
    return _entity(MAP, "keep_out", stamp_s, lines=lines)

"""What the operator page receives: the map (coarsened when large), the scan in the map
frame, the pose and its error, the robot's outline and the rules for commands."""

from __future__ import annotations

import base64
import math

import numpy as np

from navd.config import NavdConfig
from navd.geometry import LidarMount
from navd.lifecycle.messages import LaserScan, MapUpdate, PoseEstimate
from navd.viz import page_data
from navd.viz.settings import VizSettings


def test_coarsening_keeps_obstacles_over_free_over_unknown() -> None:
    grid = np.full((5, 5), -1, dtype=np.int8)
    grid[0, 0] = 0  # one free cell in the first block
    grid[0, 3] = 100  # an obstacle beside free cells in the second
    grid[1, 2] = 0
    coarse = page_data.coarsened(grid, 2)
    assert coarse.shape == (3, 3)  # the ragged edge is padded as unknown
    assert coarse[0, 0] == 0 and coarse[0, 1] == 100 and coarse[2, 2] == -1


def test_a_large_map_is_sent_coarsened_with_its_resolution_scaled() -> None:
    occupancy = np.zeros((1500, 1000), dtype=np.int8)
    occupancy[700:702, :] = 100
    update = MapUpdate(
        stamp=1.0,
        received=1.0,
        revision=1,
        resolution_m=0.05,
        origin_x_m=-3.0,
        origin_y_m=2.0,
        occupancy=occupancy,
    )
    message = page_data.map_message(update)
    assert (message["height"], message["width"]) == (750, 500)
    assert message["resolution"] == 0.1 and message["origin"] == {"x": -3.0, "y": 2.0}
    cells = np.frombuffer(base64.b64decode(message["cells"]), dtype=np.int8).reshape(750, 500)
    assert (cells[350, :] == 100).all() and (cells[:349] == 0).all()


def test_scan_points_are_placed_in_the_map_frame_from_the_pose() -> None:
    ranges = np.full(4, np.nan, dtype=np.float32)
    ranges[0] = 2.0  # one ray straight ahead of the lidar
    scan = LaserScan(
        stamp=1.0,
        received=1.0,
        device_id="l",
        angle_min=0.0,
        angle_increment=math.pi / 2,
        ranges=ranges,
        range_min=0.1,
        range_max=10.0,
    )
    pose = PoseEstimate(
        stamp=1.0,
        received=1.0,
        x_m=1.0,
        y_m=1.0,
        yaw_rad=math.pi / 2,
        covariance=np.diag([0.04, 0.01, 0.01]),
    )
    mount = LidarMount.of(NavdConfig.model_validate({"lidar": {"x_m": 0.1}}).lidar)
    packed = page_data.scan_message(scan, pose, mount)["points_cm"]
    points_cm = np.frombuffer(base64.b64decode(packed), dtype="<i4")
    assert points_cm.tolist() == [100, 310]  # 2.1 m ahead of a robot facing +y
    shown = page_data.pose_message(pose)
    assert shown["std_xy"] == 0.2 and shown["yaw"] == round(math.pi / 2, 4)


def test_the_info_says_whether_viewers_may_command_and_drive() -> None:
    local = VizSettings.from_config(NavdConfig())
    info = page_data.info_message(local)
    assert (info["commands"], info["teleop_enabled"]) == (True, True)
    assert info["footprint"] == {"kind": "circle", "radius": 0.2}
    quiet = NavdConfig.model_validate({"viz": {"commands": False}, "teleop": {"enabled": False}})
    info = page_data.info_message(VizSettings.from_config(quiet))
    assert (info["commands"], info["teleop_enabled"]) == (False, False)

"""Sensor mounts at the door: the real daemon on a real socket refuses a device it cannot
place, keeps two unplaced lidars apart, checks a ROS frame's frame_id against the mount,
and takes rosbridge lines."""

from __future__ import annotations

import json
import math

from navd.lifecycle.messages import DeviceStale, LaserScan, WheelOdometry
from navd.wire import ErrorFrame, Welcome
from tests.drivers.conftest import connected, hello, record, running_daemon, until

TWO_LIDARS = {"lidars": {"front": {"x_m": 0.2}, "rear": {"x_m": -0.2, "yaw_rad": 3.1416}}}
ROS_SCAN = {
    "header": {"stamp": {"sec": 10, "nanosec": 0}, "frame_id": "laser"},
    "angle_min": -1.0,
    "angle_max": 1.0,
    "angle_increment": 1.0,
    "range_min": 0.1,
    "range_max": 10.0,
    "ranges": [1.0, 2.0, 3.0],
}


def _line(message: dict[str, object]) -> bytes:
    return json.dumps(message).encode() + b"\n"


async def test_a_device_without_a_mount_is_refused_by_name_when_mounts_are_listed() -> None:
    async with running_daemon(mounts=TWO_LIDARS) as (_, port):
        side, refusal = await hello(port, "lidar", "side")
        assert isinstance(refusal, ErrorFrame) and refusal.fatal
        assert refusal.field == "device_id"
        assert "'side' has no mount" in refusal.reason
        assert "[mounts.lidars.side]" in refusal.reason and "front, rear" in refusal.reason
        front, welcome = await hello(port, "lidar", "front")
        assert isinstance(welcome, Welcome)
        rear, welcome = await hello(port, "lidar", "rear")
        assert isinstance(welcome, Welcome)
        # IMUs are not listed: any IMU is taken as aligned with base_link
        imu, welcome = await hello(port, "imu", "whatever-imu")
        assert isinstance(welcome, Welcome)
        for client in (side, front, rear, imu):
            await client.close()


async def test_a_second_lidar_without_mounts_is_refused_while_the_first_speaks() -> None:
    # (a lidar that has connected but sent nothing yet does not keep another out: a
    # program restarted under a new id while its old connection lingers)
    async with running_daemon(tcp={"lidar_timeout_s": 0.2}) as (daemon, port):
        stale = record(daemon, DeviceStale)
        first = await connected(port, "lidar", "lidar0")
        scans = record(daemon, LaserScan)
        first.send_raw(_line({"type": "scan", **ROS_SCAN}))
        await until(lambda: len(scans) == 1)
        second, refusal = await hello(port, "lidar", "lidar1")
        assert isinstance(refusal, ErrorFrame) and refusal.field == "device_id"
        assert "second lidar beside 'lidar0'" in refusal.reason
        assert "[mounts.lidars]" in refusal.reason
        await second.close()
        # once the first has fallen silent, another may take its place (a swapped lidar)
        await until(lambda: len(stale) == 1, 3.0)
        third, welcome = await hello(port, "lidar", "lidar1")
        assert isinstance(welcome, Welcome)
        for client in (first, third):
            await client.close()


async def test_two_lidars_connected_before_either_spoke_cannot_both_speak() -> None:
    async with running_daemon() as (daemon, port):
        scans = record(daemon, LaserScan)
        first = await connected(port, "lidar", "lidar0")
        second = await connected(port, "lidar", "lidar1")  # neither has spoken: both let in
        first.send_raw(_line({"type": "scan", **ROS_SCAN}))
        await until(lambda: len(scans) == 1)
        second.send_raw(_line({"type": "scan", **ROS_SCAN}))
        error = await second.receive(3.0)
        assert isinstance(error, ErrorFrame) and error.field == "device_id"
        assert "second lidar beside 'lidar0'" in error.reason
        assert [s.device_id for s in scans] == ["lidar0"]
        for client in (first, second):
            await client.close()


async def test_a_ros_frame_naming_another_frame_id_is_refused_by_name() -> None:
    mounts = {"lidars": {"front": {"x_m": 0.2, "frame_id": "front_laser"}}}
    async with running_daemon(mounts=mounts) as (daemon, port):
        scans = record(daemon, LaserScan)
        lidar = await connected(port, "lidar", "front")
        lidar.send_raw(_line({"type": "scan", **ROS_SCAN}))
        error = await lidar.receive(3.0)
        assert isinstance(error, ErrorFrame) and not error.fatal
        assert error.field == "header.frame_id"
        assert "'laser' is not front's frame ('front_laser')" in error.reason
        named = {**ROS_SCAN, "header": {**ROS_SCAN["header"], "frame_id": "front_laser"}}  # type: ignore[dict-item]
        lidar.send_raw(_line({"type": "scan", **named}))
        await until(lambda: len(scans) == 1)
        assert scans[0].device_id == "front" and scans[0].ranges.tolist() == [1.0, 2.0, 3.0]
        await lidar.close()


async def test_rosbridge_publish_lines_reach_the_bus() -> None:
    async with running_daemon() as (daemon, port):
        scans, odometry = record(daemon, LaserScan), record(daemon, WheelOdometry)
        lidar = await connected(port, "lidar", "lidar0")
        wheels = await connected(port, "wheel_odometry", "wheels")
        lidar.send_raw(_line({"op": "publish", "topic": "/scan", "msg": ROS_SCAN}))
        twist = {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0, "y": 0, "z": 0.1}}
        odom = {
            "header": {"stamp": {"sec": 10, "nanosec": 0}, "frame_id": "odom"},
            "child_frame_id": "base_link",
            "pose": {"pose": {}, "covariance": [0.0] * 36},
            "twist": {"twist": twist, "covariance": [0.0] * 36},
        }
        wheels.send_raw(_line({"op": "publish", "topic": "/odom", "msg": odom}))
        await until(lambda: len(scans) == 1 and len(odometry) == 1)
        assert scans[0].ranges.tolist() == [1.0, 2.0, 3.0]
        assert math.isclose(odometry[0].linear_mps, 0.3) and odometry[0].angular_radps == 0.1
        for client in (lidar, wheels):
            await client.close()

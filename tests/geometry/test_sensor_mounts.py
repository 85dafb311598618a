"""Sensor mounts by device id: which device may connect, and where each one sits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.geometry.errors import UnknownMountError
from navd.geometry.mount import LidarMount, SensorMounts, rotation_rpy
from navd.geometry.pose import Pose2


def _mounts(**mounts: object) -> SensorMounts:
    config = NavdConfig.model_validate({"mounts": mounts})
    return SensorMounts.of(config.mounts, config.lidar)


def test_without_mounts_every_device_is_placed_by_the_defaults() -> None:
    config = NavdConfig.model_validate({"lidar": {"x_m": 0.3, "min_range_m": 0.2}})
    mounts = SensorMounts.of(config.mounts, config.lidar)
    assert mounts.lidar("anything") == LidarMount(Pose2(0.3, 0.0, 0.0), 0.2)
    assert mounts.imu_rotation("imu0") is None
    assert mounts.gps_offset_m("gnss") == (0.0, 0.0)
    assert mounts.compass_yaw_rad("compass") == 0.0
    for role in ("lidar", "imu", "gps", "compass", "wheel_odometry", "control"):
        assert mounts.refusal(role, "x") is None
    assert mounts.frame_refusal("x", "any_frame") is None


def test_once_a_kind_has_mounts_only_its_listed_devices_may_connect() -> None:
    mounts = _mounts(lidars={"front": {"x_m": 0.2}, "rear": {"yaw_rad": 3.0}})
    assert mounts.lidar("front").pose == Pose2(0.2, 0.0, 0.0)
    assert mounts.refusal("lidar", "front") is None
    reason = mounts.refusal("lidar", "side")
    assert reason is not None and "[mounts.lidars.side]" in reason and "front, rear" in reason
    assert mounts.refusal("imu", "side") is None  # IMUs are not listed: any may come
    with pytest.raises(UnknownMountError, match=r"add \[mounts.lidars"):
        mounts.lidar("side")


def test_a_ros_frame_id_must_be_the_mounts_or_the_device_id() -> None:
    mounts = _mounts(lidars={"front": {"frame_id": "laser_front"}, "rear": {}})
    assert mounts.frame_refusal("front", "laser_front") is None
    assert "'laser' is not front's frame" in (mounts.frame_refusal("front", "laser") or "")
    assert mounts.frame_refusal("rear", "rear") is None  # the default: the device id
    assert mounts.frame_refusal("rear", "laser") is not None


def test_the_imu_rotation_takes_sensor_axes_into_base_link() -> None:
    # an IMU turned 90° to the left: its +x points along the robot's +y
    mounts = _mounts(imus={"imu0": {"yaw_rad": math.pi / 2}})
    rotation = mounts.imu_rotation("imu0")
    assert rotation is not None
    np.testing.assert_allclose(rotation @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-12)
    # upside down (rolled half a turn): gravity's +z reading becomes -z
    flipped = rotation_rpy(math.pi, 0.0, 0.0)
    np.testing.assert_allclose(flipped @ [0.0, 0.0, 9.8], [0.0, 0.0, -9.8], atol=1e-12)
    # a proper rotation, in any order of the three angles
    r = rotation_rpy(0.3, -0.7, 2.0)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("rpy", "sensor_axis", "base_axis"),
    [
        ((math.pi / 2, 0.0, 0.0), (0, 1, 0), (0, 0, 1)),  # rolled left: its +y points up
        ((0.0, math.pi / 2, 0.0), (1, 0, 0), (0, 0, -1)),  # pitched down: its +x points down
        ((0.0, 0.0, math.pi / 2), (1, 0, 0), (0, 1, 0)),  # yawed left: its +x points left
    ],
)
def test_each_mount_angle_turns_the_sensors_axes_as_ros_does(
    rpy: tuple[float, float, float], sensor_axis: tuple[int, ...], base_axis: tuple[int, ...]
) -> None:
    np.testing.assert_allclose(rotation_rpy(*rpy) @ sensor_axis, base_axis, atol=1e-12)


def test_mixed_angles_compose_as_fixed_axes_roll_then_pitch_then_yaw() -> None:
    from scipy.spatial.transform import Rotation

    rpy = (0.3, -0.7, 2.0)
    expected = Rotation.from_euler("xyz", rpy).as_matrix()  # extrinsic x, y, z: Rz Ry Rx
    np.testing.assert_allclose(rotation_rpy(*rpy), expected, atol=1e-12)

"""ROS 1 and ROS 2 bags: written here with the rosbags writers, read back by navd's reader."""

from __future__ import annotations

import gzip
import itertools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from navd.bench.synthetic_room import cast
from navd.cli import main
from navd.geometry import Pose2
from navd.offline.bags import inspect_bag, is_bag, read_bag
from navd.offline.errors import LogFormatError
from navd.offline.relations import read_tum
from tests.datasets import dataset

# The robot drives 1.5 m along x while turning a little; 10 scans at 5 Hz, odometry at 20 Hz
# starting earlier and ending later than the scans.
SCAN_STAMPS = [100.0 + 0.2 * i for i in range(10)]
ODOM_STAMPS = [99.9 + 0.05 * i for i in range(44)]


def _truth(stamp: float) -> Pose2:
    t = stamp - 100.0
    return Pose2(0.8 * t, 0.05 * t * t, 0.2 * t)


# base_link -> mast -> laser: the lidar sits 0.25 m ahead, 0.05 m left, turned by 0.1 rad.
MAST = Pose2(0.2, 0.05, 0.3)
LASER_ON_MAST = Pose2(0.05, 0.0, -0.2)
MOUNT = MAST.compose(LASER_ON_MAST)


def _typestore(store: Stores) -> Any:
    typestore = get_typestore(store)
    if "tf2_msgs/msg/TFMessage" not in typestore.types:  # the ROS 1 store lacks it
        typestore.register(
            get_types_from_msg(
                "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"
            )
        )
    return typestore


def _quaternion(ts: Any, yaw: float) -> Any:
    return ts.types["geometry_msgs/msg/Quaternion"](
        x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
    )


def _header(ts: Any, ros1: bool, stamp: float, frame: str) -> Any:
    sec = int(stamp)
    time = ts.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((stamp - sec) * 1e9))
    header = ts.types["std_msgs/msg/Header"]
    return header(seq=0, stamp=time, frame_id=frame) if ros1 else header(stamp=time, frame_id=frame)


def _messages(
    ts: Any, ros1: bool, scan_topics: tuple[str, ...], zero_stamps: bool = False
) -> list[tuple[str, str, float, Any]]:
    """(topic, type, stamp, message) of the whole recording, in time order; with
    ``zero_stamps`` the scan and odometry headers carry stamp 0 (the bag still records when
    each message came)."""

    def header_stamp(stamp: float) -> float:
        return 0.0 if zero_stamps else stamp

    t = ts.types
    out: list[tuple[str, str, float, Any]] = []
    transforms = [
        t["geometry_msgs/msg/TransformStamped"](
            header=_header(ts, ros1, 99.9, parent),
            child_frame_id=child,
            transform=t["geometry_msgs/msg/Transform"](
                translation=t["geometry_msgs/msg/Vector3"](x=pose.x, y=pose.y, z=0.3),
                rotation=_quaternion(ts, pose.yaw),
            ),
        )
        for parent, child, pose in (("base_link", "mast", MAST), ("mast", "laser", LASER_ON_MAST))
    ]
    tf = t["tf2_msgs/msg/TFMessage"](transforms=transforms)
    out.append(("/tf_static", "tf2_msgs/msg/TFMessage", 99.9, tf))
    for stamp in ODOM_STAMPS:
        pose = _truth(stamp)
        odom = t["nav_msgs/msg/Odometry"](
            header=_header(ts, ros1, header_stamp(stamp), "odom"),
            child_frame_id="base_link",
            pose=t["geometry_msgs/msg/PoseWithCovariance"](
                pose=t["geometry_msgs/msg/Pose"](
                    position=t["geometry_msgs/msg/Point"](x=pose.x, y=pose.y, z=0.0),
                    orientation=_quaternion(ts, pose.yaw),
                ),
                covariance=np.zeros(36),
            ),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](
                    linear=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                    angular=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                ),
                covariance=np.zeros(36),
            ),
        )
        out.append(("/odom", "nav_msgs/msg/Odometry", stamp, odom))
    for topic, stamp in itertools.product(scan_topics, SCAN_STAMPS):
        a0, inc, ranges = cast(_truth(stamp).compose(MOUNT), beams=90)
        ranges = ranges.astype(np.float32)
        ranges[3] = np.inf  # no return
        scan = t["sensor_msgs/msg/LaserScan"](
            header=_header(ts, ros1, header_stamp(stamp), "laser"),
            angle_min=a0,
            angle_max=a0 + inc * (ranges.size - 1),
            angle_increment=inc,
            time_increment=0.0,
            scan_time=0.2,
            range_min=0.1,
            range_max=12.0,
            ranges=ranges,
            intensities=np.zeros(0, dtype=np.float32),
        )
        out.append((topic, "sensor_msgs/msg/LaserScan", stamp, scan))
    return sorted(out, key=lambda m: m[2])


def write_bag(
    path: Path, *, ros1: bool, scan_topics: tuple[str, ...] = ("/scan",), zero_stamps: bool = False
) -> Path:
    ts = _typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    messages = _messages(ts, ros1, scan_topics, zero_stamps)
    writer: Any = Ros1Writer(path) if ros1 else Ros2Writer(path, version=9)
    with writer:
        connections = {}
        for topic, msgtype, _, _ in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=ts)
        for topic, msgtype, stamp, message in messages:
            data = (
                ts.serialize_ros1(message, msgtype) if ros1 else ts.serialize_cdr(message, msgtype)
            )
            writer.write(connections[topic], int(stamp * 1e9), data)
    return path


@pytest.mark.parametrize("ros1", [True, False], ids=["ros1", "ros2"])
def test_a_bag_gives_its_scans_odometry_at_their_stamps_and_the_mount(
    tmp_path: Path, ros1: bool
) -> None:
    bag = write_bag(tmp_path / ("drive.bag" if ros1 else "drive"), ros1=ros1)
    assert is_bag(bag)
    log = inspect_bag(bag)
    assert (log.scan_topic, log.odom_topic, log.scans) == ("/scan", "/odom", 10)
    assert log.mount is not None  # composed through the mast frame
    assert (log.mount.x, log.mount.y, log.mount.yaw) == pytest.approx(
        (MOUNT.x, MOUNT.y, MOUNT.yaw), abs=1e-9
    )
    scans = list(read_bag(log))
    assert [s.stamp for s in scans] == pytest.approx(SCAN_STAMPS, abs=1e-9)
    for scan in scans:
        a0, inc, ranges = cast(_truth(scan.stamp).compose(MOUNT), beams=90)
        assert (scan.angle_min, scan.angle_increment) == pytest.approx((a0, inc))
        assert (scan.range_min, scan.range_max) == pytest.approx((0.1, 12.0))
        assert scan.ranges.dtype == np.float64 and np.isinf(scan.ranges[3])
        assert np.allclose(np.delete(scan.ranges, 3), np.delete(ranges, 3), atol=1e-5)
        # interpolated between the 20 Hz odometry samples around the stamp
        truth, odom = _truth(scan.stamp), scan.odom
        assert odom is not None
        assert math.hypot(odom.x - truth.x, odom.y - truth.y) < 1e-3
        assert abs(odom.yaw - truth.yaw) < 1e-3


@pytest.mark.parametrize("ros1", [True, False], ids=["ros1", "ros2"])
def test_zero_header_stamps_fall_back_to_the_time_the_bag_received_them(
    tmp_path: Path, ros1: bool
) -> None:
    bag = write_bag(tmp_path / ("drive.bag" if ros1 else "drive"), ros1=ros1, zero_stamps=True)
    scans = list(read_bag(inspect_bag(bag)))
    assert [s.stamp for s in scans] == pytest.approx(SCAN_STAMPS, abs=1e-6)
    for scan in scans:
        truth, odom = _truth(scan.stamp), scan.odom
        assert odom is not None
        assert math.hypot(odom.x - truth.x, odom.y - truth.y) < 1e-3


def test_replay_reads_a_bag_and_uses_its_mount(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = write_bag(tmp_path / "drive.bag", ros1=True)
    out = tmp_path / "out"
    assert main(["replay", str(bag), "--out", str(out), "--quiet"]) == 0
    assert json.loads(capsys.readouterr().out)["scans"] == 10
    _, poses = read_tum(out / "trajectory.tum")
    # the track is the robot base's: right only if the mast and laser offsets were applied
    errors = [
        math.hypot(p.x - _truth(s).x, p.y - _truth(s).y)
        for p, s in zip(poses, SCAN_STAMPS, strict=True)
    ]
    assert max(errors) < 0.05


def test_several_laser_topics_must_be_chosen_by_name(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "two.bag", ros1=True, scan_topics=("/front", "/rear"))
    with pytest.raises(LogFormatError, match=r"2 sensor_msgs/msg/LaserScan topics.*--scan-topic"):
        inspect_bag(bag)
    assert inspect_bag(bag, scan_topic="/rear").scans == 10
    with pytest.raises(LogFormatError, match=r"--scan-topic /side: no such topic.*/front"):
        inspect_bag(bag, scan_topic="/side")
    with pytest.raises(LogFormatError, match=r"--odom-topic /front: is sensor_msgs/msg/LaserScan"):
        inspect_bag(bag, scan_topic="/rear", odom_topic="/front")


def test_a_file_that_is_not_a_bag_is_refused_by_name(tmp_path: Path) -> None:
    fake = tmp_path / "broken.bag"
    fake.write_bytes(b"#ROSBAG V2.0\nnot really")
    with pytest.raises(LogFormatError, match=r"broken\.bag: not a readable ROS bag"):
        inspect_bag(fake)
    with pytest.raises(LogFormatError, match=r"missing\.bag: no such file"):
        inspect_bag(tmp_path / "missing.bag")


def test_the_freiburg_bag_matches_its_text_dump_and_gives_the_laser_offset() -> None:
    freiburg = dataset("freiburg_slam_benchmark")
    log = inspect_bag(freiburg / "bags_ros1" / "fr-clinic_robotlaser.orig.bag")
    assert (log.scan_topic, log.odom_topic, log.scans) == ("/scan", "/odom", 6917)
    assert log.mount == Pose2(0.22, 0.0, 0.0)  # the README's base_link -> laser
    with gzip.open(freiburg / "derived_txt" / "fr-clinic_scans.txt.gz", "rt") as dump:
        lines = (line.split() for line in dump if not line.startswith("#"))
        for scan, words in itertools.islice(zip(read_bag(log), lines, strict=False), 300):
            assert scan.stamp == pytest.approx(float(words[0]), abs=1e-6)
            assert np.allclose(scan.ranges, np.array(words[6:], dtype=float), atol=6e-4)

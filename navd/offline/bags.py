"""ROS 1 and ROS 2 bags for replay, read with the ``rosbags`` package (no ROS installation).

The laser topic is the one of type sensor_msgs/LaserScan (or the one named), the odometry the
one of type nav_msgs/Odometry (or the one named; a bag without one replays without a motion
prior). The lidar's mounting pose on the robot comes from the bag's static transforms when they
link the odometry's child frame (the robot base) to the scans' frame. Message definitions are
taken from the bag itself, so custom builds of common messages read too.
"""

from __future__ import annotations

import contextlib
import math
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from navd.geometry import Pose2
from navd.offline.errors import LogFormatError
from navd.offline.logfiles import LogScan, OdometryTrack

__all__ = ["BagLog", "inspect_bag", "is_bag", "read_bag"]

SCAN_TYPE = "sensor_msgs/msg/LaserScan"
ODOM_TYPE = "nav_msgs/msg/Odometry"
TF_TYPE = "tf2_msgs/msg/TFMessage"
ROS2_FILES = (".db3", ".mcap")


@dataclass(frozen=True, slots=True)
class BagLog:
    """What replay needs to know about a bag before reading it.

    Attributes:
        path: the ROS 1 ``.bag`` file or the ROS 2 bag folder.
        scan_topic: the laser topic read.
        odom_topic: the odometry topic read, or None (the bag has none).
        scans: messages on the laser topic.
        mount: the lidar's pose on the robot from the bag's static transforms, or None.
    """

    path: Path
    scan_topic: str
    odom_topic: str | None
    scans: int
    mount: Pose2 | None


# What a bag damaged in its bytes raises while it is read: the readers' own errors, the
# decompressor's, the message parser's asserts and index errors, a record cut short.
DAMAGE: tuple[type[Exception], ...] = (
    OSError,
    EOFError,
    ValueError,
    KeyError,
    IndexError,
    AssertionError,
    struct.error,
)


def _damage() -> tuple[type[Exception], ...]:
    """DAMAGE and the rosbags readers' error types (imported only when a bag is read)."""
    from rosbags.highlevel import AnyReaderError  # noqa: PLC0415 - replay only
    from rosbags.rosbag1 import ReaderError as Rosbag1Error  # noqa: PLC0415
    from rosbags.rosbag2 import ReaderError as Rosbag2Error  # noqa: PLC0415
    from rosbags.serde import SerdeError  # noqa: PLC0415

    return (*DAMAGE, AnyReaderError, Rosbag1Error, Rosbag2Error, SerdeError)


def is_bag(path: Path) -> bool:
    """True for a ROS 1 ``.bag`` file, a ROS 2 bag folder or a file inside one."""
    if path.suffix == ".bag":
        return True
    if path.is_dir():
        return (path / "metadata.yaml").exists()
    return path.suffix in ROS2_FILES


def inspect_bag(
    path: Path, *, scan_topic: str | None = None, odom_topic: str | None = None
) -> BagLog:
    """Find the laser and odometry topics and the lidar mount of the bag at ``path``.

    Raises:
        LogFormatError: the bag cannot be read, has no laser topic, has several and none was
            chosen, or a chosen topic is missing or of another type (topics named).
    """
    try:
        with _reader(path) as reader:
            connections = reader.connections
            scan = _pick(connections, SCAN_TYPE, scan_topic, "--scan-topic")
            if scan is None:
                every = sorted({f"{c.topic} ({c.msgtype})" for c in connections})
                raise LogFormatError(f"{path}: no {SCAN_TYPE} topic; the bag has {every or 'none'}")
            odom = _pick(connections, ODOM_TYPE, odom_topic, "--odom-topic")
            scans = sum(c.msgcount for c in connections if c.topic == scan)
            mount = _mount(reader, scan, odom) if scans else None
    except _damage() as err:
        raise LogFormatError(f"{path}: damaged ({type(err).__name__}: {err})") from err
    return BagLog(_bag_path(path), scan, odom, scans, mount)


def read_bag(log: BagLog) -> Iterator[LogScan]:
    """The scans of ``log`` in time order, each with the odometry pose at its stamp.

    Stamps are the messages' header stamps; a zero header stamp falls back to the time the bag
    received the message.

    Raises:
        LogFormatError: the bag is damaged (cut short, bytes overwritten), named with the
            scans read before the damage.
    """
    read = 0
    try:
        with _reader(log.path) as reader:
            track = _odometry(reader, log.odom_topic)
            wanted = [c for c in reader.connections if c.topic == log.scan_topic]
            for connection, received_ns, raw in reader.messages(connections=wanted):
                msg = reader.deserialize(raw, connection.msgtype)
                stamp = _stamp(msg.header.stamp, received_ns)
                read += 1
                yield LogScan(
                    stamp,
                    float(msg.angle_min),
                    float(msg.angle_increment),
                    float(msg.range_min),
                    float(msg.range_max),
                    np.asarray(msg.ranges, dtype=np.float64),
                    track.at(stamp),
                )
    except _damage() as err:
        raise LogFormatError(
            f"{log.path}: damaged after {read} scans ({type(err).__name__}: {err})"
        ) from err


# --- helpers ----------------------------------------------------------------------------


def _bag_path(path: Path) -> Path:
    """A ROS 2 bag is read through its folder."""
    return path.parent if path.suffix in ROS2_FILES else path


def _reader(path: Path) -> contextlib.closing[Any]:
    """The bag at ``path`` opened, closed when the ``with`` block ends."""
    from rosbags.highlevel import AnyReader, AnyReaderError  # noqa: PLC0415 - replay only

    bag = _bag_path(path)
    if not bag.exists():
        raise LogFormatError(f"{path}: no such file or folder")
    try:
        reader = AnyReader([bag])
        reader.open()
    except (AnyReaderError, OSError, ValueError, KeyError) as err:
        raise LogFormatError(f"{path}: not a readable ROS bag: {err}") from err
    return contextlib.closing(reader)


def _pick(connections: list[Any], msgtype: str, chosen: str | None, option: str) -> str | None:
    """The topic of ``msgtype``: ``chosen`` (checked), else the only one, else None."""
    topics = sorted({c.topic for c in connections if c.msgtype == msgtype})
    if chosen is not None:
        types = {c.msgtype for c in connections if c.topic == chosen}
        if not types:
            raise LogFormatError(
                f"{option} {chosen}: no such topic; the bag's {msgtype} topics: {topics or 'none'}"
            )
        if msgtype not in types:
            raise LogFormatError(f"{option} {chosen}: is {sorted(types)[0]}, not {msgtype}")
        return chosen
    if len(topics) > 1:
        raise LogFormatError(
            f"the bag has {len(topics)} {msgtype} topics {topics}; choose one with {option}"
        )
    only: str | None = topics[0] if topics else None
    return only


def _stamp(header_stamp: Any, received_ns: int) -> float:
    """[s] a message's header stamp, or the time the bag received it when the header's is zero
    (some drivers never fill it in)."""
    if header_stamp.sec == 0 and header_stamp.nanosec == 0:
        return 1e-9 * received_ns
    return float(header_stamp.sec) + 1e-9 * float(header_stamp.nanosec)


def _yaw(q: Any) -> float:
    """Rotation about z of a quaternion (its roll and pitch are taken as zero)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _odometry(reader: Any, topic: str | None) -> OdometryTrack:
    stamps: list[float] = []
    poses: list[Pose2] = []
    if topic is not None:
        wanted = [c for c in reader.connections if c.topic == topic]
        for connection, received_ns, raw in reader.messages(connections=wanted):
            msg = reader.deserialize(raw, connection.msgtype)
            pose = msg.pose.pose
            stamps.append(_stamp(msg.header.stamp, received_ns))
            poses.append(Pose2(pose.position.x, pose.position.y, _yaw(pose.orientation)))
    order = np.argsort(stamps, kind="stable")  # bags are in receive order, not stamp order
    return OdometryTrack([stamps[i] for i in order], [poses[i] for i in order])


def _first(reader: Any, topic: str | None) -> Any:
    """The first message on ``topic`` (None if it has none)."""
    wanted = [c for c in reader.connections if c.topic == topic]
    for connection, _, raw in reader.messages(connections=wanted):
        return reader.deserialize(raw, connection.msgtype)
    return None


def _mount(reader: Any, scan_topic: str, odom_topic: str | None) -> Pose2 | None:
    """The laser frame in the robot base frame, composed from the static transforms."""
    scan = _first(reader, scan_topic)
    odom = _first(reader, odom_topic) if odom_topic is not None else None
    base = None if odom is None else odom.child_frame_id.lstrip("/")
    parents: dict[str, tuple[str, Pose2]] = {}
    statics = [c for c in reader.connections if c.msgtype == TF_TYPE and c.topic == "/tf_static"]
    for connection, _, raw in reader.messages(connections=statics):
        for t in reader.deserialize(raw, connection.msgtype).transforms:
            offset = t.transform.translation
            pose = Pose2(offset.x, offset.y, _yaw(t.transform.rotation))
            parents[t.child_frame_id.lstrip("/")] = (t.header.frame_id.lstrip("/"), pose)
    frame = scan.header.frame_id.lstrip("/")
    mount = Pose2(0.0, 0.0, 0.0)
    while frame != base and frame in parents:
        frame, step = parents[frame]
        mount = step.compose(mount)
    return mount if base is not None and frame == base else None

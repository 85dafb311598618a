"""Recording to files: every message reaches the disk in order, files rotate by size, the
oldest go past the budget, and a file cut mid-write reads back to its last whole chunk."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
import pytest

from navd.lifecycle.messages import Goal, LaserScan, PoseEstimate
from navd.lifecycle.messages import Path as Route
from navd.viz import recording_writer
from navd.viz.record_codec import topic_of
from navd.viz.recording_reader import RecordingError, read_recording
from navd.viz.recording_writer import (
    RecordingWriter,
    WriterSettings,
    recording_files,
    session_of,
)

SCAN_TOPIC = topic_of(LaserScan)
CONFIG = b'{"robot": {"name": "test"}}'
HEADER = {"began_s": 12.0, "had_map": False}


def scan(i: int) -> LaserScan:
    # seeded noise: the scans do not compress away, so sizes grow as on a robot
    ranges = np.random.default_rng(i).uniform(0.2, 8.0, 720).astype(np.float32)
    return LaserScan(
        stamp=i * 0.1,
        received=i * 0.1 + 0.001,
        device_id="front",
        angle_min=-np.pi,
        angle_increment=2 * np.pi / 720,
        ranges=ranges,
        range_min=0.1,
        range_max=12.0,
    )


def write(folder: Path, count: int, **settings: float) -> RecordingWriter:
    options = {"max_file_bytes": 10**9, "budget_bytes": 10**10, "flush_period_s": 0.02}
    options.update(settings)
    failures: list[str] = []
    writer = RecordingWriter(
        WriterSettings(
            folder,
            int(options["max_file_bytes"]),
            int(options["budget_bytes"]),
            options["flush_period_s"],
        ),
        CONFIG,
        HEADER,
        failures.append,
    )
    for i in range(count):
        assert SCAN_TOPIC is not None
        writer.put(SCAN_TOPIC, scan(i), i * 100_000_000)
        if i % 20 == 19:
            time.sleep(0.03)  # the writer flushes meanwhile, as on a robot
    writer.close()
    assert not failures
    return writer


def test_every_message_is_read_back_in_order_with_the_config(tmp_path: Path) -> None:
    writer = write(tmp_path, 120)
    recording = read_recording(tmp_path)
    assert writer.written == 120 and writer.dropped == 0
    assert recording.config == {"robot": {"name": "test"}}
    assert [m.stamp for _, m in recording.messages()] == [i * 0.1 for i in range(120)]
    np.testing.assert_array_equal(list(recording.messages())[7][1].ranges, scan(7).ranges)
    assert not recording.cut_short


def test_files_rotate_by_size_and_the_oldest_go_past_the_budget(tmp_path: Path) -> None:
    writer = write(tmp_path, 600, max_file_bytes=300_000, budget_bytes=1_000_000)
    files = recording_files(tmp_path)
    assert writer.files_deleted > 0 and len(files) >= 2
    assert sum(f.stat().st_size for f in files) <= 1_000_000 + 300_000  # the budget, plus
    # the overshoot of the file being written past its size at its last flush
    recording = read_recording(tmp_path)
    stamps = [m.stamp for _, m in recording.messages()]
    assert stamps == sorted(stamps) and stamps[-1] == pytest.approx(59.9)  # the newest kept
    assert stamps[0] > 0.0  # the oldest file is gone
    for file in files:  # each file replays on its own: it starts with the config
        assert read_recording(file).config == {"robot": {"name": "test"}}


def test_a_file_cut_mid_write_reads_to_its_last_whole_chunk(tmp_path: Path) -> None:
    write(tmp_path / "whole", 100)
    (whole,) = recording_files(tmp_path / "whole")
    data = whole.read_bytes()
    cut = tmp_path / "cut" / whole.name
    cut.parent.mkdir()
    cut.write_bytes(data[: len(data) * 2 // 3])  # a kill -9 mid-chunk
    recording = read_recording(cut)
    stamps = [m.stamp for _, m in recording.messages()]
    assert recording.cut_short == [cut]
    assert 10 <= len(stamps) < 100 and stamps == [i * 0.1 for i in range(len(stamps))]


def test_a_flood_beyond_the_queue_drops_the_oldest_and_counts_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(recording_writer, "MAX_QUEUED", 50)
    writer = RecordingWriter(WriterSettings(tmp_path, 10**9, 10**10, 30.0), CONFIG, HEADER, print)
    for i in range(80):  # the writer sleeps 30 s between flushes: all of these wait
        assert SCAN_TOPIC is not None
        writer.put(SCAN_TOPIC, scan(i), i)
    writer.close()
    assert writer.dropped == 30
    stamps = [m.stamp for _, m in read_recording(tmp_path).messages()]
    assert stamps == [i * 0.1 for i in range(30, 80)]


def test_what_is_not_a_recording_is_named(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match=r"no \.mcap recordings"):
        read_recording(tmp_path)
    with pytest.raises(RecordingError, match="does not exist"):
        read_recording(tmp_path / "gone.mcap")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"this is not mcap at all")
    with pytest.raises(RecordingError, match="not an MCAP file"):
        read_recording(junk)


def test_sessions_share_a_folder_without_mixing(tmp_path: Path) -> None:
    first = write(tmp_path, 30)
    second = write(tmp_path, 20)  # begun within the same second: a session of its own
    assert first.session != second.session
    with pytest.raises(RecordingError, match="2 sessions") as refused:
        read_recording(tmp_path)
    assert first.session in str(refused.value) and second.session in str(refused.value)
    one = read_recording(tmp_path, second.session)
    assert one.header["session"] == second.session and one.header["began_s"] == 12.0
    assert len(list(one.messages())) == 20
    assert session_of(first.file) == first.session
    with pytest.raises(RecordingError, match="no session 'nope'"):
        read_recording(tmp_path, "nope")


def test_a_recording_holds_what_a_viewer_draws_in_foxglove_schemas(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    from tests.viz.foxglove_client import protobuf_class
    from tests.viz.test_node import map_update

    failures: list[str] = []
    settings = WriterSettings(tmp_path, 10**9, 10**10, 0.02)
    writer = RecordingWriter(settings, CONFIG, HEADER, failures.append)
    wall_ns = 1_800_000_000 * 10**9  # the daemon's clock reads 10 s at this wall time
    pose = PoseEstimate(
        stamp=10.0, received=10.0, x_m=1.0, y_m=2.0, yaw_rad=0.5, covariance=np.eye(3) * 0.01
    )
    route = Route(
        stamp=10.0, received=10.0, goal_id="g", points_m=np.array([[1.0, 2.0], [3.0, 2.0]])
    )
    goal = Goal(stamp=10.0, received=10.0, goal_id="g", x_m=3.0, y_m=2.0)
    sent = scan(100)
    sent = dataclasses.replace(sent, stamp=9.99, received=10.0)
    for message in (sent, pose, map_update(10.0), route, goal):
        writer.put(f"/navd/x/{type(message).__name__}", message, wall_ns)
    writer.close()
    assert not failures
    (file,) = sorted(tmp_path.glob("*.mcap"))
    with file.open("rb") as stream:
        reader = make_reader(stream)
        shown = {
            channel.topic: (schema.name if schema else None, schema, message)
            for schema, channel, message in reader.iter_messages()
            if not channel.topic.startswith("/navd/")
        }
    assert {topic: name for topic, (name, _, _) in shown.items()} == {
        "/scan": "foxglove.LaserScan",
        "/tf": "foxglove.FrameTransforms",
        "/pose": "foxglove.PoseInFrame",
        "/map": "foxglove.Grid",
        "/route": "foxglove.SceneUpdate",
        "/goal": "foxglove.SceneUpdate",
    }
    _, schema, record = shown["/scan"]
    decoded = protobuf_class(schema.name, schema.data).FromString(record.data)
    np.testing.assert_allclose(decoded.ranges, sent.ranges, rtol=1e-6)
    assert decoded.frame_id == "base_link" and record.log_time == wall_ns  # placed at its mount
    # stamped on the wall clock: the scan 10 ms before its arrival
    stamp_ns = decoded.timestamp.seconds * 10**9 + decoded.timestamp.nanos
    assert abs(stamp_ns - (wall_ns - 10_000_000)) < 1_000  # within a float's rounding
    _, schema, record = shown["/pose"]
    where = protobuf_class(schema.name, schema.data).FromString(record.data)
    assert (where.frame_id, where.pose.position.x, where.pose.position.y) == ("map", 1.0, 2.0)

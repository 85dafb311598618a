"""The recorder in a running daemon: a control client starts and stops it, what the bus
carries reaches the file, and a folder it cannot write leaves the daemon driving."""

from __future__ import annotations

import asyncio
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.lifecycle.messages import (
    ConfigChange,
    Goal,
    InitialPose,
    MapUpdate,
    PoseEstimate,
    RecordingState,
)
from navd.viz.recording_reader import read_recording
from navd.wire import AsyncClient, ConfigFrame, GoalFrame, RecordFrame
from tests.drivers.conftest import connected, record, running_daemon, until

TOKEN = "a-token-for-the-test"


async def test_a_client_starts_and_stops_a_recording_of_inputs_and_outputs(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "rec"
    async with running_daemon(record={"dir": str(folder)}, tcp={"token": TOKEN}) as (
        daemon,
        port,
    ):
        states = record(daemon, RecordingState)
        control = await AsyncClient.connect(
            "127.0.0.1", port, role="control", device_id="ui", token=TOKEN
        )
        await control.request(RecordFrame(action="start"))
        await until(lambda: bool(states) and states[-1].active, timeout_s=5.0)
        await control.request(GoalFrame(x=2.0, y=1.0, goal_id="g1"))
        # a secret sent in a config change (refused: a restart key) is not kept either
        await control.request(
            ConfigFrame(changes={"tcp.token": "a-secret-sent-by-mistake", "tcp": {"token": "x"}})
        )
        now = daemon.clock.now()
        daemon.bus.publish(
            PoseEstimate(
                stamp=now, received=now, x_m=0.5, y_m=0.0, yaw_rad=0.0, covariance=np.eye(3) * 0.01
            )
        )
        await asyncio.sleep(0.1)
        await control.request(RecordFrame(action="stop"))
        await until(lambda: not states[-1].active, timeout_s=5.0)
        await control.close()
    file = Path(states[0].file)
    assert file.parent == folder and "stopped by ui" in states[-1].reason
    recording = read_recording(file)
    goals = [m for t, m in recording.messages() if isinstance(m, Goal)]
    poses = [m for t, m in recording.messages() if isinstance(m, PoseEstimate)]
    assert [(g.goal_id, g.x_m, g.y_m) for g in goals] == [("g1", 2.0, 1.0)]
    assert any(p.x_m == 0.5 for p in poses)
    assert recording.config is not None
    assert recording.config["tcp"]["token"] == "<redacted>"  # the secret is never recorded
    (change,) = [m for t, m in recording.messages() if isinstance(m, ConfigChange)]
    assert dict(change.changes) == {"tcp.token": "<redacted>", "tcp": {"token": "<redacted>"}}


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write any folder")
async def test_a_folder_it_cannot_write_is_said_and_the_daemon_drives_on(
    tmp_path: Path,
) -> None:
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    await _unwritable(locked / "rec")


async def test_a_file_in_the_way_of_the_folder_is_said_and_the_daemon_drives_on(
    tmp_path: Path,
) -> None:
    blocker = tmp_path / "rec"
    blocker.write_text("a file, not a folder")
    await _unwritable(blocker)


async def _unwritable(folder: Path) -> None:
    async with running_daemon(record={"dir": str(folder), "enabled": True}) as (daemon, port):
        states = record(daemon, RecordingState)
        control = await connected(port, "control", "ui")
        await control.request(RecordFrame(action="start"))
        await until(lambda: bool(states), timeout_s=5.0)
        assert not states[-1].active and str(folder) in states[-1].reason
        assert daemon.manager.states["recorder"].value == "active"
        await control.request(GoalFrame(x=1.0, y=0.0))  # still taking requests
        await control.close()


async def test_a_recording_begun_mid_run_starts_from_what_the_daemon_knew(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "rec"
    async with running_daemon(record={"dir": str(folder)}) as (daemon, port):
        states = record(daemon, RecordingState)
        now = daemon.clock.now()
        daemon.bus.publish(
            PoseEstimate(
                stamp=now,
                received=now,
                x_m=3.0,
                y_m=-1.0,
                yaw_rad=-3.1,
                covariance=np.diag([0.04, 0.01, 0.0025]),
            )
        )
        cells = np.zeros((4, 5), dtype=np.int8)
        daemon.bus.publish(
            MapUpdate(
                stamp=now,
                received=now,
                revision=7,
                resolution_m=0.05,
                origin_x_m=0.0,
                origin_y_m=0.0,
                occupancy=cells,
            )
        )
        control = await connected(port, "control", "ui")
        await control.request(RecordFrame(action="start"))
        await until(lambda: bool(states) and states[-1].active, timeout_s=5.0)
        await control.request(RecordFrame(action="stop"))
        await until(lambda: not states[-1].active, timeout_s=5.0)
        await control.close()
    recording = read_recording(folder)
    assert recording.header["had_map"] and recording.header["seeded_pose"]
    messages = list(recording.messages())
    seed = messages[0][1]
    assert isinstance(seed, InitialPose) and messages[0][0] == "/navd/in/InitialPose"
    assert (seed.x_m, seed.y_m, seed.yaw_rad) == (3.0, -1.0, -3.1)
    assert seed.std_xy_m == pytest.approx(0.2) and seed.std_yaw_rad == pytest.approx(0.05)
    known = messages[1][1]
    assert isinstance(known, MapUpdate) and known.revision == 7


async def test_what_comes_while_the_writer_is_set_up_is_recorded_too(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from navd.viz import recorder

    class SlowWriter(recorder.RecordingWriter):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            time.sleep(0.3)  # a slow disk: the folder and the first file take a while
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(recorder, "RecordingWriter", SlowWriter)
    folder = tmp_path / "rec"
    async with running_daemon(record={"dir": str(folder)}) as (daemon, port):
        states = record(daemon, RecordingState)
        control = await connected(port, "control", "ui")
        control.send(RecordFrame(action="start"))
        await control.request(GoalFrame(x=1.0, y=2.0, goal_id="early"))  # during the set-up
        await until(lambda: bool(states) and states[-1].active, timeout_s=5.0)
        await control.request(RecordFrame(action="stop"))
        await until(lambda: not states[-1].active, timeout_s=5.0)
        await control.close()
    goals = [m for _, m in read_recording(folder).messages() if isinstance(m, Goal)]
    assert [g.goal_id for g in goals] == ["early"]

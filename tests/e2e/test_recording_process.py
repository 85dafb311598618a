"""Recording and replaying real runs: ``navd demo --record`` then ``navd replay`` gives the
same map and route; a daemon killed with SIGKILL mid-drive leaves a recording that opens
and replays up to its last chunk."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from navd.app import build_modules
from navd.sim import from_shapes, session
from navd.viz import play, read_recording, recording_files
from tests.e2e.test_scenarios import HALL, start

pytestmark = pytest.mark.e2e


def navd(*args: str, timeout_s: float = 300.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "navd", *args],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )


def test_a_recorded_demo_replays_to_the_same_map_and_route(tmp_path: Path) -> None:
    demo = navd("demo", "--out", str(tmp_path / "demo"), "--record", str(tmp_path / "rec"))
    assert demo.returncode == 0, demo.stderr[-2000:]
    assert json.loads(demo.stdout)["reached"]
    replay = navd("replay", str(tmp_path / "rec"), "--out", str(tmp_path / "replay"))
    assert replay.returncode == 0, replay.stderr[-2000:]
    report = json.loads((tmp_path / "replay" / "playback.json").read_text())
    assert report == json.loads(replay.stdout)
    assert report["inputs"] > 1000 and not report["cut_short"]
    assert report["map_iou"] >= 0.95
    assert report["goals"]["demo"] == ["reached", "reached"]
    route = report["routes"]["demo"]
    assert route["apart_m"] <= 0.1
    assert route["replayed_length_m"] == pytest.approx(route["recorded_length_m"], abs=0.1)
    assert report["pose_error_m"][0] <= 0.05  # median [m]


async def test_a_recording_cut_by_sigkill_opens_and_replays_to_its_last_chunk(
    tmp_path: Path,
) -> None:
    world = from_shapes(HALL, "hall")
    folder = tmp_path / "rec"
    overrides = {"record": {"enabled": True, "dir": str(folder), "flush_period_s": 0.5}}
    async with session(world, tmp_path / "run", overrides=overrides) as s:
        await start(s, world)
        await asyncio.sleep(6.0)  # part of the way, in real time
        os.kill(s.daemon.pid, signal.SIGKILL)
        await s.daemon.wait()
        poses_at_kill = s.sim.truth[-1]
    (file,) = recording_files(folder)
    recording = read_recording(file)
    poses = [m for t, m in recording.messages() if t == "/navd/out/PoseEstimate"]
    assert len(poses) > 20
    assert recording.cut_short == [file]  # no end: the writer never closed it
    report = await play(read_recording(file), build_modules, tmp_path / "replay")
    assert report.inputs > 100 and report.cut_short == [str(file)]
    # on real time the replay's inputs keep their instants but not the live run's timing
    # of work, so poses agree closely, not exactly
    assert report.pose_error_m is not None and report.pose_error_m[0] <= 0.05
    assert poses_at_kill[1] > 0.5  # the robot had moved


def test_replaying_a_file_that_is_not_there_says_so_with_or_without_out(tmp_path: Path) -> None:
    # Without --out it was called "not a navd recording", which sends a user looking at the
    # file's format rather than its path.
    missing = tmp_path / "drive.mcap"
    for extra in ((), ("--out", str(tmp_path / "out"))):
        result = navd("replay", str(missing), *extra, timeout_s=60.0)
        assert result.returncode == 2
        assert result.stderr.strip() == f"navd replay: {missing}: no such file or folder"


def test_record_start_and_stop_say_which_file(daemon_on_port: Any, tmp_path: Path) -> None:
    folder = tmp_path / "recordings"
    _, port = daemon_on_port(f'[record]\ndir = "{folder}"\n')
    at = ("--port", str(port))
    idle = navd("record", "stop", *at, timeout_s=30.0)
    assert (idle.returncode, idle.stdout.strip()) == (0, "was not recording")
    started = navd("record", "start", *at, timeout_s=30.0)
    assert started.returncode == 0, started.stderr
    assert started.stdout.startswith(f"recording to {folder}")
    file = started.stdout.strip().removeprefix("recording to ")
    again = navd("record", "start", *at, timeout_s=30.0)
    assert (again.returncode, again.stdout.strip()) == (0, f"already recording to {file}")
    stopped = navd("record", "stop", *at, timeout_s=30.0)
    assert (stopped.returncode, stopped.stdout.strip()) == (0, f"recording stopped: {file}")
    assert Path(file) in recording_files(folder)
